#!/usr/bin/env bash
# ctest cases for the batch jobs (jobs/slurm/parode.sbatch, jobs/pbs/parode.pbs
# and jobs/batch/chain.sh), without a scheduler: dry runs print the launch and
# resubmission commands; with parode_stub.sh as parode and a recorder as
# sbatch/qsub, a SIGTERM to the job script (what --signal=B:TERM does) must
# reach the run and lead to a resubmission with RESTART, a restart segment
# must run the remaining steps from the previous checkpoint, failures must
# not resubmit, and the PBS timer must stop a real mpirun run before the
# wall time. Usage: tests/jobs/test_batch_jobs.sh CASE   (CASE: see the end)
# Trade-off: the scheduler commands are recorded rather than run, so what is
# tested is what the scripts ask of Slurm and PBS, not Slurm and PBS.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$ROOT"
WORK="$(mktemp -d)"
cleanup() {  # a stub left running by a failed case
  [ ! -f "$WORK/stub.log.pid" ] || kill -KILL "$(cat "$WORK/stub.log.pid")" 2>/dev/null || true
  rm -rf "$WORK"
}
trap cleanup EXIT
export SCENE=jobs/scenes/tennis.toml STEPS=1000 OUT="$WORK/out" PARODE="$ROOT/tests/jobs/parode_stub.sh"
export STUB_LOG="$WORK/stub.log" SUBMIT_CMD="$WORK/submit" SLURM_JOB_ID=4242 PBS_JOBID=77.pbs
printf '#!/bin/sh\necho "$*" >>"%s/submitted"\n' "$WORK" >"$WORK/submit"
chmod +x "$WORK/submit"
fail() { echo "FAIL: $*" >&2; for f in "$WORK"/stub.log "$WORK"/submitted "$WORK"/job.out; do [ -f "$f" ] && { echo "--- $f"; cat "$f"; }; done >&2; exit 1; }
expect() { grep -qE -- "$2" "$1" || fail "$1 lacks /$2/"; }

checkpoint_at() {  # checkpoint_at FILE STEP
  mkdir -p "$(dirname "$1")"
  { printf 'parode-checkpoint 1 %012d\n' 4096; printf '%-4063s' "{\"step\": $2}"; } >"$1"
}

# Starts JOB in the background, waits for the stub to run, sends SIGTERM to
# the job script, and waits for the job; its exit code in JOB_RC.
interrupt() {
  STUB_MODE="wait" "$@" >"$WORK/job.out" 2>&1 &
  local job=$!
  for _ in $(seq 100); do [ -e "$STUB_LOG.started" ] && break; sleep 0.1; done
  [ -e "$STUB_LOG.started" ] || fail "the run did not start"
  kill -TERM "$job"
  for _ in $(seq 200); do kill -0 "$job" 2>/dev/null || break; sleep 0.1; done
  if kill -0 "$job" 2>/dev/null; then kill -KILL "$job"; fail "the job did not end within 20 s of SIGTERM"; fi
  JOB_RC=0
  wait "$job" || JOB_RC=$?
}

