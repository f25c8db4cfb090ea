#!/usr/bin/env bash
# The main job on the default scene: sets up and builds (jobs/setup.sh), then
# collapses the 1,000-ball tennis prism for 1,000 steps with the scene's [run]
# choices (the grid collider and parode's contact solver, on every core),
# prints the summary and writes the JSON run report to results/tennis.json.
# Extra arguments go to `parode run` (e.g. --set catoms.count=8000 --threads 2).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/jobs/setup.sh" ci
mkdir -p "$root/results"
exec "$root/build/ci/parode" run "$root/jobs/scenes/tennis.toml" --report "$root/results/tennis.json" "$@"
