#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""bench/tools/wakeup_witness.py's StallMeter on made-up clocks: a stall is measured where it
falls, in the sleep (a late wake-up) or while the loop ran between two sleeps (a long gap since
the last wake-up), once, and a loop on its grid measures nothing; LostTime adds short stalls
into episodes within its window, and nothing else.

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

# Short stalls add up (LostTime, threshold 2 ms, floor 0.2 ms, window 20 ms).
FLOOR, THRESHOLD, WINDOW = 0.2 * MS, 2 * MS, 20 * MS

# Three wake-ups 0.8 ms late, 1 ms apart: 2.4 ms lost, an episode at the third, spanning from
# the first slice's start; the next slices start a new count.
lost = witness.LostTime(FLOOR, THRESHOLD, WINDOW)
episodes = [lost.woke(t * MS, 0.8 * MS) for t in (10, 11, 12)]
check(episodes[:2] == [None, None], f"no episode before the slices add up to the threshold: {episodes}")
check(episodes[2] is not None and abs(episodes[2][0] - 2.4 * MS) < 1e-9,
      f"slices that add up to the threshold are an episode of their sum: {episodes[2]}")
check(episodes[2] is not None and abs(episodes[2][1] - 2.8 * MS) < 1e-9,
      f"... spanning from the first slice's start (9.2 ms) to the last wake-up (12 ms): {episodes[2]}")
check(lost.woke(13 * MS, 0.8 * MS) is None, "after an episode the count starts again")

# The same slices spread wider than the window do not add up; slices under the floor (the
# wake-up's own cost) never count; a stall over the threshold is reported on its own, not here.
lost = witness.LostTime(FLOOR, THRESHOLD, WINDOW)
spread = [lost.woke(t * MS, 0.8 * MS) for t in (10, 40, 70, 100)]
check(spread == [None] * 4, f"slices further apart than the window are no episode: {spread}")
lost = witness.LostTime(FLOOR, THRESHOLD, WINDOW)
small = [lost.woke(t * MS, 0.15 * MS) for t in range(1, 40)]
check(small == [None] * 39, f"wake-ups under the floor late are no slice: {small}")
lost = witness.LostTime(FLOOR, THRESHOLD, WINDOW)
check(lost.woke(5 * MS, 3 * MS) is None, "a stall over the threshold is not counted again as an episode")
check(lost.woke(6 * MS, 1.5 * MS) is None, "... nor added to the next slices")

# On a StallMeter's measure: the host takes 1.5 ms of every 2 while the loop (1 ms period)
# sleeps. No wake-up is 2 ms late, yet every 2 ms the loop loses 1.5: an episode within 3 ms.
meter = witness.StallMeter(0.0, PERIOD)
lost = witness.LostTime(FLOOR, THRESHOLD, WINDOW)
now, found, worst = 0.0, None, 0.0
for _ in range(6):
    now = meter.deadline + 1.5 * MS if round(meter.deadline / MS) % 2 == 0 else meter.deadline
    late = meter.woke(now)
    worst = max(worst, late)
    found = found or lost.woke(now, late)
    meter.next(now + 0.03 * MS)
check(worst < THRESHOLD, f"no single wake-up of a slowed vCPU is a stall: worst {worst}")
check(found is not None and found[0] >= THRESHOLD, f"... but its slices are an episode: {found}")

print("wakeup_witness_test: " + ("FAILED" if failures else "ok"))
sys.exit(1 if failures else 0)
