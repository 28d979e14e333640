#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The guest runner (scripts/vm-vcan-run) reports what the guest did: the command's exit code and
# output, the caller's environment and directory, the vcan interfaces asked for, modules loaded
# on demand, writes that vanish unless written through, a timeout (124), bad usage (2), and a
# host where no guest can start (a skip that says why, or 125).
# Exits 77 (skipped) only when no guest can be started on this host, saying why.
# usage: vm_runner_test.sh <path to vm-vcan-run>
set -uo pipefail
runner=$(realpath "$1")
probe=$("$runner" --probe 2>&1) || { echo "SKIPPED: $probe"; exit 77; }
echo "$probe"

failures=0
check() { # what, then a command that must succeed
  local what=$1; shift
  if "$@"; then echo "ok   $what"; else echo "FAIL $what"; failures=$((failures + 1)); fi
}

scratch=$(mktemp -d "${TMPDIR:-/tmp}/vm-runner-test.XXXXXX")
through=$scratch/through
mkdir -p "$through" "$scratch/here"
trap 'rm -rf "$scratch"' EXIT

# One boot checks everything a command sees; its exit code is 7 on purpose.
cat >"$scratch/guest.sh" <<'GUEST'
echo "kernel $(uname -r)"
echo "cwd $PWD"
echo "value [$RTM_VM_TEST_VALUE]"
for i in vcan0 vcan1; do ip -br link show "$i" | grep -q 'UP' && echo "up $i"; done
modprobe can-bcm && grep -q '^can_bcm ' /proc/modules && echo "loaded can_bcm"
echo kept >"$1/kept" && echo gone >"$2/gone" && echo "wrote both"
echo "to stderr" >&2
exit 7
GUEST
output=$(cd "$scratch/here" && RTM_VM_TEST_VALUE='a b $c "d"' \
  "$runner" -t 200 -i vcan0 -i vcan1 -w "$through" -- bash "$scratch/guest.sh" "$through" "$scratch/here" 2>&1)
status=$?
echo "$output" | sed 's/^/  guest: /'
check "the command's exit code comes back (7)" test "$status" -eq 7
guest_kernel=${probe##*kernel }
check "the guest runs the runner's kernel ($guest_kernel)" grep -qxF "kernel $guest_kernel" <<<"$output"
check "the command runs in the caller's directory" grep -qxF "cwd $scratch/here" <<<"$output"
check "the environment arrives unchanged" grep -qxF 'value [a b $c "d"]' <<<"$output"
check "vcan0 is up" grep -qx "up vcan0" <<<"$output"
check "a second interface asked with -i is up" grep -qx "up vcan1" <<<"$output"
check "a module loads on demand" grep -qx "loaded can_bcm" <<<"$output"
check "stderr comes back with stdout" grep -qx "to stderr" <<<"$output"
check "the guest could write" grep -qx "wrote both" <<<"$output"
check "a -w directory writes through to the host" test "$(cat "$through/kept" 2>/dev/null)" = kept
check "other writes vanish at power-off" test ! -e "$scratch/here/gone"

# A command that outlives -t: exit code 124, and the runner says so.
started=$(date +%s)
output=$("$runner" -t 20 -- sleep 600 2>&1)
status=$?
elapsed=$(($(date +%s) - started))
echo "$output" | sed 's/^/  timeout: /'
check "a command past -t ends with 124" test "$status" -eq 124
check "the timeout is reported" grep -q "did not finish within 20 s" <<<"$output"
check "the guest is stopped at the timeout, not later ($elapsed s)" test "$elapsed" -lt 60

# Bad usage is refused before anything boots.
"$runner" >/dev/null 2>&1
check "no command is a usage error (2)" test $? -eq 2
"$runner" -t soon -- true >/dev/null 2>&1
check "a timeout that is not a number is a usage error (2)" test $? -eq 2
"$runner" -w "$scratch/does-not-exist" -- true >/dev/null 2>&1
check "a -w directory that does not exist is a usage error (2)" test $? -eq 2

# Where no guest can start, --skip-code turns that into a skip that says why, and without it the
# runner fails (125) with the same reason; --probe says so too.
output=$(RTM_VM_QEMU=/nonexistent/qemu "$runner" --skip-code 77 -- true 2>&1)
check "no QEMU: --skip-code's code (77)" test $? -eq 77
check "no QEMU: the skip says why" grep -q "SKIPPED.*qemu-system-x86_64 not found" <<<"$output"
output=$(RTM_VM_QEMU=/nonexistent/qemu "$runner" -- true 2>&1)
check "no QEMU and no --skip-code: the guest could not run it (125)" test $? -eq 125
RTM_VM_QEMU=/nonexistent/qemu "$runner" --probe >/dev/null 2>&1
check "no QEMU: --probe fails (1)" test $? -eq 1

if ((failures)); then echo "$failures check(s) failed"; exit 1; fi
echo "all checks passed"
