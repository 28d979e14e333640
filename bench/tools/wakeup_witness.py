#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""A witness for host stalls: sleeps to a 1 ms absolute grid at SCHED_FIFO 25 for SECONDS and
prints every wake-up more than 4 ms late with its wall-clock time, to set beside a run's events
(e.g. the demo's watchdog events, which name their time). Needs root or CAP_SYS_NICE.

usage: bench/tools/wakeup_witness.py SECONDS
"""
import os
import sys
import time

seconds = float(sys.argv[1]) if len(sys.argv) > 1 else 45
os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(25))
period = 0.001
start = time.monotonic()
deadline = start + period
stalls, wakeups, worst = [], 0, 0.0
while time.monotonic() - start < seconds:
    wait = deadline - time.monotonic()
    if wait > 0:
        time.sleep(wait)
    late = time.monotonic() - deadline
    worst = max(worst, late)
    wakeups += 1
    if late > 0.004:
        stalls.append(f"{time.strftime('%H:%M:%S', time.gmtime())}.{int(time.time() % 1 * 1000):03d} UTC {late * 1000:.1f} ms")
    deadline += period
    if deadline < time.monotonic():  # after a stall: back on the grid, no burst
        deadline = time.monotonic() + period
print(f"{wakeups} wake-ups, worst {worst * 1000:.1f} ms late; over 4 ms late: {', '.join(stalls) or 'none'}")
