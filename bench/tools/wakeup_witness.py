#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""A witness for host stalls: sleeps to an absolute grid at SCHED_FIFO for SECONDS (or until
SIGINT/SIGTERM) and reports every wake-up later than the threshold with its wall-clock time, to
set beside a run's events (e.g. the demo's watchdog events, which name their time).

At the highest priority (the default, 99) nothing of the run can hold it off: a late wake-up is
the host (the hypervisor took the vCPU) or the kernel. A vCPU can stall alone, so the demo runs
one witness pinned to each CPU. Needs root or CAP_SYS_NICE for the priority.

A stall is seen wherever it falls: in the sleep (the wake-up is late) or while the witness runs
between two sleeps (the gap since the last wake-up is longer than a period). The second kind
is common on these VMs, where the host often takes the vCPU just after a timer woke it; a
witness that only timed its wake-ups missed them (StallMeter, tested in
tests/tools/wakeup_witness_test.py).

usage: bench/tools/wakeup_witness.py [--cpu N] [--priority P] [--period-ms MS]
                                     [--threshold-ms MS] [--lost-floor-ms MS]
                                     [--lost-window-ms MS] [--out FILE] [SECONDS]

Without --out: one summary line at the end (stalls over the threshold, default 4 ms). With
--out FILE: each stall is appended to FILE as it is seen, one line
"HH:MM:SS.mmm LATE_MS" (local time of the wake-up, as the components' logs stamp theirs), and
the summary line goes to standard output.

Short stalls add up: on these VMs the host often takes a vCPU in slices of a millisecond or so,
none over the threshold, and a thread on the other CPU that waits on this one (a socket, a lock)
then stalls with it. Each wake-up later than --lost-floor-ms (default 0.2) is such a slice; when
the slices within --lost-window-ms (default 20) add up to the threshold, the witness reports an
episode, "HH:MM:SS.mmm LOST_MS SPAN_MS" (LOST_MS in slices over the SPAN_MS before that time),
and starts adding again (LostTime).
"""
import argparse
import collections
import os
import signal
import sys
import time


class StallMeter:
    """How late each wake-up of a loop on a grid of `period` seconds is, stalls while the loop
    ran included. All times are time.monotonic() seconds."""

    def __init__(self, start, period):
        self.period = period
        self.deadline = start + period
        self.previous = start

    def woke(self, now):
        """The loop woke at `now` for self.deadline: how late that is, the later of the wake-up
        itself and the gap since the last wake-up beyond one period (a stall while it ran)."""
        late = max(now - self.deadline, now - self.previous - self.period)
        self.previous = now
        return late

    def next(self, now):
        """The next deadline, after the loop's work ended at `now`: on the grid, or, after a
        stall, a period from now (no burst of wake-ups to catch up)."""
        self.deadline += self.period
        if self.deadline < now:
            self.deadline = now + self.period
        return self.deadline


class LostTime:
    """Adds up the short stalls a StallMeter measures: each wake-up later than `floor` (but not
    over `threshold`, which is reported as a stall of its own) is time the host took the vCPU.
    When they add up to `threshold` within `window` seconds, that is an episode: the host took as
    much of the CPU as one stall would, in slices too short for any one to be seen. The vCPU is
    then slow rather than stopped, and a thread on the other CPU that waits on it (a socket, a
    lock) stops with it."""

    def __init__(self, floor, threshold, window):
        self.floor, self.threshold, self.window = floor, threshold, window
        self.slices = collections.deque()  # (when the slice began, its length)
        self.total = 0.0

    def woke(self, now, late):
        """A wake-up at `now`, `late` seconds late. Returns (lost, span) when this completes an
        episode: the time lost and the span from the first slice's start to `now`; else None."""
        while self.slices and self.slices[0][0] < now - self.window:
            self.total -= self.slices.popleft()[1]
        if not self.floor < late <= self.threshold:
            return None
        self.slices.append((now - late, late))
        self.total += late
        if self.total < self.threshold:
            return None
        episode = (self.total, now - self.slices[0][0])
        self.slices.clear()
        self.total = 0.0
        return episode


def main():
    parser = argparse.ArgumentParser(description="host stall witness")
    parser.add_argument("seconds", nargs="?", type=float, default=45.0)
    parser.add_argument("--cpu", type=int, default=None, help="pin to this CPU")
    parser.add_argument("--priority", type=int, default=99, help="SCHED_FIFO priority (1..99)")
    parser.add_argument("--period-ms", type=float, default=1.0)
    parser.add_argument("--threshold-ms", type=float, default=4.0)
    parser.add_argument("--lost-floor-ms", type=float, default=0.2,
                        help="a wake-up later than this is a short stall, added up into episodes")
    parser.add_argument("--lost-window-ms", type=float, default=20.0,
                        help="short stalls adding up to the threshold within this are an episode")
    parser.add_argument("--out", default=None)
    args = parser.parse_args()
    if (args.period_ms <= 0 or args.threshold_ms <= 0 or not 1 <= args.priority <= 99 or
            not 0 < args.lost_floor_ms < args.threshold_ms or args.lost_window_ms <= 0):
        parser.error("want --period-ms > 0, --threshold-ms > 0, --priority in 1..99, "
                     "0 < --lost-floor-ms < --threshold-ms and --lost-window-ms > 0")

    if args.cpu is not None:
        os.sched_setaffinity(0, {args.cpu})
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(args.priority))
    except PermissionError:
        print("wakeup_witness: SCHED_FIFO refused (needs root or CAP_SYS_NICE)", file=sys.stderr)
        return 2

    stop = False

    def request_stop(*_):
        nonlocal stop
        stop = True

    signal.signal(signal.SIGINT, request_stop)
    signal.signal(signal.SIGTERM, request_stop)
    out = open(args.out, "a", buffering=1) if args.out else None
    period = args.period_ms / 1000
    threshold = args.threshold_ms / 1000
    start = time.monotonic()
    meter = StallMeter(start, period)
    lost = LostTime(args.lost_floor_ms / 1000, threshold, args.lost_window_ms / 1000)
    stalls, episodes, wakeups, worst = [], 0, 0, 0.0

    def stamp():
        now = time.time()
        return f"{time.strftime('%H:%M:%S', time.localtime(now))}.{int(now % 1 * 1000):03d}"

    while not stop and time.monotonic() - start < args.seconds:
        wait = meter.deadline - time.monotonic()
        if wait > 0:
            time.sleep(wait)
        woke = time.monotonic()
        late = meter.woke(woke)
        worst = max(worst, late)
        wakeups += 1
        if late > threshold:
            when = stamp()
            stalls.append(f"{when} {late * 1000:.1f} ms")
            if out:
                out.write(f"{when} {late * 1000:.1f}\n")
        episode = lost.woke(woke, late)
        if episode:
            episodes += 1
            if out:
                out.write(f"{stamp()} {episode[0] * 1000:.1f} {episode[1] * 1000:.1f}\n")
        meter.next(time.monotonic())
    where = f" on CPU {args.cpu}" if args.cpu is not None else ""
    if out:
        print(f"{wakeups} wake-ups{where}, worst {worst * 1000:.1f} ms late; "
              f"{len(stalls)} over {args.threshold_ms:g} ms and {episodes} episodes of as much in short stalls "
              f"(in {args.out})")
    else:
        print(f"{wakeups} wake-ups{where}, worst {worst * 1000:.1f} ms late; over {args.threshold_ms:g} ms late: "
              f"{', '.join(stalls) or 'none'}; {episodes} episodes of {args.threshold_ms:g} ms lost in short stalls "
              f"within {args.lost_window_ms:g} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
