# SPDX-License-Identifier: Apache-2.0
# What the layering checks' own tests share (sourced): a scratch folder removed on exit,
# run_check COMMAND... (its output in $output, shown indented, its exit status in $status),
# expect WHAT COMMAND... (counts a failure when COMMAND fails) and finish (exit 1 if any).
set -uo pipefail
scratch=$(mktemp -d "${TMPDIR:-/tmp}/layering-test.XXXXXX")
trap 'rm -rf "$scratch"' EXIT
failures=0
run_check() {
  output=$("$@")
  status=$?
  sed 's/^/  check: /' <<<"$output"
}
expect() {
  if "${@:2}"; then echo "ok   $1"; else echo "FAIL $1"; failures=$((failures + 1)); fi
}
finish() {
  if ((failures)); then echo "$failures check(s) failed"; exit 1; fi
  echo "all checks passed"
}
