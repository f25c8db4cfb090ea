"""Medians over the turns of run.sh's runs.csv: ms a step per substage of the solve."""
import csv
import statistics
import sys

rows = list(csv.DictReader(open(sys.argv[1])))
keys = ['solve_ms', 'build_ms', 'warm_start_ms', 'sweeps_ms', 'integrate_ms']
configs = list(dict.fromkeys(r['config'] for r in rows))
base = statistics.median(float(r['solve_ms']) for r in rows if r['config'] == configs[0])
print('| config | ' + ' | '.join(k[:-3] for k in keys) + ' | solve / default | turns |')
print('|' + '---|' * (len(keys) + 3))
for c in configs:
    rs = [r for r in rows if r['config'] == c]
    med = [statistics.median(float(r[k]) for r in rs) for k in keys]
    print(f'| {c} | ' + ' | '.join(f'{m:.2f}' for m in med) + f' | {med[0] / base:.3f} | {len(rs)} |')
