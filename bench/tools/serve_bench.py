#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""rtm serve's figures, in one run, in headless Chromium (Debian's chromium, chromium-driver,
python3-selenium):

  - first paint: from opening the page to every one of N components drawn (rtm-test-talker
    processes, one omniNames), five times;
  - live plots: 10 OutPorts plotted at once (one server-sent stream for all, 25 events a second,
    each with every datum its ports wrote since the last),
    the data per second each plot received, and received / sent / lost (every datum);
  - what the page costs the 2 ms loops: the talkers' lateness p99 with no page, then with the
    page open and plotting 10 of them, alternating, each phase on freshly started components
    (their statistics cover that phase only).

usage: bench/tools/serve_bench.py [build folder (build/default)] [components (50)] [phase seconds (20)]
                                 [SCHED_FIFO priority of the talkers' loops (0: SCHED_OTHER)]
                                 [nice value of the browser (0)]
"""
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request

from selenium.webdriver.common.by import By

from serve_harness import Processes, headless_chromium, start_naming_service

build = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else "build/default")
count = int(sys.argv[2]) if len(sys.argv) > 2 else 50
phase_s = float(sys.argv[3]) if len(sys.argv) > 3 else 20
rt_priority = int(sys.argv[4]) if len(sys.argv) > 4 else 0
browser_nice = int(sys.argv[5]) if len(sys.argv) > 5 else 0
rtm_bin = os.path.join(build, "bin", "rtm")
talker = os.path.join(build, "tests", "bin", "rtm-test-talker")
work = tempfile.mkdtemp(prefix="rtm-serve-bench-")
processes = Processes()
start, stop = processes.start, processes.stop


def rtm_json(*args):
    out = subprocess.run([rtm_bin, "--naming", naming, "--json", *args], capture_output=True, text=True, timeout=60)
    return json.loads(out.stdout)


def talkers(prefix, n, on):
    extra = (["--on"] if on else []) + (["--rt-priority", str(rt_priority)] if on and rt_priority else [])
    ps = [start([talker, "--name", f"{prefix}{i}", "--naming", naming] + extra) for i in range(n)]
    deadline = time.time() + 60
    while time.time() < deadline:
        names = {c["name"] for c in rtm_json("ls") if c.get("alive")}
        if all(f"{prefix}{i}" in names for i in range(n)):
            return ps
        time.sleep(0.2)
    raise RuntimeError("talkers did not bind")


naming = start_naming_service(processes, work)
driver = headless_chromium(work, browser_nice)
try:
    serve = start([rtm_bin, "--naming", naming, "serve"])
    url = serve.stdout.readline().strip()
    policy = f"SCHED_FIFO {rt_priority}" if rt_priority else "SCHED_OTHER"
    print(f"machine: {os.cpu_count()} CPUs, load {os.getloadavg()[0]:.2f}; {count} components; phases of "
          f"{phase_s:.0f} s; the 10 loops at {policy}; the browser at nice {browser_nice}")

    # ---- first paint with `count` components
    idle = talkers("c", count, False)
    paints = []
    for _ in range(5):
        driver.get("about:blank")
        t0 = time.time()
        driver.get(url)
        while len(driver.find_elements(By.CSS_SELECTOR, "text[data-component]")) < count:
            time.sleep(0.01)
        paints.append(time.time() - t0)
    print(f"first paint, {count} components: median {statistics.median(paints):.2f} s, "
          f"max {max(paints):.2f} s over 5 loads (goal <= 1 s)")
    stop(idle)

    def plot_counts():
        """Per plot: the data the page received, the server sent, and the server counted lost."""
        return driver.execute_script(
            "return [...document.querySelectorAll('#plots canvas')].map(c => "
            "[+(c.dataset.received || 0), +(c.dataset.sent || 0), +(c.dataset.lost || 0)])")

    # ---- alternating phases: no page / page with 10 plots, fresh talkers each phase
    rows = []
    for phase in ("no page", "page, 10 plots", "no page", "page, 10 plots"):
        ps = talkers("p", 10, True)
        rate = None
        if phase.startswith("page"):
            driver.get("about:blank")
            driver.get(url)
            while len(driver.find_elements(By.CSS_SELECTOR, "text[data-component]")) < 10:
                time.sleep(0.05)
            for i in range(10):
                driver.execute_script(
                    f"document.querySelector('circle[data-port=\"p{i}.force\"]').dispatchEvent(new MouseEvent('click'))")
            before, started = plot_counts(), time.monotonic()
        else:
            driver.get("about:blank")
        time.sleep(phase_s)
        if phase.startswith("page"):
            after, elapsed = plot_counts(), time.monotonic() - started
            rates = [(a[0] - b[0]) / elapsed for a, b in zip(after, before)]
            # every datum: what the page received of what the server sent, and what was lost on the way
            received, sent, lost = (sum(a[i] for a in after) for i in range(3))
            rate = (len(rates), min(rates), statistics.median(rates), received, sent, lost)
        timing = [c["timing"] for c in rtm_json("ls", "-l") if c["name"].startswith("p")]
        p99 = statistics.median(t["lateness_p99_ns"] for t in timing) / 1000
        worst = max(t["lateness_p99_ns"] for t in timing) / 1000
        overruns = sum(t["overruns"] for t in timing)
        cycles = sum(t["cycles"] for t in timing)
        rows.append((phase, p99, worst, overruns, cycles, rate))
        line = f"{phase:<16} lateness p99 median {p99:7.1f} us, worst {worst:7.1f} us; overruns {overruns} of {cycles}"
        if rate:
            line += (f"; {rate[0]} plots, data/s min {rate[1]:.1f} median {rate[2]:.1f}, "
                     f"received {rate[3]} of {rate[4]} sent, {rate[5]} lost (goal: every datum)")
        print(line, flush=True)
        driver.get("about:blank")
        stop(ps)
    without = statistics.mean(r[1] for r in rows if r[0] == "no page")
    with_page = statistics.mean(r[1] for r in rows if r[0] != "no page")
    print(f"lateness p99 with the page / without: {with_page / without:.2f} (goal <= 1.1)")
finally:
    driver.quit()
    stop()
    shutil.rmtree(work, ignore_errors=True)
