#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Smoke test of the force-servo demo on the built tree: a short operator profile (hands off,
# press at 10 N, 20 N, release) through examples/force-servo/demo, then: exit code 0, the
# summary and the CSV written, both press phases found in contact, no sanitizer report in the
# processes' logs, and nothing the demo started still running. Figures are not checked (no --check): that is for quiet machines.
#
# With a motion script instead of a system file (SCRIPT.py), the demo runs that script in the
# joystick's place: exit code 0, every motion of the script done, the slide's figures reported
# (the path within its limit), and the same checks of the chain, sanitizers and leftovers.
#
# Usage: demo_smoke_test.sh DEMO BIN_DIR [SYSTEM_FILE | SCRIPT.py]   (default: the demo's own,
# the paper's five processes; examples/force-servo/system-shared.yaml runs the servo's shared tick)
set -euo pipefail

demo=$1
bin_dir=$2
system_args=() script=""
if [[ "${3:-}" == *.py ]]; then
  script=$3
elif [[ -n "${3:-}" ]]; then
  system_args=(--system "$3")
fi
tmp=$(mktemp -d "${TMPDIR:-/tmp}/rtm-demo-smoke.XXXXXX")

# Every process the demo starts inherits TMPDIR=$tmp/run (its private runtime folder is made
# there too): those are the ones that must be gone afterwards.
leftovers() {
  local pid
  for environ in /proc/[0-9]*/environ; do
    pid=${environ#/proc/}
    pid=${pid%/environ}
    [[ "$pid" == "$$" ]] && continue
    if tr '\0' '\n' 2>/dev/null <"$environ" | grep -qx "TMPDIR=$tmp/run"; then
      echo "$pid $(tr '\0' ' ' <"/proc/$pid/cmdline" 2>/dev/null)"
    fi
  done
}
cleanup() {
  local status=$?
  # Whatever the outcome, nothing of this run may stay behind.
  leftovers | while read -r pid _; do kill -KILL "$pid" 2>/dev/null || true; done
  rm -rf "$tmp"
  exit "$status"
}
trap cleanup EXIT

fail() {
  echo "demo smoke test: $*" >&2
  echo "---- demo output" >&2
  cat "$tmp/demo.log" >&2 || true
  exit 1
}

mkdir -p "$tmp/run"
# The tool tip starts 20 mm above the table and descends at the approach speed (5 mm/s), so it
# touches down about 4 s into the 10 N press; the press lasts 6 s so that the phase's steady
# state (its last second) is in contact with time to spare on a slow or busy machine.
cat >"$tmp/profile.yaml" <<'YAML'
segments:
  - hold: 1.0
  - ramp: {duration_s: 0.5, force_N: [0, 0, -10]}
  - hold: 6.0
  - ramp: {duration_s: 0.5, force_N: [0, 0, -20]}
  - hold: 3.0
  - ramp: {duration_s: 0.5, force_N: [0, 0, 3]}
  - hold: 1.0
YAML

status=0
if [[ -n "$script" ]]; then
  TMPDIR="$tmp/run" "$demo" --bin "$bin_dir" --script "$script" --duration 90 --out "$tmp/out" \
    >"$tmp/demo.log" 2>&1 || status=$?
else
  TMPDIR="$tmp/run" "$demo" --bin "$bin_dir" "${system_args[@]}" --profile "$tmp/profile.yaml" --duration 13 \
    --out "$tmp/out" >"$tmp/demo.log" 2>&1 || status=$?
fi
((status == 0)) || fail "exit code $status, want 0"

for file in summary.txt force_servo.csv; do
  [[ -s "$tmp/out/$file" ]] || fail "$file missing or empty in the output folder"
done
[[ $(wc -l <"$tmp/out/force_servo.csv") -gt 1000 ]] || fail "force_servo.csv holds fewer than 1000 rows"
if [[ -n "$script" ]]; then
  # Each motion row of "Motion script": "  T s  D s  OUTCOME  description".
  motions=$(awk '/^Motion script, each motion/ { on = 1; next } on && /^  / { print $5; next } { on = 0 }' \
    "$tmp/out/summary.txt")
  [[ -n "$motions" && -z $(grep -vx done <<<"$motions") ]] || fail "not every motion of the script is done:
$(cat "$tmp/out/summary.txt")"
  grep -q "figure: force error along the normal while sliding, p99" "$tmp/out/summary.txt" ||
    fail "no slide force figure in summary.txt"
  grep -q "figure: path deviation, max .*: ok$" "$tmp/out/summary.txt" ||
    fail "the slide's path is not within its limit in summary.txt:
$(cat "$tmp/out/summary.txt")"
  grep -q "rtm script exited 0" "$tmp/out/summary.txt" || fail "rtm script did not exit 0"
else
  # A phase row: "#  start - end  reference x y z  measured x y z ... contact" (z is field 7).
  for reference in -10.0 -20.0; do
    awk -v ref="$reference" '$NF == "contact" && $7 == ref { found = 1 } END { exit !found }' \
      "$tmp/out/summary.txt" || fail "no press phase at $reference N in contact in summary.txt:
$(cat "$tmp/out/summary.txt")"
  done
fi

# The paper's chain is watched at its end, the actuator (a process of its own, or the shared
# tick's member), and the summary reports it.
grep -q "^  chain wrist_to_drive at actuator0: latency p50" "$tmp/out/summary.txt" ||
  fail "the chain wrist_to_drive is not reported as measured at actuator0 in summary.txt:
$(cat "$tmp/out/summary.txt")"

# A sanitizer build: no process of the run may have reported an error (they keep running).
if grep -l -E "ERROR: (Address|Leak|Thread|UndefinedBehavior)Sanitizer|runtime error:" "$tmp/out/raw/"* >/dev/null 2>&1; then
  fail "a sanitizer report in the run's logs: $(grep -l -E "Sanitizer|runtime error:" "$tmp/out/raw/"*)"
fi

# The bus and naming port of this run, from the demo's own lines.
bus=$(sed -n 's/^demo: pa10-sim on local:\([^ ]*\).*/\1/p' "$tmp/demo.log")
naming=$(sed -n 's/^demo: omniNames on \(.*\)$/\1/p' "$tmp/demo.log")
[[ -n "$bus" && -n "$naming" ]] || fail "the demo did not name its bus and naming service"
left=$(leftovers)
if [[ -z "$left" ]]; then
  left=$(pgrep -af -- "$bus|-start ${naming##*:}" || true)
fi
[[ -z "$left" ]] || fail "processes of the demo still running after it returned:
$left"
echo "demo smoke test: ok (bus $bus, naming $naming)"
