#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# check_exports.sh passes libraries that export their own folders and generated ones, and
# names each library that exports the project root or another library's folder.
# usage: check_exports_test.sh <check_exports.sh>
check=$1
# shellcheck source=expect.sh
source "$(dirname "$0")/expect.sh"
dir=$scratch
root=/p build=/p/build
cat >"$dir/good" <<GOOD
rtm_can|/p/arm/can|/p/arm/can/include
rtm_idl|/p/idl|/p/build/idl
rtm_cli|/p/tools/rtm|/p/tools/rtm
rtm_none|/p/x|
GOOD
run_check "$check" "$root" "$build" "$dir/good"
expect "own include folders and generated ones pass" test $status -eq 0
expect "the libraries are counted" grep -q "each of 4 libraries" <<<"$output"

cat >"$dir/bad" <<BAD
rtm_can|/p/arm/can|/p/arm/can/include,/p
rtm_pa10|/p/arm/pa10|/p/arm/can/include
rtm_sim|/p/sim|/p/simulator/include
BAD
run_check "$check" "$root" "$build" "$dir/bad"
expect "violations fail the check" test $status -eq 1
expect "exporting the project root is named" grep -q "^rtm_can exports the project root /p" <<<"$output"
expect "exporting another library's folder is named" grep -q "^rtm_pa10 (built in arm/pa10) exports arm/can/include" <<<"$output"
expect "a sibling folder sharing a prefix is not its own" grep -q "^rtm_sim (built in sim) exports simulator/include" <<<"$output"
expect "three violations counted" grep -q "^3 export violation" <<<"$output"
: >"$dir/empty"
"$check" "$root" "$build" "$dir/empty" >/dev/null
expect "an empty list is an error, not a pass" test $? -eq 2
finish
