#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# What access control costs `rtm ls -l` of 20 components (docs/performance.md): 20 test talkers
# started owner-only (each connection's caller asked of the kernel when it is accepted) or open
# to all (nothing asked), in alternating rounds, and `rtm ls -l` timed N times per round.
# omniNames on a free loopback port; everything started is stopped.
#
#   bench/tools/access_ls.sh [build folder (build/default)] [rounds (3)] [runs per round (20)]
set -euo pipefail
build=$(cd "${1:-build/default}" && pwd)
rounds=${2:-3}
runs=${3:-20}
work=$(mktemp -d)
names_pid=
talkers=()
stop_talkers() {
  ((${#talkers[@]})) && kill "${talkers[@]}" 2>/dev/null && wait "${talkers[@]}" 2>/dev/null
  talkers=()
}
cleanup() {
  stop_talkers || true
  [[ -n $names_pid ]] && kill "$names_pid" 2>/dev/null && wait "$names_pid" 2>/dev/null
  rm -rf "$work"
}
trap cleanup EXIT
ns() { date +%s%N; }

port=$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
omniNames -start "$port" -logdir "$work" -ignoreport -ORBendPoint "giop:tcp:127.0.0.1:$port" >"$work/names.out" 2>&1 &
names_pid=$!
sleep 0.5
export RTM_NAMING=127.0.0.1:$port
rtm=$build/bin/rtm
talker=$build/tests/bin/rtm-test-talker

printf '%-6s %-6s %10s %10s %10s\n' round access median_ms min_ms max_ms
for ((r = 1; r <= rounds; r++)); do
  for access in owner open; do
    for ((i = 0; i < 20; i++)); do
      "$talker" --name "t$i" --access "$access" >/dev/null 2>&1 &
      talkers+=($!)
    done
    until [[ $("$rtm" ls --names 2>/dev/null | wc -l) -ge 20 ]]; do sleep 0.1; done
    times=()
    for ((k = 0; k < runs; k++)); do
      t0=$(ns)
      "$rtm" ls -l >/dev/null
      times+=($((($(ns) - t0) / 1000)))
    done
    printf '%s\n' "${times[@]}" | sort -n |
      awk -v r="$r" -v a="$access" '{ t[NR] = $1 } END { printf "%-6s %-6s %10.1f %10.1f %10.1f\n", r, a, t[int(NR / 2) + 1] / 1000, t[1] / 1000, t[NR] / 1000 }'
    stop_talkers
    "$rtm" ls --clean >/dev/null
  done
done
