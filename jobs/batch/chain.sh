# One segment of a chained batch run of parode, sourced by the Slurm and PBS
# job scripts (jobs/slurm/parode.sbatch, jobs/pbs/parode.pbs). They set the
# array LAUNCH (the launcher's words, empty for none), define chain_forward
# PID (pass SIGTERM on to the run) and chain_submit_command CKPT SEGMENT (set
# the array SUBMIT to the command that submits the next segment), then call
# chain_main.
#
# A segment runs `parode run SCENE` (the first) or `parode run SCENE --restart
# CKPT` (the others) for the steps still to go, writing a checkpoint every
# CHECKPOINT_EVERY steps to OUT/NAME.ckpt. When the job's time runs out the
# scheduler signals the job shell (Slurm: --signal=B:TERM@lead; PBS: a timer
# started here); the shell passes SIGTERM on to every parode process, which
# finishes its step, writes the checkpoint and its run report marked
# "interrupted" and exits with code 7; the segment then submits the next one
# with RESTART=OUT/NAME.ckpt, to start once this job has ended.
#
# Settings (environment; the job scripts pass them on to the next segment):
#   SCENE (required)  STEPS (required: steps of the whole run)
#   NAME=<scene file name>  OUT=results/NAME  CHECKPOINT_EVERY=1000
#   COLLIDE=grid  SOLVER=parallel  RUN_ARGS="" (more `parode run` options, e.g.
#   "--set catoms.count=1000000")  PARODE=build/ci/parode
#   MAX_SEGMENTS=20  RESTART, SEGMENT (set by the chain)  DRY_RUN=1: print the
#   commands (the segment's run, and the resubmission) instead of running them.
# Needs python3 on the node that runs the job script (it reads the
# checkpoint's step and the report's mark).
# Trade-off: the chain restarts from the checkpoint file, not from the step
# count in a report, so a segment that dies without writing one (a node
# failure) is simply resubmitted by hand with the same RESTART; the previous
# checkpoint is kept as NAME.ckpt.prev until the new one is complete.
# shellcheck shell=bash

chain_die() { echo "parode job: $*" >&2; exit 2; }

# Step of a checkpoint: its first line is "parode-checkpoint 1 <head bytes>",
# then the JSON metadata with "step".
chain_checkpoint_step() {
  python3 - "$1" <<'PY'
import json, sys
with open(sys.argv[1], "rb") as f:
    magic = f.readline().split()
    if len(magic) != 3 or magic[0] != b"parode-checkpoint":
        sys.exit(f"{sys.argv[1]}: not a parode checkpoint")
    head = f.read(int(magic[2]) - f.tell())
print(json.loads(head.decode().strip())["step"])
PY
}

# Whether a run report says the run was interrupted (a launcher such as
# mpirun may turn parode's exit code 7 into its own).
chain_report_interrupted() {
  [ -f "$1" ] && python3 - "$1" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
sys.exit(0 if "interrupted" in r else 1)  # {"signal", "step", "checkpoint"}
PY
}

chain_settings() {
  [ -n "${SCENE:-}" ] || chain_die "SCENE is not set (the scene file to run)"
  [ -f "$SCENE" ] || chain_die "SCENE=$SCENE: no such scene file"
  [[ "${STEPS:-}" =~ ^[1-9][0-9]*$ ]] || chain_die "STEPS must be the run's total step count, not '${STEPS:-}'"
  NAME="${NAME:-$(basename "$SCENE" .toml)}"
  OUT="${OUT:-results/$NAME}"
  CHECKPOINT_EVERY="${CHECKPOINT_EVERY:-1000}"
  [[ "$CHECKPOINT_EVERY" =~ ^[1-9][0-9]*$ ]] || chain_die "CHECKPOINT_EVERY must be a positive integer"
  COLLIDE="${COLLIDE:-grid}" SOLVER="${SOLVER:-parallel}" PARODE="${PARODE:-build/ci/parode}"
  SEGMENT="${SEGMENT:-1}" MAX_SEGMENTS="${MAX_SEGMENTS:-20}"
  CHECKPOINT="$OUT/$NAME.ckpt"
  REPORT="$OUT/$NAME-segment$SEGMENT.json"
}

