#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# rtm play over a long recording: how late each datum is put after its recorded offset, and
# whether the pace drifts (the last datum's offset against the recording's span).
#   bench/tools/play_drift.sh BUILD_DIR SECONDS [rtm play options...]
# Starts omniNames on a free loopback port and the test talker "u" (its InPort in0), writes a
# recording of one TimedFloat6 port at 2 ms lasting SECONDS (rtm_bench_mcap_synth), plays it
# into u.in0 and prints rtm play's JSON, then the drift. Stops what it started.
set -euo pipefail
build=$(cd "${1:?usage: play_drift.sh BUILD_DIR SECONDS}" && pwd)
seconds=${2:?usage: play_drift.sh BUILD_DIR SECONDS}
shift 2
work=$(mktemp -d "${TMPDIR:-/tmp}/rtm-play-drift.XXXXXX")
pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
  for pid in "${pids[@]}"; do wait "$pid" 2>/dev/null || true; done
  rm -rf "$work"
}
trap cleanup EXIT
port=$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
omniNames -start "$port" -datadir "$work" -ignoreport -ORBendPoint "giop:tcp:127.0.0.1:$port" >"$work/omniNames.log" 2>&1 &
pids+=($!)
rtm=("$build/bin/rtm" --naming "127.0.0.1:$port")
for _ in $(seq 50); do "${rtm[@]}" ls >/dev/null 2>&1 && break; sleep 0.1; done
"$build/tests/bin/rtm-test-talker" --name u --naming "127.0.0.1:$port" >"$work/talker.log" 2>&1 &
pids+=($!)
for _ in $(seq 50); do "${rtm[@]}" cat u >/dev/null 2>&1 && break; sleep 0.1; done
"$build/bench/core/rtm_bench_mcap_synth" "$work/long.mcap" "$seconds" >&2
"${rtm[@]}" --json play "$work/long.mcap" --map synthetic.out=u.in0 "$@" | tee "$work/play.json"
python3 - "$work/play.json" "$seconds" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
span = float(sys.argv[2]) - 0.002  # the last datum's offset
print(f"span of the recording {span:.3f} s, played in {d['seconds']:.6f} s: "
      f"the last datum {1e3 * (d['seconds'] - span):.3f} ms after its offset (the put and the exit included); "
      f"lateness p50 {d['lateness_p50_us']:.0f} us, p99 {d['lateness_p99_us']:.0f} us, max {d['lateness_max_us']:.0f} us")
PY
