#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The two-component example: a source and a sink wired through a real naming service.
#   1. installs missing Debian packages (scripts/deps.sh) and builds the default preset's
#      example targets;
#   2. starts omniNames on a free loopback port, with its data in a temporary directory;
#   3. starts rtm-example-source (a TimedFloat6 ramp every 2 ms) and rtm-example-sink;
#   4. subscribes source0.out0 -> sink0.in0 and turns both on;
#   5. shows a few seconds of live values, then stops everything it started.
# Usage: examples/source_sink/demo.sh [seconds]
# RTM_DEMO_BUILD_DIR=<dir> uses that (configured) build tree instead of the default preset's.
set -euo pipefail
cd "$(dirname "$0")/../.."
seconds=${1:-5}

scripts/deps.sh
build_dir=${RTM_DEMO_BUILD_DIR:-build/default}
[[ -n "${RTM_DEMO_BUILD_DIR:-}" ]] || cmake --preset default >/dev/null
cmake --build "$build_dir" -j"$(nproc)" --target rtm-example-source rtm-example-sink rtm-example-wire
bin=$build_dir/bin  # the components (programs and modules: rtm_add_component)
wire=$build_dir/examples/source_sink/rtm-example-wire

workdir=$(mktemp -d -t rtm-demo-XXXXXX)
pids=()
cleanup() {
  # Components first (they unbind their names), then the naming service.
  for ((i = ${#pids[@]} - 1; i >= 0; i--)); do
    kill -TERM "${pids[i]}" 2>/dev/null || true
    for _ in $(seq 50); do kill -0 "${pids[i]}" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "${pids[i]}" 2>/dev/null || true
    wait "${pids[i]}" 2>/dev/null || true
  done
  rm -rf "$workdir"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

port_is_free() { ! ss -Hltn "sport = :$1" | grep -q .; }

# A free loopback port for omniNames; another process may take it first, so retry.
for _ in $(seq 20); do
  port=$((20000 + RANDOM % 40000))
  port_is_free "$port" || continue
  rm -rf "$workdir/names" && mkdir -p "$workdir/names"
  omniNames -start "$port" -logdir "$workdir/names" -ignoreport \
    -ORBendPoint "giop:tcp:127.0.0.1:$port" >"$workdir/omninames.log" 2>&1 &
  names_pid=$!
  for _ in $(seq 50); do
    grep -q "Root context is" "$workdir/omninames.log" 2>/dev/null && break
    sleep 0.1
  done
  if kill -0 "$names_pid" 2>/dev/null && grep -q "Root context is" "$workdir/omninames.log"; then
    pids+=("$names_pid")
    break
  fi
  wait "$names_pid" 2>/dev/null || true
  names_pid=
done
[[ -n "${names_pid:-}" ]] || { echo "demo: omniNames did not start" >&2; exit 1; }
export RTM_NAMING="127.0.0.1:$port"
echo "demo: omniNames at $RTM_NAMING"

wait_bound() {  # log file, name
  for _ in $(seq 100); do
    grep -q "bound $2 " "$1" 2>/dev/null && return 0
    sleep 0.05
  done
  echo "demo: $2 did not bind:" >&2
  cat "$1" >&2
  exit 1
}

"$bin/rtm-example-source" --name source0 --period 2ms >"$workdir/source.log" 2>&1 &
pids+=($!)
"$bin/rtm-example-sink" --name sink0 --period 2ms --print-every 500ms >"$workdir/sink.log" 2>&1 &
pids+=($!)
wait_bound "$workdir/source.log" source0
wait_bound "$workdir/sink.log" sink0

"$wire" source0.out0 sink0.in0
echo "demo: live values for $seconds s (sink0 prints twice a second)"
tail -n +1 -f "$workdir/sink.log" &
tail_pid=$!
sleep "$seconds"
kill "$tail_pid" 2>/dev/null || true
wait "$tail_pid" 2>/dev/null || true
echo "demo: stopping"