# The parode command of this segment into the array RUN; sets FROM_STEP,
# REMAINING and KEEP_PREVIOUS (restarting from the file the run will write:
# it moves to NAME.ckpt.prev first).
chain_parode_command() {
  local steps="$STEPS" restart_args=()
  FROM_STEP=0 KEEP_PREVIOUS=""
  if [ -n "${RESTART:-}" ]; then
    [ -f "$RESTART" ] || chain_die "RESTART=$RESTART: no such checkpoint"
    FROM_STEP="$(chain_checkpoint_step "$RESTART")" || chain_die "RESTART=$RESTART: unreadable checkpoint"
    steps=$((STEPS - FROM_STEP))
    restart_args=(--restart "$RESTART")
    if [ "$RESTART" -ef "$CHECKPOINT" ]; then
      KEEP_PREVIOUS=1
      restart_args=(--restart "$CHECKPOINT.prev")
    fi
  fi
  local extra=()
  read -r -a extra <<<"${RUN_ARGS:-}"
  RUN=("$PARODE" run "$SCENE" --steps "$steps" "${restart_args[@]}" --checkpoint "$CHECKPOINT"
       --checkpoint-every "$CHECKPOINT_EVERY" --collide "$COLLIDE" --solver "$SOLVER"
       --threads "${OMP_NUM_THREADS:-1}" --report "$REPORT" "${extra[@]}")
  REMAINING="$steps"
}

# Runs LAUNCH + RUN in the background, passing SIGTERM/SIGINT on through
# chain_forward (set by the job script); sets RC to the run's exit code.
chain_run() {
  local child again
  trap 'chain_forward "$child"' TERM INT
  "${LAUNCH[@]}" "${RUN[@]}" &
  child=$!
  while :; do
    wait "$child" && RC=0 || RC=$?
    kill -0 "$child" 2>/dev/null || break  # still running: a trap interrupted the wait
  done
  if [ "$RC" -gt 128 ]; then  # it ended right after an interrupted wait: its own code
    wait "$child" 2>/dev/null && again=0 || again=$?
    [ "$again" -eq 127 ] || RC="$again"
  fi
  trap - TERM INT
}

chain_next() {
  local step
  step="$(chain_checkpoint_step "$CHECKPOINT" 2>/dev/null)" || chain_die "interrupted, but $CHECKPOINT is missing or unreadable: not resubmitting"
  [ "$step" -gt "$FROM_STEP" ] || chain_die "interrupted at step $step without progress since step $FROM_STEP: not resubmitting"
  [ "$SEGMENT" -lt "$MAX_SEGMENTS" ] || chain_die "segment $SEGMENT of MAX_SEGMENTS=$MAX_SEGMENTS: not resubmitting"
  echo "parode job: interrupted at step $step of $STEPS; submitting segment $((SEGMENT + 1))"
  chain_submit_command "$CHECKPOINT" "$((SEGMENT + 1))"
  "${SUBMIT[@]}"
}

chain_main() {
  chain_settings
  chain_parode_command
  if [ -n "${DRY_RUN:-}" ]; then
    chain_submit_command "$CHECKPOINT" "$((SEGMENT + 1))"
    echo "run: ${LAUNCH[*]} ${RUN[*]}"
    echo "on exit 7 (interrupted): ${SUBMIT[*]}"
    return 0
  fi
  if [ "$REMAINING" -le 0 ]; then echo "parode job: $RESTART is at step $FROM_STEP of $STEPS: nothing left"; return 0; fi
  mkdir -p "$OUT"
  [ -z "$KEEP_PREVIOUS" ] || mv -f "$CHECKPOINT" "$CHECKPOINT.prev"
  echo "parode job: segment $SEGMENT, steps $FROM_STEP to $STEPS: ${LAUNCH[*]} ${RUN[*]}"
  chain_run
  if [ "$RC" -eq 0 ]; then echo "parode job: done, report $REPORT"; return 0; fi
  if [ "$RC" -eq 7 ] || chain_report_interrupted "$REPORT"; then chain_next; return 0; fi
  echo "parode job: parode failed with exit code $RC (README: exit codes); not resubmitting" >&2
  return "$RC"
}
