#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""rtm serve's page in a real headless Chromium against another local user's strings.

rtm-test-hostile reports a cross-site scripting payload in every string it has (its kind and
description, its statistics' names, units and descriptions, its parameters' names, values, units
and descriptions, its ports' names and descriptions, its last error) and binds itself in the
naming service under names that break the naming rule, payloads too. Each payload's script would
ask a listener this test runs on a free loopback port for a page and then go there. Checked:
every payload is shown as text (read back from the DOM), a name that breaks the rule is shown
marked and offers nothing, no element is injected, no request reaches the listener, Chromium
reports no blocked script, and clicking every name, opening the details and plotting the hostile
port triggers nothing; beside it, two talkers are wired by a drag, plotted, switched off and
given a parameter from the page, and unwired by a click. Screenshots in <artifacts>.

usage: serve_hostile_browser_test.py <rtm> <rtm-test-hostile> <rtm-test-talker> <artifacts>
Exit 77 (skipped) when Chromium's driver or Selenium is not installed.
"""
import http.server
import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request

try:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
except ImportError:
    print("python3-selenium is not installed: skipped")
    sys.exit(77)

from browser_harness import check, chrome, drag, finish, free_port, retrying, start, start_names, stop_all, wait_for
import browser_harness

RTM, HOSTILE, TALKER, ARTIFACTS = sys.argv[1:5]
DRIVER = browser_harness.skip_without_chromedriver()

work = tempfile.mkdtemp(prefix="rtm-hostile-browser-")
hits = []  # every request that reached the listener


def shot(driver, name):
    browser_harness.shot(driver, ARTIFACTS, name)


class Listener(http.server.BaseHTTPRequestHandler):
    """What a payload's script would reach: every request is recorded."""

    def answer(self):
        hits.append(f"{self.command} {self.path}")
        self.send_response(204)
        self.end_headers()

    do_GET = do_POST = do_HEAD = do_OPTIONS = answer

    def log_message(self, *args):
        pass


listener = http.server.ThreadingHTTPServer(("127.0.0.1", free_port()), Listener)
threading.Thread(target=listener.serve_forever, daemon=True).start()
beacon = f"http://127.0.0.1:{listener.server_address[1]}"
naming = start_names(work)
driver = None


def rtm_json(*args):
    r = subprocess.run([RTM, "--naming", naming, "--json", *args], capture_output=True, text=True, timeout=30,
                       env=dict(os.environ, RTM_TLS=""))
    return json.loads(r.stdout)


def in_page(script, *args):
    return driver.execute_script(script, *args)


# The texts of every element the page drew, its titles and its inputs' values, read in the page.
READ_BACK = """
const texts = [...document.querySelectorAll('body *')].filter(e => e.children.length === 0).map(e => e.textContent);
const titles = [...document.querySelectorAll('title')].map(e => e.textContent)
    .concat([...document.querySelectorAll('[title]')].map(e => e.getAttribute('title')));
const values = [...document.querySelectorAll('input')].map(e => e.value);
return {texts, titles, values};
"""
# Elements no drawing of this page makes: anything markup in a string would bring.
INJECTED = """
return [...document.querySelectorAll('img, iframe, object, embed, form, a, foreignObject, #svg svg, script, style, link')]
  .filter(e => !(e.tagName === 'SCRIPT' && e.getAttribute('src') === '/app.js')
            && !(e.tagName === 'LINK' && e.getAttribute('href') === '/style.css'))
  .map(e => e.outerHTML.slice(0, 120))
  .concat([...document.querySelectorAll('*')].flatMap(e => [...e.attributes].filter(a => /^on/i.test(a.name))
  .map(a => e.tagName + ' ' + a.name)));
"""

try:
    hostile = start([HOSTILE, "--name", "hostile0", "--naming", naming, "--beacon", beacon, "--bind-names", "--on"])
    start([TALKER, "--name", "talker0", "--naming", naming, "--on"])
    start([TALKER, "--name", "talker1", "--naming", naming])
    start([TALKER, "--name", "slow0", "--naming", naming, "--in0-delay-ms", "3000"])
    wait_for(lambda: {"hostile0", "talker0", "talker1", "slow0"} <= {c["name"] for c in rtm_json("ls")}, 20,
             "the hostile component and the three talkers are bound")
    serve = start([RTM, "--naming", naming, "serve"], env=dict(os.environ, RTM_TLS=""))
    url = serve.stdout.readline().strip()
    check(url.startswith("http://127.0.0.1:"), "rtm serve printed its URL: " + url)
    token = url.split("#token=")[1]
    base = url.split("/#")[0]

    def api(path):
        request = urllib.request.Request(base + path, headers={"X-RTM-Token": token})
        return json.load(urllib.request.urlopen(request, timeout=10))

    listed = api("/api/system")
    names = [c["name"] for c in listed]
    bad = [c["name"] for c in listed if not c.get("name_ok")]
    check(len(bad) >= 10 and "talker0" not in bad and "hostile0" not in bad,
          f"serve marks the {len(bad)} names that break the rule, and only those")
    hostile_system = next(c for c in listed if c["name"] == "hostile0")
    hostile_details = api("/api/components/hostile0")

    driver = chrome(webdriver, Service(DRIVER), console=True)
    driver.get(url)

    def drawn_names():
        return in_page("return [...document.querySelectorAll('#svg text.name')].map(t => t.textContent)")
    wait_for(lambda: sorted(drawn_names()) == sorted(names), 15,
             "every listed name is drawn, as the text the naming service holds")
    wait_for(lambda: hostile_system.get("last_error", "") in in_page(READ_BACK)["texts"], 15,
             "the hostile component's last error is shown as text")
    shot(driver, "1-hostile-system")

    marked = in_page("""
      return [...document.querySelectorAll('#svg g.badname')].map(g => ({
        name: g.querySelector('text.name').textContent,
        mark: g.querySelector('text.mark').textContent,
        acts: g.querySelectorAll('.btn, circle.port').length,
        component: g.querySelector('[data-component]') !== null}));""")
    check(sorted(m["name"] for m in marked) == sorted(bad), "each name that breaks the rule is drawn apart")
    check(all("not a valid name" in m["mark"] and m["acts"] == 0 and not m["component"] for m in marked),
          "each is marked 'not a valid name' and has no button, no port, nothing to click")

    shown = in_page(READ_BACK)
    text_of = set(shown["texts"])
    check(any(hostile_system["kind"] in t for t in text_of), "the hostile kind is shown as text")
    for p in hostile_system["ports"]:
        check(any(t.startswith(p["name"] + " : ") for t in text_of), "port name shown as text: " + p["name"][:40])
        check(any(p.get("description", "") in t for t in shown["titles"]),
              "port description shown as text: " + p.get("description", "")[:40])
    check(in_page(INJECTED) == [], "no element or event attribute came from a string: " + repr(in_page(INJECTED)))

    # Every name clicked: those that break the rule do nothing at all.
    details_before = in_page("return document.getElementById('details').innerText")
    in_page("document.querySelectorAll('#svg g.badname text').forEach(t => t.dispatchEvent(new MouseEvent('click', {bubbles: true})))")
    time.sleep(1)
    check(in_page("return document.getElementById('details').innerText") == details_before,
          "clicking a name that breaks the rule opens nothing")
    check(in_page("return document.getElementById('error').textContent") == "", "and asks the server nothing")

    # The hostile component's details: every statistic and parameter string read back as text.
    driver.find_element("css selector", 'text[data-component="hostile0"]').click()
    wait_for(lambda: len(in_page("return [...document.querySelectorAll('#stats tr')]")) >= len(hostile_details["statistics"]),
             10, "the hostile component's statistics are shown")
    shown = in_page(READ_BACK)
    text_of, titles, values = set(shown["texts"]), set(shown["titles"]), set(shown["values"])
    check(hostile_details["description"] in text_of, "the hostile description is shown as text")
    for name, s in hostile_details["statistics"].items():
        check(name in text_of and s["unit"] in text_of and s["description"] in titles,
              "statistic shown as text (name, unit, description): " + name[:40])
    for name, p in hostile_details["parameters"].items():
        check(name in text_of and (p["value"] in values or p["value"] in text_of) and p["unit"] in text_of
              and any(p["description"] in t for t in titles),
              "parameter shown as text (name, value, unit, description): " + name[:40])
    check(in_page(INJECTED) == [], "no element or event attribute came from the details")

    # Every port of the hostile component clicked, its OutPorts plotted: the addresses are text.
    in_page("document.querySelectorAll('#svg circle.port').forEach(c => { if (c.dataset.port.startsWith('hostile0.')) "
            "c.dispatchEvent(new MouseEvent('click', {bubbles: true})); })")
    outs = [f"hostile0.{p['name']}" for p in hostile_system["ports"] if p["direction"] == "out"]
    wait_for(lambda: sorted(in_page("return [...document.querySelectorAll('#plots .plot b')].map(b => b.textContent)"))
             == sorted(outs), 10, "each hostile OutPort plotted under its address as text")
    in_page("document.querySelectorAll('#svg circle.port').forEach(c => { if (c.dataset.port.startsWith('hostile0.')) "
            "c.dispatchEvent(new MouseEvent('click', {bubbles: true})); })")  # and unplotted
    shot(driver, "2-hostile-details")

    # Beside it, the page's own features on two talkers.

    def subscriptions():
        talker0 = next(c for c in api("/api/system") if c["name"] == "talker0")
        return [s["peer"] for p in talker0["ports"] for s in p.get("subscriptions", [])]
    drag(driver, "talker0.force", "talker1.in0")
    wait_for(lambda: "talker1.in0" in subscriptions(), 10, "a drag from talker0.force onto talker1.in0 connects them")
    EDGE = 'path.edge[data-from="talker0.force"]'
    wait_for(lambda: driver.find_elements("css selector", EDGE), 10, "the new edge is drawn")
    # A reader slow to take its data (each put into slow0.in0 waits 3 s): talker0's deliveries
    # fail, and the edge says so and why. Over CORBA (path=corba): on this host the ring would
    # hand the data over without a call that could fail, and the slow reader only drop.
    def post(path, body):
        request = urllib.request.Request(base + path, data=json.dumps(body).encode(), method="POST",
                                         headers={"X-RTM-Token": token, "Content-Type": "application/json"})
        return json.load(urllib.request.urlopen(request, timeout=20))
    post("/api/connect", {"from": "talker0.force", "to": "slow0.in0", "type": "repeated", "policy": "path=corba"})
    SLOW_EDGE = 'path.edge.failing[data-from="talker0.force"][data-to="slow0.in0"]'
    wait_for(lambda: "TIMEOUT" in driver.find_element("css selector", SLOW_EDGE).get_attribute("textContent"), 20,
             "an edge whose deliveries fail is drawn failing, with why")
    shot(driver, "2-failing-edge")
    post("/api/disconnect", {"from": "talker0.force", "to": "slow0.in0", "type": "repeated"})
    wait_for(lambda: not driver.find_elements("css selector", 'path.edge[data-to="slow0.in0"]'), 20,
             "the failing edge goes with its subscription")


    retrying(lambda: driver.find_element("css selector", 'circle[data-port="talker0.force"]').click())
    wait_for(lambda: in_page("const c = document.querySelector('#plots canvas'); return c && c.dataset.series") == "6",
             10, "talker0.force is plotted, six lines")
    before = in_page("return document.querySelector('#plots canvas').toDataURL()")
    time.sleep(1.0)
    check(in_page("return document.querySelector('#plots canvas').toDataURL()") != before, "the plot moves")

    retrying(lambda: driver.find_element("css selector", 'text[data-component="talker1"]').click())
    wait_for(lambda: driver.find_elements("css selector", '#params input[data-parameter="offset"]'), 10,
             "talker1's parameters are shown with the offset editable")
    offset = driver.find_element("css selector", '#params input[data-parameter="offset"]')
    offset.clear()
    offset.send_keys("2.5\n")
    wait_for(lambda: api("/api/components/talker1")["parameters"]["offset"]["value"] == "2.5", 10,
             "the offset set on the page is talker1's")

    retrying(lambda: in_page("""
      const g = document.querySelector('text[data-component="talker0"]').parentNode;
      [...g.querySelectorAll('text.btn')].find(b => b.textContent === 'off').dispatchEvent(new MouseEvent('click', {bubbles: true}));"""))
    wait_for(lambda: next(c for c in api("/api/system") if c["name"] == "talker0")["state"] == "off", 10,
             "the off button turns talker0 off")

    retrying(lambda: in_page("arguments[0].dispatchEvent(new MouseEvent('click', {bubbles: true}))",
                             driver.find_element("css selector", EDGE)))
    wait_for(lambda: "talker1.in0" not in subscriptions(), 10, "a click on the edge disconnects it")
    shot(driver, "3-features")

    time.sleep(2)  # what a payload's script would have sent has arrived by now
    # The page writes its open plots into its URL's fragment (&plot=...), and nothing else.
    check(driver.current_url.split("&plot=")[0] == url, "the page never went elsewhere: " + driver.current_url)
    refused = [e["message"] for e in driver.get_log("browser") if "Content Security Policy" in e["message"]
               or "Refused to" in e["message"]]
    check(refused == [], "Chromium blocked nothing (no string ever tried to run): " + repr(refused[:3]))
except Exception as e:  # a step that could not go on (the page went elsewhere, say): the rest is still checked
    check(False, f"the test stopped at {type(e).__name__}: {str(e)[:200]}")
finally:
    check(hits == [], "no request reached the listener: " + repr(hits[:5]))
    if driver is not None:
        driver.quit()
    stop_all(interrupt_first=(RTM,))
    listener.shutdown()

finish(work, "all hostile-page checks passed; screenshots in " + ARTIFACTS)
