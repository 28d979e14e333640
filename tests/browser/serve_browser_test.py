#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""rtm serve's page in a real headless Chromium, against the real force-servo system on the
simulator: the five components and their ports shown; a drag from joystick0's OutPort onto
servo0's InPort subscribes it (rtm cat confirms); a mismatched drag shows rtm connect's message
at the port; on, and the live plot moves; save, `rtm down`, `rtm up` of the saved file brings
the same wiring back; a click on the edge disconnects. Each step keeps a screenshot in
<artifacts>.

usage: serve_browser_test.py <bin folder> <pa10-sim> <talker> <force-servo example folder> <artifacts>
Exit 77 (skipped) when Chromium's driver or Selenium is not installed.
"""
import json
import os
import re
import subprocess
import sys
import tempfile
import time
import urllib.request

try:
    from selenium import webdriver
    from selenium.webdriver.common.by import By
    from selenium.webdriver.chrome.service import Service
except ImportError:
    print("python3-selenium is not installed: skipped")
    sys.exit(77)

from browser_harness import check, chrome, drag, finish, retrying, start, start_names, stop_all, wait_for
import browser_harness

BIN, SIM, TALKER, EXAMPLE, ARTIFACTS = sys.argv[1:6]
RTM = os.path.join(BIN, "rtm")
DRIVER = browser_harness.skip_without_chromedriver()

work = tempfile.mkdtemp(prefix="rtm-browser-")


def rtm(*args, timeout=30):
    env = dict(os.environ, RTM_BIN_PATH=BIN, XDG_RUNTIME_DIR=work, RTM_TLS="")
    r = subprocess.run([RTM, "--naming", naming, "--timeout", "10000", *args], capture_output=True, text=True,
                       timeout=timeout, env=env)
    return r


def shot(driver, name):
    browser_harness.shot(driver, ARTIFACTS, name)


naming = start_names(work)
bus = "local:" + os.path.join(work, "pa10.bus")
start([SIM, "--bus", bus, "--profile", os.path.join(EXAMPLE, "operator_profile.yaml"), "--quiet"])
driver = None
try:
    wait_for(lambda: os.path.exists(bus[6:]), 20, "pa10-sim opened its bus")
    # The demo's system on this bus, unwired and off, with a talker whose pos3 takes another type.
    with open(os.path.join(EXAMPLE, "system.yaml")) as f:
        text = f.read().replace("local:/tmp/rtm-pa10.bus", bus)
    text = re.sub(r"(?ms)^connections:.*", "", text).replace("name: force-servo", "name: browser")
    text = text.replace("components:\n", f"components:\n  - name: talker0\n    command: [{TALKER}]\n", 1)
    system_file = os.path.join(work, "system.yaml")
    with open(system_file, "w") as f:
        f.write(text)
    up = rtm("up", system_file, timeout=90)
    check(up.returncode == 0, "rtm up of the unwired system: " + up.stdout + up.stderr)

    serve = start([RTM, "--naming", naming, "serve"], env=dict(os.environ, RTM_TLS=""))
    url = serve.stdout.readline().strip()
    check(url.startswith("http://127.0.0.1:"), "rtm serve printed its URL: " + url)
    token = url.split("#token=")[1]

    driver = chrome(webdriver, Service(DRIVER))
    driver.execute_cdp_cmd("Browser.setDownloadBehavior", {"behavior": "allow", "downloadPath": work})
    started = time.time()
    driver.get(url)
    names = ["actuator0", "sensor0", "controller0", "servo0", "joystick0", "talker0"]

    def shown():
        texts = [t.text for t in driver.find_elements(By.CSS_SELECTOR, "#svg text")]
        return all(n in texts for n in names)
    wait_for(shown, 15, "the page shows the five members and the talker")
    print(f"first paint with {len(names)} components: {time.time() - started:.2f} s")
    listed = json.load(urllib.request.urlopen(urllib.request.Request(
        url.split("/#")[0] + "/api/system", headers={"X-RTM-Token": token}), timeout=10))
    ports = sum(len(c.get("ports", [])) for c in listed)
    circles = driver.find_elements(By.CSS_SELECTOR, "circle.port")
    check(len(circles) == ports and ports >= 10, f"every port is shown ({len(circles)} circles, {ports} ports)")
    shot(driver, "1-system")

    # servo0's reference InPort is its controller's (the composite exposes it): the
    # subscription's peer is controller0.reference.
    wired = "-> controller0.reference"
    JOYSTICK_EDGE = 'path.edge[data-from="joystick0.reference"]'
    drag(driver, "joystick0.reference", "servo0.reference")
    wait_for(lambda: wired in rtm("cat", "joystick0").stdout, 10,
             "a drag from joystick0.reference onto servo0.reference subscribes it (rtm cat)")
    wait_for(lambda: driver.find_elements(By.CSS_SELECTOR, JOYSTICK_EDGE), 10, "the new edge is drawn")
    shot(driver, "2-connected")

    drag(driver, "joystick0.reference", "talker0.pos3")
    wait_for(lambda: "types differ" in driver.find_element(By.ID, "error").text, 10,
             "a mismatched drag shows rtm connect's message: " + repr(driver.find_element(By.ID, "error").text))
    msgs = [t.text for t in driver.find_elements(By.CSS_SELECTOR, "text.msg")]
    check(any("types differ" in m for m in msgs), "the message is shown at the port: " + repr(msgs))
    shot(driver, "3-mismatch")

    for name in ("servo0", "joystick0"):
        on = rtm("on", name)
        check(on.returncode == 0, f"rtm on {name}: {on.stderr}")
    retrying(lambda: driver.find_element(By.CSS_SELECTOR, 'circle[data-port="controller0.twist"]').click())

    def plot_lines():  # how many lines the plot's canvas holds
        return driver.execute_script(
            "const c = document.querySelector('#plots canvas'); return c ? c.dataset.series : null")

    def plot_pixels():  # the canvas as drawn, read in the page in one go (redrawn 25 times a second)
        return driver.execute_script("return document.querySelector('#plots canvas').toDataURL()")
    wait_for(lambda: plot_lines() == "6", 15,
             "the plot draws the six values of controller0.twist: " + repr(plot_lines()))
    before = plot_pixels()
    time.sleep(1.5)
    check(plot_pixels() != before, "the live plot moves")
    info = driver.find_element(By.CSS_SELECTOR, "#plots .info").text
    rate = float(info.split(" new data/s")[0]) if "new data/s" in info else 0.0
    check(rate >= 10, f"the plot shows new data at >= 10/s ({info})")
    check(re.search(r"\b[1-9][0-9]* not shown", info) is not None,
          f"the plot counts the data published between its updates as not shown ({info})")
    shot(driver, "4-plot")

    # The page left and loaded again seven times (what reloads, "back" and other pages do): a
    # page kept for "back" with its streams open held one of the browser's six connections to
    # the server each, and the next page's plot waited behind them.
    # (Before the pages closed their streams when left, the seven loads took 60 s, each waiting
    # for a connection; 30 s is a bound for a hang, not a figure: they take about 2.)
    loads_started = time.time()
    for _ in range(7):
        driver.get("about:blank")
        driver.get(url)
    wait_for(shown, 15, "the page loaded again shows the system")
    loads = time.time() - loads_started
    check(loads < 30, f"seven loads of the page did not wait for connections held by pages left ({loads:.1f} s)")
    retrying(lambda: driver.find_element(By.CSS_SELECTOR, 'circle[data-port="controller0.twist"]').click())
    wait_for(lambda: plot_lines() == "6", 15,
             "after seven loads the plot still draws controller0.twist: " + repr(plot_lines()))

    # A component's statistics and parameters: change the controller's gain from the page.
    retrying(lambda: driver.find_element(By.CSS_SELECTOR, 'text[data-component="controller0"]').click())
    wait_for(lambda: driver.find_elements(By.CSS_SELECTOR, '#params input[data-parameter="gain"]'), 10,
             "controller0's parameters are shown with the gain editable")
    gain = driver.find_element(By.CSS_SELECTOR, '#params input[data-parameter="gain"]')
    gain.clear()
    gain.send_keys("0.002 0.002 0.002 0 0 0\n")
    def gain_line():
        m = re.search(r"^\s+gain\s+(.*)$", rtm("cat", "controller0").stdout, re.M)
        return m.group(1) if m else ""
    wait_for(lambda: gain_line().startswith("0.002 0.002 0.002"), 10,
             "the gain set on the page is the controller's (rtm cat): " + gain_line())
    shot(driver, "4b-parameters")

    driver.find_element(By.ID, "save").click()
    saved = os.path.join(work, "saved.yaml")
    wait_for(lambda: os.path.exists(saved) and os.path.getsize(saved) > 0, 10, "save downloads saved.yaml")
    with open(saved) as f:
        saved_text = f.read()
    check("{from: joystick0.reference, to: controller0.reference}" in saved_text, "the saved file has the wiring")
    down = rtm("down", "browser", timeout=60)
    check(down.returncode == 0, "rtm down: " + down.stderr)
    up = rtm("up", saved, timeout=90)
    check(up.returncode == 0, "rtm up of the saved file: " + up.stdout + up.stderr)
    check(wired in rtm("cat", "joystick0").stdout, "rtm up of the saved file reproduces the wiring")
    wait_for(lambda: driver.find_elements(By.CSS_SELECTOR, JOYSTICK_EDGE), 15, "the page shows the restored edge")
    shot(driver, "5-restored")

    retrying(lambda: driver.execute_script("arguments[0].dispatchEvent(new MouseEvent('click', {bubbles: true}))",
                                           driver.find_element(By.CSS_SELECTOR, JOYSTICK_EDGE)))
    wait_for(lambda: wired not in rtm("cat", "joystick0").stdout, 10,
             "a click on the edge disconnects it (rtm cat); the page says: " +
             repr(driver.find_element(By.ID, "error").text))
    wait_for(lambda: not driver.find_elements(By.CSS_SELECTOR, JOYSTICK_EDGE), 10, "the edge is gone from the page")
    shot(driver, "6-disconnected")

    # Loading the saved file shows it first (the connection it would make, dashed) and changes
    # nothing; "apply" makes the connection.
    driver.find_element(By.ID, "load").send_keys(saved)
    PROPOSED = 'path.proposed[data-from="joystick0.reference"]'
    wait_for(lambda: "to connect" in driver.find_element(By.ID, "preview").text, 10,
             "the loaded file is shown with what applying would do: " +
             repr(driver.find_element(By.ID, "preview").text))
    wait_for(lambda: driver.find_elements(By.CSS_SELECTOR, PROPOSED), 10, "the connection to make is drawn dashed")
    time.sleep(1)
    check(wired not in rtm("cat", "joystick0").stdout, "showing the file connected nothing (rtm cat)")
    shot(driver, "7-file-shown")
    driver.find_element(By.ID, "apply").click()
    wait_for(lambda: wired in rtm("cat", "joystick0").stdout, 10, "apply connects it (rtm cat)")
    wait_for(lambda: driver.find_elements(By.CSS_SELECTOR, JOYSTICK_EDGE), 10, "the applied edge is drawn")
    check(not driver.find_elements(By.CSS_SELECTOR, "path.proposed"), "the dashed proposal is gone after apply")
    shot(driver, "8-file-applied")

    # Without the token the API refuses (what a page from elsewhere would meet).
    api = url.split("/#")[0] + "/api/system"
    try:
        urllib.request.urlopen(api, timeout=5)
        check(False, "the API answered without the token")
    except urllib.error.HTTPError as e:
        check(e.code == 401, f"the API without the token: {e.code}")
    request = urllib.request.Request(api, headers={"X-RTM-Token": token})
    check(len(json.load(urllib.request.urlopen(request, timeout=5))) == 6, "the API with the token")
finally:
    if driver is not None:
        driver.quit()
    rtm("down", "saved", timeout=60)
    rtm("down", "browser", timeout=60)
    stop_all(interrupt_first=(RTM,))

finish(work, "all browser checks passed; screenshots in " + ARTIFACTS)