case "${1:?case}" in
  dry-slurm-srun)
    DRY_RUN=1 SLURM_CPUS_PER_TASK=8 bash jobs/slurm/parode.sbatch >"$WORK/job.out"
    expect "$WORK/job.out" "^run: srun --cpus-per-task=8 --cpu-bind=cores .*parode_stub.sh run jobs/scenes/tennis.toml --steps 1000 --checkpoint $OUT/tennis.ckpt --checkpoint-every 1000 --collide grid --solver parallel --threads 8 --report $OUT/tennis-segment1.json"
    expect "$WORK/job.out" "^on exit 7 \(interrupted\): $SUBMIT_CMD --dependency=afterany:4242 --export=ALL,RESTART=$OUT/tennis.ckpt,SEGMENT=2 " ;;
  dry-slurm-mpirun)
    DRY_RUN=1 LAUNCHER=mpirun SOCKETS=2 SLURM_NTASKS_PER_NODE=4 SLURM_CPUS_PER_TASK=6 bash jobs/slurm/parode.sbatch >"$WORK/job.out"
    expect "$WORK/job.out" "^run: mpirun --map-by ppr:2:socket:PE=6 --bind-to core -x OMP_NUM_THREADS .*--mca odls_base_sigkill_timeout 240 .*--threads 6 " ;;
  dry-pbs)
    DRY_RUN=1 OMP_NUM_THREADS=16 bash jobs/pbs/parode.pbs >"$WORK/job.out"
    expect "$WORK/job.out" "^run: mpirun --map-by ppr:1:socket:PE=16 --bind-to core .*--checkpoint $OUT/tennis.ckpt "
    expect "$WORK/job.out" "^on exit 7 \(interrupted\): $SUBMIT_CMD -V -W depend=afterany:77.pbs -v RESTART=$OUT/tennis.ckpt,SEGMENT=2 jobs/pbs/parode.pbs" ;;
  signal-resubmits)
    interrupt env LAUNCHER=none bash jobs/slurm/parode.sbatch
    [ "$JOB_RC" -eq 0 ] || fail "the interrupted segment exited $JOB_RC"
    expect "$STUB_LOG" "^stub: SIGTERM"
    expect "$WORK/submitted" "--dependency=afterany:4242 --export=ALL,RESTART=$OUT/tennis.ckpt,SEGMENT=2 "
    expect "$WORK/job.out" "interrupted at step 600 of 1000; submitting segment 2" ;;
  launcher-code-and-report)  # mpirun turns exit 7 into its own code: the report decides
    interrupt env LAUNCHER=none STUB_EXIT=1 bash jobs/slurm/parode.sbatch
    [ "$JOB_RC" -eq 0 ] || fail "the interrupted segment exited $JOB_RC"
    expect "$WORK/submitted" "RESTART=$OUT/tennis.ckpt,SEGMENT=2" ;;
  restart-runs-the-rest)
    checkpoint_at "$OUT/tennis.ckpt" 600
    STUB_MODE="done" LAUNCHER=none RESTART="$OUT/tennis.ckpt" SEGMENT=2 bash jobs/slurm/parode.sbatch >"$WORK/job.out"
    expect "$STUB_LOG" "run jobs/scenes/tennis.toml --steps 400 --restart $OUT/tennis.ckpt.prev --checkpoint $OUT/tennis.ckpt .*--report $OUT/tennis-segment2.json"
    [ -f "$OUT/tennis.ckpt.prev" ] || fail "the previous checkpoint was not kept as tennis.ckpt.prev"
    [ ! -e "$WORK/submitted" ] || fail "a finished run resubmitted" ;;
  failure-stops)
    rc=0
    STUB_MODE=fail LAUNCHER=none bash jobs/slurm/parode.sbatch >"$WORK/job.out" 2>&1 || rc=$?
    [ "$rc" -eq 1 ] || fail "a failed run exited $rc, not parode's 1"
    [ ! -e "$WORK/submitted" ] || fail "a failed run resubmitted" ;;
  no-progress-stops)
    checkpoint_at "$OUT/elsewhere.ckpt" 600
    interrupt env LAUNCHER=none RESTART="$OUT/elsewhere.ckpt" STUB_STEP=600 bash jobs/slurm/parode.sbatch
    [ "$JOB_RC" -eq 2 ] || fail "a segment without progress exited $JOB_RC"
    expect "$WORK/job.out" "without progress since step 600"
    [ ! -e "$WORK/submitted" ] || fail "a segment without progress resubmitted" ;;
  pbs-timer-mpirun)  # the wall-time timer, SIGTERM through a real mpirun
    command -v mpirun >/dev/null || exit 77
    export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
    rc=0
    STUB_MODE="wait" WALLTIME=00:00:04 LEAD=2 GRACE=20 timeout 60 bash jobs/pbs/parode.pbs >"$WORK/job.out" 2>&1 || rc=$?
    [ "$rc" -eq 0 ] || fail "the PBS segment exited $rc"
    expect "$STUB_LOG" "^stub: SIGTERM"
    expect "$WORK/submitted" "-V -W depend=afterany:77.pbs -v RESTART=$OUT/tennis.ckpt,SEGMENT=2 " ;;
  *) echo "test_batch_jobs.sh: unknown case '$1'" >&2; exit 2 ;;
esac
echo "ok: $1"
