#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""What `import rtm` costs against the same C++ (docs/performance.md, "Python"):

  get/put   calls a second of Port.get() and Port.put() from a Python loop, beside the same
            calls made from C++ in the same process (Port._repeat_get/_repeat_put: each still
            releases and takes the GIL, as a call from Python does), alternating, per round;
  watch     a watch of a 2 ms OutPort (rtm-test-talker, C++) for --seconds: data received,
            dropped, and gaps in the ramp (one datum a cycle, in order);
  component a 2 ms component in Python (tests/python/doubler.py: read a wrench, write it times
            a factor) beside one in C++ doing the same (rtm-test-talker: read a wrench, write
            one), both fed by a third, in one run of --seconds: lateness, overruns, and the
            Python one's wait for the GIL and step() holding it; beside them a second Python
            one reading with read_values() instead of read() (no Datum made);
  motion    a motion script's cycle (rtm.motion's Arm._cycle during a slide at 10 N, as the
            script component's step calls it), in --rounds of --calls cycles, and with
            --baseline FILE (an earlier rtm/motion.py) the same cycles of that one, alternating.

  PYTHONPATH=build/default/python python3 bench/python/python_bench.py \\
      --bin build/default/tests/bin [--calls 20000] [--rounds 5] [--seconds 60] [--parts get_put,watch,component]
  PYTHONPATH=build/default/python python3 bench/python/python_bench.py --parts motion [--baseline FILE]

