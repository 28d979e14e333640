#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The stability-latency study (bench/sim/stability_study, lock-step) confirmed in real time: the
# force-servo demo on pa10-sim's default steel table, in the paper's mode (five processes,
# examples/force-servo/system.yaml) or the shared tick (system-shared.yaml), with the contact
# gain set to G. The tool approaches at 5 mm/s, as in the study, and presses at 10 N for 5 s.
# One line per run: touch-down overshoot, settling after touch-down, and the force's swing over
# the press's last second (the study's "stable": overshoot <= 20 %, swing <= 1 N).
#
#   bench/sim/confirm_stability.sh [--bin DIR] MODE:GAIN ...     MODE = paper | shared
#   e.g. bench/sim/confirm_stability.sh paper:0.00066 paper:0.0009 shared:0.0009 shared:0.00117
#
# Every run starts and stops its own omniNames, simulator and components (the demo does).
set -euo pipefail
cd "$(dirname "$0")/../.."

bin_dir=build/default/bin
if [[ "${1:-}" == --bin ]]; then
  bin_dir=$2
  shift 2
fi
(($# > 0)) || { sed -n '2,13p' "$0" >&2; exit 2; }

work=$(mktemp -d "${TMPDIR:-/tmp}/rtm-confirm-stability.XXXXXX")
trap 'rm -rf "$work"' EXIT
cat >"$work/press.yaml" <<'EOF'
segments:
  - hold: 1.0
  - ramp: {duration_s: 0.3, force_N: [0, 0, -10]}
  - hold: 9.7
EOF

printf '%-7s %-9s %-10s %-14s %-14s %-10s %s\n' mode gain overshoot "settle [s]" "swing [N]" latency "verdict (study: overshoot <= 20 %, swing <= 1 N)"
for run in "$@"; do
  mode=${run%%:*}
  gain=${run#*:}
  [[ "$gain" =~ ^[0-9.eE+-]+$ ]] || { echo "confirm_stability: bad gain in '$run'" >&2; exit 2; }
  case "$mode" in
    paper) system=examples/force-servo/system.yaml ;;
    shared) system=examples/force-servo/system-shared.yaml ;;
    *) echo "confirm_stability: mode must be paper or shared, got '$run'" >&2; exit 2 ;;
  esac
  grep -q -- '--gain, "[0-9.]*", "[0-9.]*", "[0-9.]*"' "$system" ||
    { echo "confirm_stability: no contact gain found in $system" >&2; exit 1; }
  sed -E "s/--gain, \"[0-9.]+\", \"[0-9.]+\", \"[0-9.]+\"/--gain, \"$gain\", \"$gain\", \"$gain\"/" "$system" \
    >"$work/system-$mode.yaml"
  out="$work/$mode-$gain"
  examples/force-servo/demo --bin "$bin_dir" --system "$work/system-$mode.yaml" --profile "$work/press.yaml" \
    --duration 12 --out "$out" >"$work/$mode-$gain.log" 2>&1 ||
    { echo "confirm_stability: the demo failed for $run (log below)" >&2; cat "$work/$mode-$gain.log" >&2; exit 1; }
  summary="$out/summary.txt"
  overshoot=$(sed -n 's/.*touch-down overshoot .*\(ok\|MISSED\) *\(-\?[0-9.]* %\).*/\2/p' "$summary")
  settle=$(sed -n 's/.*settling after touch-down .*\(ok\|MISSED\) *\([0-9.]* s\).*/\2/p' "$summary")
  # The press phase's p-p column: the force's swing over its last second.
  swing=$(awk '$NF == "contact" && $1 ~ /^[0-9]+$/ {print $12}' "$summary" | tail -1)
  latency=$(sed -n 's/.*Sensor sample to drive command.*p50 \([0-9.]* us\).*/\1/p' "$summary")
  verdict=unstable
  if [[ -n "$overshoot" && -n "$swing" ]] &&
    awk -v o="${overshoot% %}" -v s="$swing" 'BEGIN { exit !(o <= 20 && s <= 1) }'; then
    verdict=stable
  fi
  printf '%-7s %-9s %-10s %-14s %-14s %-10s %s\n' "$mode" "$gain" "${overshoot:--}" "${settle:-not settled}" \
    "${swing:--}" "${latency:--}" "$verdict"
done
