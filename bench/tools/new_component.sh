#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# From `rtm new component` to a running component, as a new user goes: install the build into a
# temporary prefix (not timed), then time each step against that prefix alone: rtm new,
# cmake configure, build (logic library, executable, test), the project's own test, and
# `rtm up` until the component is on (omniNames on a free loopback port). Also the installed
# size and the .deb's size.
#
#   bench/tools/new_component.sh [build folder (build/default)] [rounds (3)]
set -euo pipefail
build=$(cd "${1:-build/default}" && pwd)
rounds=${2:-3}
work=$(mktemp -d)
names_pid=
cleanup() {
  [[ -n $names_pid ]] && kill "$names_pid" 2>/dev/null && wait "$names_pid" 2>/dev/null
  rm -rf "$work"
}
trap cleanup EXIT
ms() { date +%s%3N; }

cmake --install "$build" --prefix "$work/usr" >/dev/null
echo "installed tree: $(du -sk "$work/usr" | cut -f1) kB ($(du -sk "$work/usr/bin" | cut -f1) kB programs)"
if (cd "$build" && cpack -G DEB -B "$work/deb" >/dev/null 2>&1); then
  for deb in "$work"/deb/rtm_*.deb "$work"/deb/rtm-dev_*.deb; do
    echo "package $(basename "$deb"): $(du -k "$deb" | cut -f1) kB, installed size $(dpkg-deb -f "$deb" Installed-Size) kB"
  done
fi

port=$(( (RANDOM % 20000) + 30000 ))
mkdir -p "$work/names"
omniNames -start "$port" -datadir "$work/names" -logdir "$work/names" -ignoreport \
  -ORBendPoint "giop:tcp:127.0.0.1:$port" >"$work/names/out" 2>&1 &
names_pid=$!
sleep 0.5
export RTM_NAMING=127.0.0.1:$port XDG_RUNTIME_DIR=$work
rtm=$work/usr/bin/rtm
printf '%-6s %8s %10s %8s %8s %8s %8s\n' round new configure build test up total
for ((r = 1; r <= rounds; r++)); do
  dir=$work/r$r
  mkdir -p "$dir"
  t0=$(ms)
  "$rtm" new component gripper_ctl --in wrench:TimedFloat6 --out twist:TimedFloat6 --dir "$dir" >/dev/null
  t1=$(ms)
  cmake -S "$dir/gripper_ctl" -B "$dir/gripper_ctl/build" -DCMAKE_PREFIX_PATH="$work/usr" >/dev/null
  t2=$(ms)
  cmake --build "$dir/gripper_ctl/build" -j"$(nproc)" >/dev/null
  t3=$(ms)
  ctest --test-dir "$dir/gripper_ctl/build" >/dev/null
  t4=$(ms)
  (cd "$dir/gripper_ctl" && "$rtm" up gripper_ctl.yaml >/dev/null)
  t5=$(ms)
  "$rtm" get gripper_ctl0.twist >/dev/null 2>&1 || true
  (cd "$dir/gripper_ctl" && "$rtm" down gripper_ctl >/dev/null)
  printf '%-6s %6d ms %7d ms %5d ms %5d ms %5d ms %5d ms\n' "$r" $((t1 - t0)) $((t2 - t1)) $((t3 - t2)) \
    $((t4 - t3)) $((t5 - t4)) $((t5 - t0))
done
