#!/bin/bash
# SPDX-License-Identifier: Apache-2.0
# Runs the force-servo demo RUNS times with a flight recorder of the scheduler (ftrace:
# sched_switch, sched_wakeup, sched_migrate_task, on CLOCK_MONOTONIC, 120 MB a CPU) and keeps
# the trace of each run that has a watchdog event the demo could not explain by a host stall
# (OUT-<k>.trace beside OUT-<k>/, with OUT-<k>.offset: wall clock minus CLOCK_MONOTONIC, to
# set the trace beside the logs). Read a trace with bench/tools/sched_window.py. Root only.
#
#   bench/tools/demo_sched_trace.sh BIN_DIR OUT [RUNS] [demo options...]
#   e.g. bench/tools/demo_sched_trace.sh build/default/bin /tmp/tr 10
set -euo pipefail
(($# >= 2)) || { echo "usage: $0 BIN_DIR OUT [RUNS] [demo options...]" >&2; exit 2; }
bin=$1 out=$2 runs=${3:-5}
shift $(($# >= 3 ? 3 : 2))
tracing=/sys/kernel/tracing
[[ -w $tracing/tracing_on ]] || { echo "$0: $tracing is not writable (root, tracefs mounted)" >&2; exit 2; }
here=$(cd "$(dirname "$0")/../.." && pwd)
events=(sched/sched_switch sched/sched_wakeup sched/sched_migrate_task)
restore() {
  echo 0 >"$tracing/tracing_on"
  for e in "${events[@]}"; do echo 0 >"$tracing/events/$e/enable"; done
  echo >"$tracing/trace"
  echo 1408 >"$tracing/buffer_size_kb"
}
trap restore EXIT
for ((k = 1; k <= runs; ++k)); do
  echo 0 >"$tracing/tracing_on"
  echo >"$tracing/trace"
  echo mono >"$tracing/trace_clock"
  echo 120000 >"$tracing/buffer_size_kb"
  for e in "${events[@]}"; do echo 1 >"$tracing/events/$e/enable"; done
  run=$out-$k
  rm -rf "$run"
  python3 -c 'import time; print(time.time() - time.clock_gettime(time.CLOCK_MONOTONIC))' >"$run.offset"
  echo 1 >"$tracing/tracing_on"
  status=0
  "$here/examples/force-servo/demo" --bin "$bin" --out "$run" "$@" >"$run.log" 2>&1 || status=$?
  echo 0 >"$tracing/tracing_on"
  line=$(grep -h 'not explained by a host stall' "$run/summary.txt" 2>/dev/null || echo "no summary (demo exit $status)")
  echo "run $k: $line"
  if grep -q MISSED <<<"$line"; then
    cat "$tracing/trace" >"$run.trace"
    echo "  kept $run.trace"
  fi
done
