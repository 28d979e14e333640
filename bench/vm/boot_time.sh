#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# How long scripts/vm-vcan-run takes to start a command in its guest, and to return.
#
# usage: bench/vm/boot_time.sh [RUNS]   (default 10)
# Each run starts `vm-vcan-run -w DIR -- touch DIR/started` and takes the host's clock when the
# runner starts, when DIR/started appears on the host (boot to command: the runner builds its
# initramfs, QEMU boots the kernel, mounts the host's root, brings vcan0 up and execs the
# command; polled every 2 ms) and when the runner returns (the whole call, power-off included).
# The first call also fetches the kernel when it is not cached yet: run --prepare first, as
# scripts/test.sh does, to leave that out. Prints every run, then p50 and max of each.
set -euo pipefail
runs=${1:-10}
runner=$(cd "$(dirname "$0")/../.." && pwd)/scripts/vm-vcan-run
"$runner" --probe
now_us() { echo $(($(date +%s%N) / 1000)); }

boot=() whole=()
for ((i = 1; i <= runs; i++)); do
  dir=$(mktemp -d "${TMPDIR:-/tmp}/vm-boot.XXXXXX")
  t0=$(now_us)
  "$runner" -w "$dir" -- touch "$dir/started" &
  pid=$!
  while [[ ! -e $dir/started ]] && kill -0 "$pid" 2>/dev/null; do sleep 0.002; done
  t1=$(now_us)
  wait "$pid"
  t2=$(now_us)
  [[ -e $dir/started ]] || { echo "run $i: the command did not run" >&2; exit 1; }
  rm -rf "$dir"
  boot+=($((t1 - t0))) whole+=($((t2 - t0)))
  awk -v i="$i" -v b="${boot[-1]}" -v w="${whole[-1]}" \
    'BEGIN { printf "run %2d: boot to command %6.2f s, whole call %6.2f s\n", i, b / 1e6, w / 1e6 }'
done

stats() { # name, values in us: p50 (lower median) and max, in seconds
  local name=$1; shift
  local sorted; mapfile -t sorted < <(printf '%s\n' "$@" | sort -n)
  awk -v n="$name" -v p="${sorted[(${#sorted[@]} - 1) / 2]}" -v m="${sorted[-1]}" -v c="${#sorted[@]}" \
    'BEGIN { printf "%-16s p50 %6.2f s   max %6.2f s   (%d runs)\n", n, p / 1e6, m / 1e6, c }'
}
echo "host: $(nproc) CPUs, load $(cut -d' ' -f1-3 /proc/loadavg), accel ${RTM_VM_ACCEL:-auto}"
stats "boot to command" "${boot[@]}"
stats "whole call" "${whole[@]}"