It starts its own omniNames on a free loopback port and the components, and stops them all.
"""

import argparse
import importlib.util
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "tests", "python"))

import rtm  # noqa: E402
from rtm_processes import NamingService, start_component, stop, wait_for  # noqa: E402


def rate(calls, seconds):
    return calls / seconds if seconds > 0 else float("inf")


def get_put(system, calls, rounds):
    out, inp = system.port("talk0.force"), system.port("talk0.pos3")
    values = [0.1, 0.2, 0.3]
    rows = {"get": ([], []), "put": ([], [])}
    for _ in range(rounds):
        start = time.perf_counter()
        for _ in range(calls):
            out.get()
        rows["get"][0].append(rate(calls, time.perf_counter() - start))
        rows["get"][1].append(rate(calls, out._repeat_get(calls)))
        start = time.perf_counter()
        for _ in range(calls):
            inp.put(values)
        rows["put"][0].append(rate(calls, time.perf_counter() - start))
        rows["put"][1].append(rate(calls, inp._repeat_put(values, calls)))
    print(f"get/put: {calls} calls a round, {rounds} rounds, median (range)")
    for name, (py, cpp) in rows.items():
        p, c = statistics.median(py), statistics.median(cpp)
        print(f"  {name}: Python {p:8.0f} calls/s ({min(py):.0f}-{max(py):.0f}), "
              f"C++ {c:8.0f} calls/s ({min(cpp):.0f}-{max(cpp):.0f}), Python/C++ time {c / p:.2f}x")


def watch(system, seconds):
    with system.watch("talk0.force", capacity=1024, timeout=5) as data:
        first = previous = None
        gaps = taken = 0
        end = time.monotonic() + seconds
        for datum in data:
            n = datum.values[0]
            if previous is not None and n != previous + 1:
                gaps += 1
            first = n if first is None else first
            previous = n
            taken += 1
            if time.monotonic() >= end:
                break
        print(f"watch of a 2 ms port for {seconds} s: {taken} data taken, received {data.received}, "
              f"dropped {data.dropped}, late {data.late}, gaps in the ramp {gaps}, "
              f"shared memory {data.shared_memory}")


def component(system, names, test_bin, seconds):
    doubler = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "python", "doubler.py")
    started = [start_component([sys.executable, doubler], "py0", names.address, "--on"),
               start_component([sys.executable, doubler], "pyv0", names.address, "--on", "--param", "light=1"),
               start_component(os.path.join(test_bin, "rtm-test-talker"), "cpp0", names.address, "--on")]
    try:
        if not wait_for(lambda: {"py0", "pyv0", "cpp0"} <= set(system.components())):
            sys.exit("py0, pyv0 or cpp0 did not come up")
        for name in ("py0", "pyv0", "cpp0"):
            system.connect("talk0.force", f"{name}.in0")
        time.sleep(seconds)
        rows = {name: system.describe(name) for name in ("py0", "pyv0", "cpp0")}
    finally:
        for process in started:
            stop(process)
    print(f"component at 2 ms, {seconds} s, beside each other (lateness: wake-up after the cycle was due)")
    for name, d in rows.items():
        t = d["timing"]
        print(f"  {name}: {t['cycles']} cycles, overruns {t['overruns']}, lateness p50 {t['lateness_p50_ns'] / 1e3:.1f} us, "
              f"p99 {t['lateness_p99_ns'] / 1e3:.1f} us, max {t['lateness_max_ns'] / 1e3:.1f} us")
    def stat(name, key):
        return rows[name]["statistics"][key]["value"]

    for name, how in (("py0", "read()"), ("pyv0", "read_values()")):
        print(f"  {name} ({how}) GIL: wait p50 {stat(name, 'python.gil_wait_p50'):.1f} us, "
              f"p99 {stat(name, 'python.gil_wait_p99'):.1f} us, max {stat(name, 'python.gil_wait_max'):.1f} us; "
              f"step() holding it p50 {stat(name, 'python.step_p50'):.1f} us, "
              f"p99 {stat(name, 'python.step_p99'):.1f} us, max {stat(name, 'python.step_max'):.1f} us")
    ratio = {q: stat("pyv0", f"python.step_{q}") / stat("py0", f"python.step_{q}") for q in ("p50", "p99")}
    print(f"  step() read_values() / read(): p50 {ratio['p50']:.2f}x, p99 {ratio['p99']:.2f}x")
    ratio = rows["py0"]["timing"]["lateness_p99_ns"] / max(1, rows["cpp0"]["timing"]["lateness_p99_ns"])
    print(f"  lateness p99, Python / C++: {ratio:.2f}x")


def motion_cycles(module, calls):
    """Seconds each of `calls` cycles of a slide took, in order."""
    import numpy as np

    arm = module.Arm([0.0004] * 3, [0.003] * 3, 1.0, 0.005)
    wrench, pose = np.array([0.5, 0.1, -10.0, 0, 0, 0]), np.array([0.55, 0, 0.23, 0, 0, 0])
    state = arm._state
    state.normal, state.in_contact = module.direction("-z"), True
    arm._hold_force, arm._hold_point = 10.0, pose[:3].copy()
    arm._cycle(0.0, wrench, pose)
    arm._current = module._Slide(module.direction("x"), 0.05, 0.01, 10.0)
    step = np.array([1e-5, 1e-6, 0, 0, 0, 0])
    took = []
    for i in range(calls):
        moved = pose + i * step
        started = time.perf_counter()
        arm._cycle(0.002 * (i + 1), wrench, moved)
        took.append(time.perf_counter() - started)
    return took


def motion(calls, rounds, baseline):
    import rtm.motion

    modules = [("rtm.motion", rtm.motion)]
    if baseline:
        spec = importlib.util.spec_from_file_location("motion_baseline", baseline)
        old = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(old)
        modules.append((f"baseline {os.path.basename(baseline)}", old))
    p50s = {name: [] for name, _ in modules}
    print(f"a motion script's cycle during a slide (Arm._cycle), {rounds} rounds of {calls} cycles, alternating")
    for r in range(rounds):
        for name, module in modules:
            took = sorted(motion_cycles(module, calls))
            p50, p99 = took[len(took) // 2] * 1e6, took[int(len(took) * 0.99)] * 1e6
            p50s[name].append(p50)
            print(f"  round {r + 1} {name}: p50 {p50:.1f} us, p99 {p99:.1f} us, max {took[-1] * 1e6:.1f} us")
    medians = {name: statistics.median(v) for name, v in p50s.items()}
    for name, m in medians.items():
        print(f"  {name}: median of the rounds' p50 {m:.1f} us")
    if baseline:
        print(f"  rtm.motion / baseline: {medians['rtm.motion'] / medians[modules[1][0]]:.2f}x")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--bin", help="the folder of rtm-test-talker (build/default/tests/bin)")
    parser.add_argument("--baseline", help="motion: an earlier rtm/motion.py to time beside this one")
    parser.add_argument("--calls", type=int, default=20000)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--seconds", type=float, default=60)
    parser.add_argument("--parts", default="get_put,watch,component")
    args = parser.parse_args()
    parts = args.parts.split(",")
    if "motion" in parts:
        motion(args.calls, args.rounds, args.baseline)
        parts.remove("motion")
    if not parts:
        return
    if not args.bin:
        parser.error("--bin: the folder of rtm-test-talker, for get_put, watch and component")
    names = NamingService()
    talker = None
    try:
        talker = start_component(os.path.join(args.bin, "rtm-test-talker"), "talk0", names.address, "--on")
        system = rtm.System(naming=names.address)
        if not wait_for(lambda: "talk0" in system.components()):
            sys.exit("talk0 did not come up")
        wait_for(lambda: system.describe("talk0")["timing"]["cycles"] > 0)
        if "get_put" in parts:
            get_put(system, args.calls, args.rounds)
        if "watch" in parts:
            watch(system, args.seconds)
        if "component" in parts:
            component(system, names, args.bin, args.seconds)
    finally:
        if talker is not None:
            stop(talker)
        names.stop()


if __name__ == "__main__":
    main()
