#!/usr/bin/python3
"""What `rtm serve`'s page costs in CPU, process by process, in headless Chromium (Debian's
chromium, chromium-driver, python3-selenium): ten rtm-test-talker components on at 2 ms, one
omniNames, rtm serve; then three phases of equal length: no page (about:blank), the page open
with no plot, the page open plotting all ten OutPorts. For each phase, the CPU time each group of
processes used (utime + stime from /proc), as a share of one CPU.

usage: bench/tools/serve_cpu.py [build folder (build/default)] [phase seconds (15)]
"""
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time

from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.by import By

build = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else "build/default")
phase_s = float(sys.argv[2]) if len(sys.argv) > 2 else 15
rtm_bin = os.path.join(build, "bin", "rtm")
talker = os.path.join(build, "tests", "bin", "rtm-test-talker")
work = tempfile.mkdtemp(prefix="rtm-serve-cpu-")
procs = []

GROUPS = {
    "chromium renderer": lambda c: "chrom" in c and "--type=renderer" in c,
    "chromium gpu": lambda c: "chrom" in c and "--type=gpu" in c,
    "chromium other": lambda c: "chrom" in c and "--type=renderer" not in c and "--type=gpu" not in c,
    "rtm serve": lambda c: c.startswith(rtm_bin) and " serve" in c,
    "10 talkers": lambda c: "rtm-test-talker" in c,
    "omniNames": lambda c: c.startswith("omniNames"),
}


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start(argv):
    p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    procs.append(p)
    return p


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


port = free_port()
naming = f"127.0.0.1:{port}"
os.makedirs(os.path.join(work, "names"))
start(["omniNames", "-start", str(port), "-datadir", os.path.join(work, "names"), "-logdir",
       os.path.join(work, "names"), "-ignoreport", "-ORBendPoint", f"giop:tcp:127.0.0.1:{port}"])
time.sleep(0.5)
options = webdriver.ChromeOptions()
for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1400,1000"):
    options.add_argument(arg)
driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=options)
try:
    url = start([rtm_bin, "--naming", naming, "serve"]).stdout.readline().strip()
    for i in range(10):
        start([talker, "--name", f"p{i}", "--naming", naming, "--on"])
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
    for p in procs:
        p.send_signal(signal.SIGTERM)
    for p in procs:
        try:
            p.wait(timeout=5)
        except subprocess.TimeoutExpired:
            p.kill()
    shutil.rmtree(work, ignore_errors=True)
