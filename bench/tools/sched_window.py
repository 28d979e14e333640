#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""What ran on each CPU in a window of a scheduler trace (bench/tools/demo_sched_trace.sh):
every switch to or from a real-time thread, and each stretch of 1.5 ms or more in which a CPU
recorded nothing (a host stall, or one thread running on).

usage: bench/tools/sched_window.py TRACE OFFSET_FILE FROM TO
  FROM, TO: wall-clock times of the day, HH:MM:SS.ffffff, as the components' logs stamp theirs.
"""
import datetime
import re
import sys

SWITCH = re.compile(r"^\s*.+?-\d+\s+\[(\d+)\]\s+\S+\s+([\d.]+): sched_switch: prev_comm=(.*?) prev_pid=(\d+) "
                    r"prev_prio=(\d+) prev_state=(\S+) ==> next_comm=(.*?) next_pid=(\d+) next_prio=(\d+)")
ANY = re.compile(r"^\s*.+?-\d+\s+\[(\d+)\]\s+\S+\s+([\d.]+): ")


def main():
    if len(sys.argv) != 5:
        print(__doc__, file=sys.stderr)
        return 2
    trace, offset_file, first, last = sys.argv[1:]
    offset = float(open(offset_file).read())  # wall clock - CLOCK_MONOTONIC, seconds
    with open(trace) as lines:  # the day of the trace's first event
        day = next(datetime.date.fromtimestamp(float(m.group(2)) + offset) for m in map(ANY.match, lines) if m)

    def monotonic(text):
        wall = datetime.datetime.strptime(f"{day} {text}", "%Y-%m-%d %H:%M:%S.%f").timestamp()
        return wall - offset

    begin, end = monotonic(first), monotonic(last)
    last_seen = {}
    with open(trace) as lines:
        for line in lines:
            any_event = ANY.match(line)
            if not any_event:
                continue
            cpu, stamp = int(any_event.group(1)), float(any_event.group(2))
            if stamp < begin:
                continue
            if stamp > end:
                break
            if cpu in last_seen and stamp - last_seen[cpu] >= 0.0015:
                print(f"   cpu{cpu}: nothing recorded for {1e3 * (stamp - last_seen[cpu]):.1f} ms")
            last_seen[cpu] = stamp
            switch = SWITCH.match(line)
            if not switch:
                continue
            _, _, prev, prev_pid, prev_prio, state, nxt, next_pid, next_prio = switch.groups()
            if int(prev_prio) < 100 or int(next_prio) < 100:  # a real-time thread (kernel prio < 100)
                wall = datetime.datetime.fromtimestamp(stamp + offset).strftime("%H:%M:%S.%f")
                print(f"{wall} cpu{cpu} {prev}/{prev_pid} (prio {prev_prio}, {state}) -> {nxt}/{next_pid} (prio {next_prio})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
