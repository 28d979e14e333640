#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""bench/tools/wakeup_witness.py's StallMeter on made-up clocks: a stall is measured where it
falls, in the sleep (a late wake-up) or while the loop ran between two sleeps (a long gap since
the last wake-up), once, and a loop on its grid measures nothing.

usage: wakeup_witness_test.py PATH_TO_wakeup_witness.py
"""
import importlib.util
import sys

spec = importlib.util.spec_from_file_location("wakeup_witness", sys.argv[1])
witness = importlib.util.module_from_spec(spec)
spec.loader.exec_module(witness)

failures = []


def check(condition, what):
    if not condition:
        failures.append(what)
        print("FAILED: " + what)


MS = 1e-3
PERIOD = 1 * MS

# On the grid, each wake-up 20 us late and 30 us of work: nothing near a stall.
meter = witness.StallMeter(0.0, PERIOD)
lates = []
for k in range(1, 6):
    lates.append(meter.woke(k * PERIOD + 0.02 * MS))
    meter.next(k * PERIOD + 0.05 * MS)
check(all(late < 0.05 * MS for late in lates), f"a loop on its grid measures no stall: {lates}")

# A stall in the sleep: the wake-up for 1 ms comes at 5 ms.
meter = witness.StallMeter(0.0, PERIOD)
late = meter.woke(5 * MS)
check(abs(late - 4 * MS) < 1e-9, f"a late wake-up is measured as its lateness: {late}")
meter.next(5.03 * MS)  # after the stall: a period from now, no burst
check(abs(meter.deadline - 6.03 * MS) < 1e-9, f"after a stall the grid resumes a period later: {meter.deadline}")
late = meter.woke(6.03 * MS)
check(late < 0.05 * MS, f"the stall in the sleep is measured once, not again at the next wake-up: {late}")

# A stall while the loop runs: it wakes on time at 1 ms, and its work ends at 6 ms (the host
# took the vCPU); it then sleeps a period and wakes on time. Timing the wake-ups alone sees
# nothing; the gap since the last one shows the 5 ms.
meter = witness.StallMeter(0.0, PERIOD)
first = meter.woke(1.01 * MS)
meter.next(6.0 * MS)
check(abs(meter.deadline - 7.0 * MS) < 1e-9, f"the loop sleeps a period after its stalled run: {meter.deadline}")
second = meter.woke(7.0 * MS)
check(first < 0.05 * MS, f"the wake-up before the stall was on time: {first}")
check(second > 4.9 * MS, f"a stall while the loop ran is measured at the next wake-up: {second}")
check(second < 5.1 * MS, f"... and not as more than the gap it left: {second}")
meter.next(7.03 * MS)
third = meter.woke(8.0 * MS)
check(third < 0.05 * MS, f"... and once: {third}")

print("wakeup_witness_test: " + ("FAILED" if failures else "ok"))
sys.exit(1 if failures else 0)
