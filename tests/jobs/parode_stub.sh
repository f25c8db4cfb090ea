#!/usr/bin/env bash
# Stands in for `parode run` in the batch job tests (test_batch_jobs.sh):
# records its arguments in STUB_LOG, then, by STUB_MODE:
#   wait   run until SIGTERM, then write a checkpoint at step STUB_STEP (to
#          --checkpoint), a report marked interrupted (to --report), exit 7
#          (or STUB_EXIT: what a launcher may turn it into)
#   done   exit 0 at once;  fail  exit 1 at once
# Trade-off: it mimics only what the job scripts read (the checkpoint's
# first line and step, the report's "interrupted", the exit code), so the
# scripts can be tested without a scheduler and without the real run.
set -euo pipefail
echo "$*" >>"${STUB_LOG:?}"
checkpoint="" report=""
while [ $# -gt 0 ]; do
  case "$1" in
    --checkpoint) checkpoint="$2"; shift ;;
    --report) report="$2"; shift ;;
  esac
  shift
done

interrupted() {
  local meta
  meta="{\"step\": ${STUB_STEP:-600}, \"scene\": \"tennis\"}"
  { printf 'parode-checkpoint 1 %012d\n' 4096; printf '%-4063s' "$meta"; } >"$checkpoint"
  echo '{"scene": "tennis", "interrupted": {"signal": "SIGTERM", "step": 600, "checkpoint": "x.ckpt"}}' >"$report"
  echo "stub: SIGTERM" >>"$STUB_LOG"
  exit "${STUB_EXIT:-7}"
}

case "${STUB_MODE:-done}" in
  wait)
    trap interrupted TERM
    echo $$ >"$STUB_LOG.pid"
    touch "$STUB_LOG.started"
    while :; do sleep 0.1; done ;;
  done) exit 0 ;;
  fail) exit 1 ;;
esac
