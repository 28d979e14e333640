# SPDX-License-Identifier: Apache-2.0
"""What rtm serve's browser tests share: the checks they count, the processes they start (each
stopped at the end, rtm serve with SIGINT), a private omniNames on a free loopback port, waiting,
screenshots and headless Chromium through Debian's chromedriver.

A test imports it after its own Selenium import (which exits 77 when Selenium is missing) and
calls skip_without_chromedriver() first.
"""
import os
import shutil
import signal
import socket
import subprocess
import sys
import time

failures = []
processes = []


def skip_without_chromedriver():
    """Debian's chromedriver, or exit 77 (skipped)."""
    driver = shutil.which("chromedriver") or "/usr/bin/chromedriver"
    if not os.path.exists(driver):
        print("chromedriver (Debian's chromium-driver) is not installed: skipped")
        sys.exit(77)
    return driver


def check(ok, what):
    print(("ok: " if ok else "FAIL: ") + what, flush=True)
    if not ok:
        failures.append(what)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start(argv, **kw):
    p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, **kw)
    processes.append(p)
    return p


def start_names(work):
    """A private omniNames on a free loopback port, its data in work/names: "127.0.0.1:<port>"."""
    port = free_port()
    os.makedirs(os.path.join(work, "names"))
    start(["omniNames", "-start", str(port), "-datadir", os.path.join(work, "names"), "-logdir",
           os.path.join(work, "names"), "-ignoreport", "-ORBendPoint", f"giop:tcp:127.0.0.1:{port}"])
    return f"127.0.0.1:{port}"


def wait_for(predicate, seconds, what):
    deadline = time.time() + seconds
    while time.time() < deadline:
        try:
            if predicate():
                return True
        except Exception:  # the page or a process not ready yet
            pass
        time.sleep(0.1)
    check(False, what)
    return False


def shot(driver, folder, name):
    os.makedirs(folder, exist_ok=True)
    driver.save_screenshot(os.path.join(folder, name + ".png"))


def retrying(action):
    """action(), found anew while the page redraws between finding an element and using it."""
    from selenium.common.exceptions import StaleElementReferenceException
    for _ in range(5):
        try:
            return action()
        except StaleElementReferenceException:
            time.sleep(0.2)
    check(False, "the page kept redrawing under an action")
    return None


def drag(driver, source, target):
    """Drag the port circle of address source onto that of target, as a user does."""
    from selenium.webdriver.common.action_chains import ActionChains

    def act():
        a = driver.find_element("css selector", f'circle[data-port="{source}"]')
        b = driver.find_element("css selector", f'circle[data-port="{target}"]')
        driver.execute_script("arguments[0].scrollIntoView({block: 'center'})", a)
        ActionChains(driver).move_to_element(a).click_and_hold().move_to_element(b).release().perform()
    retrying(act)


def chrome(webdriver, service, window="1400,1000", console=False):
    """Headless Chromium; console: keep the page's console (driver.get_log("browser"))."""
    options = webdriver.ChromeOptions()
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", f"--window-size={window}"):
        options.add_argument(arg)
    if console:
        options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=service, options=options)


def stop_all(interrupt_first=()):
    """Every process started, last first: those whose program is in interrupt_first get SIGINT
    (rtm serve stops on Ctrl-C), the rest SIGTERM; SIGKILL after 5 s."""
    for p in reversed(processes):
        if p.poll() is None:
            p.send_signal(signal.SIGINT if p.args[0] in interrupt_first else signal.SIGTERM)
            try:
                p.wait(timeout=5)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


def finish(work, done_text):
    shutil.rmtree(work, ignore_errors=True)
    print(f"{len(failures)} failed" if failures else done_text)
    sys.exit(1 if failures else 0)
