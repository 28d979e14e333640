#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The whole test suite: installs what is missing, builds and runs three stages,
#   default  the Release build, every test (unit, integration, slow, socketcan);
#   asan     ASan+UBSan: unit and integration tests, SocketCAN ones included (not slow ones);
#   tsan     ThreadSanitizer (framework core and CAN library): the threading and socketcan tests.
# Every stage runs even when an earlier one failed; at the end one line per stage, the skipped
# tests and why, the failed tests, and a total. Exits 1 when any stage failed (its build or a
# test), else 0.
# The SocketCAN tests run in a QEMU guest (scripts/vm-vcan-run): its kernel is fetched once into
# ${XDG_CACHE_HOME:-$HOME/.cache}/rtm/vm (~35 MB), never installed.
# Usage: scripts/test.sh [ctest args...]   (e.g. -L unit, -R Servo)
set -uo pipefail
cd "$(dirname "$0")/.."
scripts/deps.sh test || exit 1
scripts/vm-vcan-run --prepare || echo "test: no guest for the SocketCAN tests here: they will be skipped"
jobs=$(nproc)
logs=$(mktemp -d "${TMPDIR:-/tmp}/rtm-test.XXXXXX")
trap 'rm -rf "$logs"' EXIT

summary=()
skipped_names=()
failed_names=()
failed_excerpts=()
total_passed=0 total_failed=0 total_skipped=0 any_failed=0
for preset in default asan tsan; do
  echo "=== preset $preset"
  started=$SECONDS
  if ! { cmake --preset "$preset" >/dev/null && cmake --build --preset "$preset" -j "$jobs"; }; then
    summary+=("$(printf '%-8s build FAILED, no test ran (%d s)' "$preset" $((SECONDS - started)))")
    any_failed=1 total_failed=$((total_failed + 1)) # a failed build counts as one failure
    continue
  fi
  ctest --preset "$preset" "$@" 2>&1 | tee "$logs/$preset.log"
  ctest_status=${PIPESTATUS[0]}
  # "100% tests passed, 0 tests failed out of 411"; skipped tests are listed as "(Skipped)".
  line=$(grep -E 'tests passed, [0-9]+ tests? failed out of [0-9]+' "$logs/$preset.log" | tail -n 1)
  total=$(sed -E 's/.* out of ([0-9]+).*/\1/' <<<"$line")
  failed=$(sed -E 's/.*passed, ([0-9]+) tests? failed.*/\1/' <<<"$line")
  mapfile -t skipped < <(sed -nE 's/^[[:space:]]*[0-9]+ - (.*) \(Skipped\)$/\1/p' "$logs/$preset.log")
  if [[ -z $line ]]; then
    total=0 failed=0
  fi
  passed=$((total - failed - ${#skipped[@]}))
  verdict=passed
  if ((ctest_status != 0 || failed > 0 || total == 0)); then
    verdict=FAILED any_failed=1
  fi
  summary+=("$(printf '%-8s %s: %d passed, %d failed, %d skipped (%d s)' "$preset" "$verdict" \
    "$passed" "$failed" "${#skipped[@]}" $((SECONDS - started)))")
  for name in "${skipped[@]}"; do skipped_names+=("$preset: $name"); done
  # ctest's own list: "The following tests FAILED:" then "<tab>123 - Name (Failed)".
  mapfile -t failing < <(sed -n '/^The following tests FAILED:/,$p' "$logs/$preset.log" |
    sed -nE 's/^[[:space:]]*[0-9]+ - (.*) \(([^)]*)\)$/\1 (\2)/p')
  for name in "${failing[@]}"; do failed_names+=("$preset: $name"); done
  # The start and end of each failed test's output, from ctest's own record, so that the last
  # screen of this script says why (the full output is above, among the stage's tests).
  for name in "${failing[@]}"; do
    excerpt="$logs/failed.${#failed_excerpts[@]}"
    echo "--- $preset: ${name% (*}: its output" >"$excerpt"
    awk -v name="${name% (*}" '
      $0 ~ /^[0-9]+\/[0-9]+ Test: / { sub(/^[0-9]+\/[0-9]+ Test: /, ""); in_test = ($0 == name) }
      in_test && /^Output:$/ { getline; grabbing = 1; n = 0; next }
      grabbing && /^<end of output>$/ { grabbing = 0; in_test = 0; next }
      grabbing { lines[n++] = $0 }
      END {
        if (n <= 40) { for (i = 0; i < n; i++) print lines[i]; exit }
        for (i = 0; i < 10; i++) print lines[i]
        printf "  [... %d lines ...]\n", n - 35
        for (i = n - 25; i < n; i++) print lines[i]
      }
    ' "build/$preset/Testing/Temporary/LastTest.log" >>"$excerpt"
    failed_excerpts+=("$excerpt")
  done
  total_passed=$((total_passed + passed))
  total_failed=$((total_failed + failed))
  total_skipped=$((total_skipped + ${#skipped[@]}))
done

echo
echo "=== stages"
printf '%s\n' "${summary[@]}"
if ((${#skipped_names[@]})); then
  echo "=== skipped tests"
  printf '  %s\n' "${skipped_names[@]}"
  if printf '%s\n' "${skipped_names[@]}" | grep -q '_in_vm$\|vm_runner'; then
    echo "  why the SocketCAN tests were skipped: $(scripts/vm-vcan-run --probe 2>&1)"
  fi
fi
if ((${#failed_names[@]})); then
  echo "=== failed tests (their output is above, under the stage's preset)"
  printf '  %s\n' "${failed_names[@]}"
  cat "${failed_excerpts[@]}"
fi
echo "total: $total_passed passed, $total_failed failed, $total_skipped skipped"
exit "$any_failed"
