#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""rtm serve's page in a real headless Chromium, against the real force-servo system on the
simulator: the five components and their ports shown; a drag from joystick0's OutPort onto
servo0's InPort subscribes it (rtm cat confirms); a mismatched drag shows rtm connect's message
at the port; on, and the layout reads along the data (the joystick left of the servo, drawn as a
frame around sensor, controller and actuator in that order, no edge across a box, each edge
ending at the port it names); the live plot moves and its URL names it; a plot opened from the
URL gets every datum of the 500 Hz sensor (counted against the port's own count), with axes,
ticks and a legend with units; a recording (rtm record) opened and plotted whole; save, `rtm down`, `rtm up` of the saved file brings
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


# The drawing's geometry, read in the page: each box and frame, each port's centre, each edge's
# points, and every edge segment that crosses a box's inside.
LAYOUT_FACTS = """
const rect = r => ({x: +r.getAttribute('x'), y: +r.getAttribute('y'), w: +r.getAttribute('width'), h: +r.getAttribute('height')});
const boxes = {}, frames = {}, ports = {};
document.querySelectorAll('g[data-box]').forEach(g => { boxes[g.dataset.box] = rect(g.querySelector('rect.box')); });
document.querySelectorAll('g[data-frame]').forEach(g => { frames[g.dataset.frame] = {...rect(g.querySelector('rect.frame')), members: g.dataset.members.split(' ')}; });
document.querySelectorAll('circle.port').forEach(c => { ports[c.dataset.port] = [+c.getAttribute('cx'), +c.getAttribute('cy')]; });
const edges = [...document.querySelectorAll('path.edge')].map(p => {
  const points = p.getAttribute('d').replace(/^M/, '').split(' L').map(xy => xy.split(',').map(Number));
  return {from: p.dataset.from, to: p.dataset.to, points, end: points[points.length - 1]};
});
const crossings = [];
for (const e of edges) for (let i = 1; i < e.points.length; i++) {
  const [ax, ay] = e.points[i - 1], [bx, by] = e.points[i];
  for (const [name, b] of Object.entries(boxes)) {
    const x0 = b.x + 1, x1 = b.x + b.w - 1, y0 = b.y + 1, y1 = b.y + b.h - 1;  // inside, not its border
    const hit = Math.max(ax, bx) > x0 && Math.min(ax, bx) < x1 && Math.max(ay, by) > y0 && Math.min(ay, by) < y1;
    if (hit) crossings.push(`${e.from} -> ${e.to} segment ${i} crosses ${name}`);
  }
}
const svg = document.getElementById('svg');
return {boxes, frames, ports, edges, crossings, svg: {w: +svg.getAttribute('width'), h: +svg.getAttribute('height')}};
"""

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
    at_load = driver.execute_script(
        "return {boxes: document.querySelectorAll('rect.box').length, text: document.getElementById('graph').textContent}")
    # The load event waits for the first look: what is there when get() returns (as for a
    # one-shot headless screenshot) is the graph, no placeholder.
    check(at_load["boxes"] >= 1 and "asking rtm serve" not in at_load["text"],
          "at its load the page shows the graph: " + repr(at_load))
    wait_for(shown, 15, "the page shows the five members and the talker")
    # A one-shot headless Chromium (as for `chromium --headless --screenshot URL`) takes the page
    # as it is at its load event: the graph, no placeholder.
    one_shot = subprocess.run(["chromium", "--headless=new", "--no-sandbox", "--disable-gpu",
                               "--user-data-dir=" + os.path.join(work, "one-shot-profile"), "--dump-dom", url],
                              capture_output=True, text=True, timeout=60)
    check('class="box"' in one_shot.stdout and "asking rtm serve" not in one_shot.stdout,
          "a one-shot headless Chromium sees the graph at the page's load: " + one_shot.stdout[-600:])
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
    # The layout, with the servo on (its members wired by it) and the joystick wired to it.
    wait_for(lambda: driver.find_elements(By.CSS_SELECTOR, 'path.edge[data-from="sensor0.wrench"]'), 15,
             "the servo's own wiring (sensor0.wrench -> controller0.wrench) is drawn")
    wait_for(lambda: driver.find_elements(By.CSS_SELECTOR, 'path.edge[data-from="controller0.twist"]'), 15,
             "the servo's own wiring (controller0.twist -> actuator0.twist) is drawn")
    geometry = driver.execute_script(LAYOUT_FACTS)
    boxes, frames = geometry["boxes"], geometry["frames"]
    check(set(frames.get("servo0", {}).get("members", [])) == {"sensor0", "controller0", "actuator0"},
          "servo0 is drawn as a frame around its three members: " + repr(frames.get("servo0")))
    check("servo0" not in boxes, "servo0 is no box beside its members")
    frame = frames.get("servo0", {"x": 0, "y": 0, "w": 0, "h": 0})
    for m in ("sensor0", "controller0", "actuator0"):
        b = boxes.get(m, {"x": -1, "y": -1, "w": 0, "h": 0})
        check(frame["x"] < b["x"] and b["x"] + b["w"] < frame["x"] + frame["w"] and
              frame["y"] < b["y"] and b["y"] + b["h"] < frame["y"] + frame["h"],
              f"the frame contains {m}: frame {frame}, box {b}")
    check(boxes["joystick0"]["x"] + boxes["joystick0"]["w"] < frame["x"],
          "the joystick is left of the servo it feeds (ranks along the data)")
    check(boxes["sensor0"]["x"] < boxes["controller0"]["x"] < boxes["actuator0"]["x"],
          "inside the servo: sensor, controller, actuator from left to right")
    check(geometry["crossings"] == [], "no edge segment crosses a box: " + repr(geometry["crossings"][:5]))
    check(geometry["svg"]["w"] >= max(b["x"] + b["w"] for b in boxes.values()) and
          geometry["svg"]["h"] >= max(b["y"] + b["h"] for b in boxes.values()),
          "the drawing is as large as what it holds (it scrolls, nothing is cut off)")
    for e in geometry["edges"]:
        end = geometry["ports"].get(e["to"])
        check(end is not None and abs(e["end"][0] - end[0]) < 1.5 and abs(e["end"][1] - end[1]) < 1.5,
              f"the edge {e['from']} -> {e['to']} ends at the port it names ({e['end']} vs {end})")
    joystick_edge = next((e for e in geometry["edges"] if e["from"] == "joystick0.reference"), None)
    servo_port = geometry["ports"].get("servo0.reference")
    check(joystick_edge is not None and servo_port is not None and
          any(abs(x - servo_port[0]) < 1.5 and abs(y - servo_port[1]) < 1.5 for x, y in joystick_edge["points"]),
          "the joystick's edge enters the servo through servo0.reference, on the frame")
    servo_timing = driver.execute_script(
        "return document.querySelector('g[data-frame=\"servo0\"] text.timing').textContent")
    check("? ms" not in servo_timing and "p99 0 " not in servo_timing and "no loop of its own" in servo_timing,
          "the servo's own line says it runs no loop of its own: " + repr(servo_timing))
    shot(driver, "3b-layout")

    retrying(lambda: driver.find_element(By.CSS_SELECTOR, 'circle[data-port="controller0.twist"]').click())

    def plot_lines():  # how many lines the plot's canvas holds
        return driver.execute_script(
            "const c = document.querySelector('#plots canvas'); return c ? c.dataset.series : null")

    def plot_pixels():  # the canvas as drawn, read in the page in one go (redrawn 25 times a second)
        return driver.execute_script("return document.querySelector('#plots canvas').toDataURL()")
    wait_for(lambda: plot_lines() == "6", 15,
             "the plot draws the six values of controller0.twist: " + repr(plot_lines()))
    before = plot_pixels()
    wait_for(lambda: plot_pixels() != before, 5, "the live plot moves")
    check("plot=controller0.twist" in driver.execute_script("return location.hash"),
          "the URL names the plot opened: " + driver.execute_script("return location.hash"))
    retrying(lambda: driver.find_element(By.CSS_SELECTOR, 'circle[data-port="controller0.twist"]').click())
    wait_for(lambda: "plot=" not in driver.execute_script("return location.hash") and
             not driver.find_elements(By.CSS_SELECTOR, "#plots .plot"), 5, "closing the plot takes it out of the URL")
    shot(driver, "4-plot")

    # A plot opened from the URL: the 500 Hz sensor's wrench, every datum. The page's count of
    # data received is compared with the count the publisher says it wrote over the same time.
    driver.get("about:blank")
    started = time.time()
    driver.get(url + "&plot=sensor0.wrench")
    wait_for(lambda: plot_lines() == "6", 15, "the plot named in the URL (sensor0.wrench) is open: " + repr(plot_lines()))

    def plot_facts():
        return driver.execute_script("const c = document.querySelector('#plots canvas'); return {...c.dataset,"
                                     "legend: [...document.querySelectorAll('#plots .legend [data-element]')].map(e => e.textContent),"
                                     "axis: document.querySelector('#plots .axis').textContent}")

    def written():  # data sensor0.wrench wrote, as the port counts them
        listed = json.load(urllib.request.urlopen(urllib.request.Request(
            url.split("/#")[0] + "/api/components/sensor0", headers={"X-RTM-Token": token}), timeout=10))
        return next(p for p in listed["ports"] if p["name"] == "wrench")["counters"]["accepted"]
    wait_for(lambda: int(plot_facts()["received"]) > 0, 10, "the sensor's data arrive")
    print(f"a plot opened from the URL: first data drawn {time.time() - started:.2f} s after the page was asked for")
    facts = plot_facts()
    check(facts["legend"] == ["fx [N]", "fy [N]", "fz [N]", "tx [N·m]", "ty [N·m]", "tz [N·m]"],
          "the legend names each element with its unit: " + repr(facts["legend"]))
    check("N" in facts["axis"] and "time [s]" in facts["axis"], "the axes say their units: " + facts["axis"])
    check(int(facts["vticks"]) >= 3 and int(facts["tticks"]) >= 3, f"both axes have ticks: {facts}")
    received_0, written_0, t_0 = int(plot_facts()["received"]), written(), time.time()
    wait_for(lambda: time.time() - t_0 > 4 and int(plot_facts()["received"]) > received_0 + 1000, 15,
             "four seconds of the sensor's data arrive")
    written_1, facts = written(), plot_facts()
    page_delta, port_delta = int(facts["received"]) - received_0, written_1 - written_0
    rate = page_delta / (time.time() - t_0)
    print(f"sensor0.wrench: {page_delta} data on the page while the port wrote {port_delta} ({rate:.0f}/s)")
    # The two counts are read a round trip and up to one event (40 ms, 20 data) apart.
    check(abs(page_delta - port_delta) <= 40, f"the page received every datum the port wrote ({page_delta} of {port_delta})")
    check(facts["received"] == facts["sent"] and facts["lost"] == "0",
          f"the page has every datum the server sent, none lost: {facts}")
    check(facts["envelope"] == "1" and int(facts["drawn"]) > int(driver.execute_script(
        "return document.querySelector('#plots canvas').width")),
          f"more data than pixels: drawn as a min-max envelope, none left out ({facts['drawn']} data)")
    shot(driver, "4a-plot-from-url")
    driver.get("about:blank")

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
    # Its timing contract (the system file's phase and await, its own 50 us budget) and how it
    # keeps it: met or missed, with the worst case and when.
    contract = driver.find_element(By.ID, "contract").text
    check(contract.startswith("contract: deadline 2000 µs ") and "budget 50 µs" in contract and " at " in contract,
          "controller0's contract is shown with its deadline, budget and worst case: " + repr(contract))
    controller_line = driver.execute_script(
        "return document.querySelector('g[data-box=\"controller0\"] text.timing').textContent")
    check(("contract met" in controller_line) or ("missed" in controller_line) or ("exceeded" in controller_line),
          "controller0's line says whether it keeps its contract: " + repr(controller_line))
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

    # A recording of the sensor (rtm record), opened on the page: its channel plotted whole, on a
    # plot drawn as a live one is, with the recorded elements' names and units.
    recording = os.path.join(work, "run.mcap")
    recorded = rtm("record", "sensor0.wrench", "-o", recording, "--count", "500", timeout=60)
    check(recorded.returncode == 0, "rtm record of sensor0.wrench: " + recorded.stdout + recorded.stderr)
    field = driver.find_element(By.ID, "recording")
    field.clear()
    field.send_keys(recording)
    driver.find_element(By.ID, "open-recording").click()
    CHANNEL = 'button.channel[data-topic="sensor0.wrench"]'
    wait_for(lambda: driver.find_elements(By.CSS_SELECTOR, CHANNEL), 10,
             "the recording's channels are listed: " + driver.find_element(By.ID, "recording-channels").text)
    driver.find_element(By.CSS_SELECTOR, CHANNEL).click()
    RECORDED = '#plots .plot.recorded'
    def recorded_facts():
        return driver.execute_script(
            "const d = document.querySelector(arguments[0]); if (!d) return null; const c = d.querySelector('canvas');"
            "return {...c.dataset, legend: [...d.querySelectorAll('.legend [data-element]')].map(e => e.textContent),"
            "info: d.querySelector('.info').textContent}", RECORDED)
    wait_for(lambda: (recorded_facts() or {}).get("drawn") == "500", 10,
             "the recorded channel is drawn whole: " + repr(recorded_facts()))
    facts = recorded_facts() or {}
    check(facts.get("series") == "6", "six lines, one per element: " + repr(facts.get("series")))
    check("fx [N]" in facts.get("legend", []) and "tz [N·m]" in facts.get("legend", []),
          "the legend names the recorded elements with their units: " + repr(facts.get("legend")))
    check("recorded: 500 of 500" in facts.get("info", ""), "the plot says what it shows: " + repr(facts.get("info")))
    shot(driver, "8a-recording")
    driver.find_element(By.CSS_SELECTOR, CHANNEL).click()
    wait_for(lambda: not driver.find_elements(By.CSS_SELECTOR, RECORDED), 5, "a second click removes the recorded plot")

    # The same channel on the live plot of the port it came from: the live plot is started, the
    # recording drawn over it dashed, six lines, while the live data go on arriving.
    driver.find_element(By.CSS_SELECTOR, 'button.overlay[data-topic="sensor0.wrench"]').click()
    LIVE = '#plots .plot[data-port="sensor0.wrench"]'
    def live_facts():
        return driver.execute_script(
            "const d = document.querySelector(arguments[0]); if (!d) return null; const c = d.querySelector('canvas');"
            "return {...c.dataset, info: d.querySelector('.info').textContent}", LIVE)
    wait_for(lambda: int((live_facts() or {}).get("overlay", "0")) > 0, 10,
             "the recording is drawn over the live plot: " + repr(live_facts()))
    first = live_facts() or {}
    check(first.get("overlaySeries") == "6", "six recorded lines over the live ones: " + repr(first))
    wait_for(lambda: int((live_facts() or {}).get("received", "0")) > int(first.get("received", "0")), 10,
             "live data go on arriving under the recording: " + repr(live_facts()))
    # It plays along: more of it is drawn as the live data advance (the recording is 1 s long).
    wait_for(lambda: int((live_facts() or {}).get("overlay", "0")) >= 400, 10,
             "the recording is drawn further as the live data advance: " + repr(live_facts()))
    wait_for(lambda: "dashed: as recorded" in (live_facts() or {}).get("info", ""), 5,
             "the plot says what the dashed lines are: " + repr((live_facts() or {}).get("info")))
    driver.execute_script("document.querySelector(arguments[0]).scrollIntoView()", LIVE)
    shot(driver, "8b-recording-over-live")
    driver.find_element(By.CSS_SELECTOR, 'button.overlay[data-topic="sensor0.wrench"]').click()
    wait_for(lambda: (live_facts() or {}).get("overlay") == "0", 5, "a second click takes the recording off the live plot")

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
