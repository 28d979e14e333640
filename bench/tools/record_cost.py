#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""What recording costs the force servo's loops: the demo run alternately with and without
`rtm record` (its --no-record), the same system and profile each time.

usage: bench/tools/record_cost.py BIN_DIR [ROUNDS] [--demo-args ...]
  BIN_DIR  the programs (build/default/bin)
  ROUNDS   pairs of runs (default 3), each pair: with, then without (then the next pair the
           other way round, so neither mode always runs first)

Prints per run and per mode: each loop's lateness p99 (rtm ls -l), the sensor sample -> drive
latency p99 (the actuator's), the recorder's CPU (% of one CPU, from the demo's cpu.txt) and
run.mcap's bytes per datum against the CSV files'; then the ratio with / without of the median
of each loop's p99.
"""
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
DEMO = os.path.join(HERE, "..", "..", "examples", "force-servo", "demo")
LOOPS = ["sensor0", "controller0", "actuator0", "joystick0"]


def run(bin_dir, record, extra):
    out = tempfile.mkdtemp(prefix="rtm-record-cost-")
    args = [DEMO, "--bin", bin_dir, "--out", out] + ([] if record else ["--no-record"]) + extra
    subprocess.run(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
    timing = json.load(open(os.path.join(out, "raw", "timing.json")))
    p99 = {c["name"]: c["timing"]["lateness_p99_ns"] / 1000 for c in timing if c.get("timing") and c["name"] in LOOPS}
    actuator = next(c for c in timing if c["name"] == "actuator0")
    latency = actuator["statistics"]["latency_p99"]["value"]
    cpu = None
    for line in open(os.path.join(out, "raw", "cpu.txt")):
        if "rtm record" in line:
            cpu = float(re.findall(r"([0-9.]+) %", line)[0])
    summary = open(os.path.join(out, "summary.txt")).read()
    sizes = re.search(r"\(([0-9.]+) per datum\); the same ports as CSV: [0-9]+ bytes \(([0-9.]+) per datum\)", summary)
    return {"record": record, "p99_us": p99, "latency_p99_us": latency, "recorder_cpu": cpu,
            "mcap_per_datum": float(sizes.group(1)) if sizes else None,
            "csv_per_datum": float(sizes.group(2)) if sizes else None, "out": out}


def main():
    args = sys.argv[1:]
    extra = []
    if "--demo-args" in args:
        i = args.index("--demo-args")
        extra = args[i + 1:]
        args = args[:i]
    if not args:
        print(__doc__, file=sys.stderr)
        return 2
    bin_dir = os.path.abspath(args[0])
    rounds = int(args[1]) if len(args) > 1 else 3
    runs = []
    for r in range(rounds):
        for record in ([True, False] if r % 2 == 0 else [False, True]):
            result = run(bin_dir, record, extra)
            runs.append(result)
            print(("with   " if record else "without"), json.dumps({k: v for k, v in result.items() if k != "record"}),
                  flush=True)
    for loop in LOOPS:
        with_ = statistics.median(r["p99_us"][loop] for r in runs if r["record"])
        without = statistics.median(r["p99_us"][loop] for r in runs if not r["record"])
        print(f"{loop:12s} lateness p99 median: with {with_:.0f} us, without {without:.0f} us, ratio {with_ / without:.2f}")
    with_ = statistics.median(r["latency_p99_us"] for r in runs if r["record"])
    without = statistics.median(r["latency_p99_us"] for r in runs if not r["record"])
    print(f"sample -> drive p99 median: with {with_:.0f} us, without {without:.0f} us, ratio {with_ / without:.2f}")
    cpus = [r["recorder_cpu"] for r in runs if r["record"] and r["recorder_cpu"] is not None]
    if cpus:
        print(f"recorder CPU: median {statistics.median(cpus):.1f} % of one CPU (max {max(cpus):.1f})")
    sizes = [(r["mcap_per_datum"], r["csv_per_datum"]) for r in runs if r["record"] and r["mcap_per_datum"]]
    if sizes:
        print(f"bytes per datum: MCAP {statistics.median(s[0] for s in sizes):.1f}, "
              f"CSV {statistics.median(s[1] for s in sizes):.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
