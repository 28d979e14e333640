#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# End-to-end latency of the force servo: from a sensor sample's stamp to the drive command
# leaving for the bus, per run mode, measured during the force-servo demo on pa10-sim.
#
#   paper   sensor, controller, actuator, servo, joystick: five processes, each on its own
#           2 ms activity, data over CORBA (examples/force-servo/system.yaml)
#   shared  servo --shared-tick: one 2 ms tick in one process runs the CAN master's receive,
#           sensor -> controller -> actuator, the master's transmit (RPDOs + SYNC)
#           (examples/force-servo/system-shared.yaml)
#   shared-master  the same members on one tick, but the master keeps its own thread and the
#           tick runs --tick-lead-us (100 us) before each of its cycles (--bus-cycle master)
#
# Where it is measured: the controller stamps each command with the stamp of the sensor sample
# it was computed from; the actuator hands the joint rates to the CANopen master (a target
# sequence number) and, on a later cycle, reads the master's last sent target: once that has
# reached its command it records sent time - stamp (CLOCK_REALTIME; the sent time is taken by
# the master's cycle right after writing the seven RPDOs carrying the command, just before
# SYNC). "handover" is the older, shorter span: stamp -> order_velocity returned. Both are logged
# as p50/p99/max when the actuator is turned off; 1 us buckets below 1 ms, 100 us buckets to
# 10 ms (upper edges reported).
# Loop lateness per component comes from `rtm --json ls -l` taken at the end of each run.
#
# Usage: bench/components/servo_latency.sh [--bin DIR] [--modes "paper shared shared-master"] [--out DIR]
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/../.." && pwd)
bin_dir=${RTM_BIN_DIR:-$repo/build/default/bin}
modes="paper shared shared-master"
out=""
while (($#)); do
  case "$1" in
    --bin) bin_dir=$2; shift 2 ;;
    --modes) modes=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    -h|--help) sed -n '2,23p' "$0"; exit 0 ;;
    *) echo "servo_latency: unknown option '$1'" >&2; exit 2 ;;
  esac
done
[[ -n "$out" ]] || out=$(mktemp -d "${TMPDIR:-/tmp}/rtm-servo-latency.XXXXXX")
mkdir -p "$out"

examples=$repo/examples/force-servo
sed 's/--shared-tick,/--shared-tick, --bus-cycle, master,/' "$examples/system-shared.yaml" >"$out/system-shared-master.yaml"
declare -A system=([paper]=$examples/system.yaml [shared]=$examples/system-shared.yaml
                   [shared-master]=$out/system-shared-master.yaml)
results=()
for mode in $modes; do
  [[ -n "${system[$mode]:-}" ]] || { echo "servo_latency: unknown mode '$mode'" >&2; exit 2; }
  echo "=== $mode"
  "$repo/examples/force-servo/demo" --bin "$bin_dir" --system "${system[$mode]}" \
    --out "$out/$mode" >"$out/$mode.log" 2>&1 || echo "servo_latency: the $mode run reported a problem (see $out/$mode.log)" >&2
  # The actuator's statistics as the report lists them, one component per block:
  # "  actuator0      clamped 0, commands N, ..." and continuation lines.
  line=$(awk '/^Statistics the components publish/ { on = 1; next } on && /^$/ { exit }
              on { if ($0 ~ /^  [^ ]/) name = $1; block[name] = block[name] " " $0 }
              END { for (n in block) if (block[n] ~ / latency_p50 /) print block[n] }' "$out/$mode/summary.txt" 2>/dev/null || true)
  [[ -n "$line" ]] || { echo "servo_latency: no latency statistics in the $mode run's summary ($out/$mode)" >&2; exit 1; }
  stat() { sed -n "s/.*[ ,]$1 \([0-9.]*\).*/\1/p" <<<"$line"; }
  p50=$(stat latency_p50) p99=$(stat latency_p99) max=$(stat latency_max)
  h50=$(stat handover_p50) h99=$(stat handover_p99)
  commands=$(stat commands) watchdog=$(stat watchdog_events)
  results+=("$(printf '| %-13s | %8s | %8s | %8s | %8s | %8s | %11s |' "$mode" "$commands" "$p50" "$p99" "$max" "$watchdog" \
    "${h50:-?}/${h99:-?}")")
  echo "--- loop timing ($mode)"
  sed -n '/^Loop timing/,/^$/p' "$out/$mode/summary.txt"
done

echo
echo "Sensor sample stamp -> drive command RPDOs written by the bus master (us), $(nproc) CPUs, $(date -u +%Y-%m-%d)"
echo "| mode          | commands |  p50 us  |  p99 us  |  max us  | watchdog | handover p50/p99 us |"
echo "|---------------|----------|----------|----------|----------|----------|---------------------|"
printf '%s\n' "${results[@]}"
echo "(runs, logs and plots in $out)"
