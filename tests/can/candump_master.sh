#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Inside the guest (scripts/vm-vcan-run): records vcan0 with candump while the master test runs, then checks the
# recording holds the protocol's traffic (SYNC, every drive's RPDO and TPDO, both sensors' TPDOs,
# NMT, SDO and heartbeats). usage: candump_master.sh <can_socketcan_test binary>
set -eu
test_binary=$1
command -v candump >/dev/null || { echo "candump not found (package can-utils)"; exit 1; }
dump=/tmp/vcan0.log
candump -L vcan0 >"$dump" &
candump_pid=$!
trap 'kill $candump_pid 2>/dev/null || true' EXIT
sleep 0.2  # candump must be listening before the first frame
"$test_binary" --gtest_filter='SocketCan.MasterStartsTheEmulatedPa10AndExchangesPdos'
sleep 0.2
kill $candump_pid
wait $candump_pid 2>/dev/null || true
trap - EXIT
# candump -L lines: "(1700000000.000000) vcan0 080#01"
count() { grep -c " vcan0 $1#" "$dump" || true; }
status=0
expect() {  # id, minimum count, what
  n=$(count "$1")
  printf '%-4s %-34s %6s frames\n' "$1" "$3" "$n"
  [ "$n" -ge "$2" ] || { echo "  expected at least $2"; status=1; }
}
echo "candump recorded $(wc -l <"$dump") frames on vcan0:"
expect 000 2 "NMT (pre-operational, start)"
expect 080 50 "SYNC"
for d in 1 2 3 4 5 6 7; do
  expect 20$d 50 "RPDO1 drive $d"
  expect 18$d 50 "TPDO1 drive $d"
done
expect 190 50 "TPDO1 wrist sensor force"
expect 290 50 "TPDO2 wrist sensor torque"
expect 191 50 "TPDO1 joystick sensor force"
expect 291 50 "TPDO2 joystick sensor torque"
expect 601 2 "SDO request drive 1"
expect 581 2 "SDO response drive 1"
expect 701 1 "heartbeat drive 1"
# The SYNC payload is the counter: the first must be 01.
first_sync=$(grep -m1 " vcan0 080#" "$dump" | sed 's/.*#//')
[ "$first_sync" = "01" ] || { echo "first SYNC carried $first_sync, expected 01"; status=1; }
exit $status
