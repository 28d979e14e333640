# SPDX-License-Identifier: Apache-2.0
"""What rtm serve's benches share: processes they start and stop, a naming service of their own
on a free loopback port, and headless Chromium (Debian's chromium and chromium-driver)."""
import os
import signal
import socket
import subprocess
import time

from selenium import webdriver
from selenium.webdriver.chrome.service import Service


class Processes:
    """Every process a bench starts, stopped (SIGTERM, then SIGKILL after 5 s) by stop()."""

    def __init__(self):
        self.started = []

    def start(self, argv):
        p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        self.started.append(p)
        return p

    def stop(self, ps=None):
        ps = [p for p in (self.started if ps is None else ps) if p.poll() is None]
        for p in ps:
            p.send_signal(signal.SIGTERM)
        for p in ps:
            try:
                p.wait(timeout=5)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


def start_naming_service(processes, work):
    """omniNames on a free loopback port, its files under work; returns "127.0.0.1:PORT"."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    folder = os.path.join(work, "names")
    os.makedirs(folder, exist_ok=True)
    processes.start(["omniNames", "-start", str(port), "-datadir", folder, "-logdir", folder, "-ignoreport",
                     "-ORBendPoint", f"giop:tcp:127.0.0.1:{port}"])
    time.sleep(0.5)
    return f"127.0.0.1:{port}"


def headless_chromium(work, nice=0):
    """A WebDriver for headless Chromium; with nice, the browser and all it starts at that value."""
    options = webdriver.ChromeOptions()
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1400,1000"):
        options.add_argument(arg)
    if nice:
        wrapper = os.path.join(work, "chromium")
        with open(wrapper, "w") as f:
            f.write(f"#!/bin/sh\nexec nice -n {nice} /usr/bin/chromium \"$@\"\n")
        os.chmod(wrapper, 0o755)
        options.binary_location = wrapper
    return webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=options)
