#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""What `rtm serve`'s page costs in CPU, process by process, in headless Chromium (Debian's
chromium, chromium-driver, python3-selenium): ten rtm-test-talker components on at 2 ms, one
omniNames, rtm serve; then three phases of equal length: no page (about:blank), the page open
with no plot, the page open plotting all ten OutPorts. For each phase, the CPU time each group of
processes used (utime + stime from /proc), as a share of one CPU.

usage: bench/tools/serve_cpu.py [build folder (build/default)] [phase seconds (15)]
"""
import os
import shutil
import sys
import tempfile
import time

from selenium.webdriver.common.by import By

from serve_harness import Processes, headless_chromium, start_naming_service

build = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else "build/default")
phase_s = float(sys.argv[2]) if len(sys.argv) > 2 else 15
rtm_bin = os.path.join(build, "bin", "rtm")
talker = os.path.join(build, "tests", "bin", "rtm-test-talker")
work = tempfile.mkdtemp(prefix="rtm-serve-cpu-")
processes = Processes()

GROUPS = {
    "chromium renderer": lambda c: "chrom" in c and "--type=renderer" in c,
    "chromium gpu": lambda c: "chrom" in c and "--type=gpu" in c,
    "chromium other": lambda c: "chrom" in c and "--type=renderer" not in c and "--type=gpu" not in c,
    "rtm serve": lambda c: c.startswith(rtm_bin) and " serve" in c,
    "10 talkers": lambda c: "rtm-test-talker" in c,
    "omniNames": lambda c: c.startswith("omniNames"),
}


def cpu_seconds():
    """CPU seconds used so far by each group's live processes."""
    used = dict.fromkeys(GROUPS, 0.0)
    tick = os.sysconf("SC_CLK_TCK")
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                cmd = f.read().replace(b"\0", b" ").decode(errors="replace")
            with open(f"/proc/{pid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        for name, match in GROUPS.items():
            if match(cmd):
                used[name] += (int(fields[11]) + int(fields[12])) / tick
    return used


naming = start_naming_service(processes, work)
driver = headless_chromium(work)
try:
    url = processes.start([rtm_bin, "--naming", naming, "serve"]).stdout.readline().strip()
    for i in range(10):
        processes.start([talker, "--name", f"p{i}", "--naming", naming, "--on"])
    time.sleep(3)
    print(f"machine: {os.cpu_count()} CPUs, load {os.getloadavg()[0]:.2f}; phases of {phase_s:.0f} s; "
          "CPU used, % of one CPU")
    print(f"{'phase':<22}" + "".join(f"{name:>19}" for name in GROUPS))
    for phase in ("no page", "page, no plot", "page, 10 plots"):
        driver.get("about:blank")
        if phase != "no page":
            driver.get(url)
            while len(driver.find_elements(By.CSS_SELECTOR, "text[data-component]")) < 10:
                time.sleep(0.05)
            for i in range(10 if phase == "page, 10 plots" else 0):
                driver.execute_script(
                    f"document.querySelector('circle[data-port=\"p{i}.force\"]').dispatchEvent(new MouseEvent('click'))")
        time.sleep(1)
        before, t0 = cpu_seconds(), time.time()
        time.sleep(phase_s)
        after, elapsed = cpu_seconds(), time.time() - t0
        print(f"{phase:<22}" + "".join(f"{100 * (after[n] - before[n]) / elapsed:>18.1f}%" for n in GROUPS),
              flush=True)
finally:
    driver.quit()
    processes.stop()
    shutil.rmtree(work, ignore_errors=True)
