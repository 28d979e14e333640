# SPDX-License-Identifier: Apache-2.0
"""Motion scripts (rtm.motion, `rtm script`) against the real force servo: pa10-sim serving a
private CAN bus, the paper's system from examples/force-servo/system.yaml (without the joystick,
whose place the script takes) up in a private omniNames, and `rtm script` run as a user runs it.
Each test starts its own simulator and system and stops them."""

import os
import re
import signal
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import rtm
from conftest import BIN_DIR, until
from rtm_processes import stop, wait_for

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.path.join(HERE, "..", "..")
SYSTEM_FILE = os.path.join(SOURCE, "examples", "force-servo", "system.yaml")
PA10_SIM = os.path.join(BIN_DIR, "..", "sim", "pa10-sim")
RTM = os.path.join(BIN_DIR, "rtm")


def without_joystick(text: str) -> str:
    """The system file without its joystick: the entry, its connections and its activation."""
    out, skipping = [], False
    for line in text.splitlines():
        if line.startswith("  - name: joystick0"):
            skipping = True
            continue
        if skipping and (line.startswith("  - ") or (line and not line.startswith((" ", "#")))):
            skipping = False
        if skipping or "joystick0." in line:
            continue
        if line.startswith("activate:"):
            line = re.sub(r",\s*joystick0|joystick0,\s*", "", line)
        out.append(line)
    text = "\n".join(out) + "\n"
    return re.sub(r"^connections:\s*\n(?!  - )", "connections: []\n", text, flags=re.M)


@pytest.fixture
def servo(naming, system, tmp_path, monkeypatch):
    """pa10-sim on a private bus and the force servo up on it; yields the System."""
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))
    monkeypatch.setenv("RTM_NAMING", naming)
    bus = f"local:{tmp_path}/pa10.bus"
    sim = subprocess.Popen([PA10_SIM, "--bus", bus, "--quiet"], stdout=subprocess.DEVNULL,
                           stderr=open(tmp_path / "pa10-sim.log", "w"))
    name = f"servo-test-{os.getpid()}"
    try:
        until(lambda: os.path.exists(f"{tmp_path}/pa10.bus") or sim.poll() is not None, what="pa10-sim's bus")
        assert sim.poll() is None, (tmp_path / "pa10-sim.log").read_text()
        with open(SYSTEM_FILE, encoding="utf-8") as f:
            text = without_joystick(f.read())
        text = text.replace("local:/tmp/rtm-pa10.bus", bus)
        text = re.sub(r"^name:.*$", f"name: {name}", text, flags=re.M)
        (tmp_path / "system.yaml").write_text(text)
        system.up(str(tmp_path / "system.yaml"), timeout=20.0)
        yield system
    finally:
        try:
            system.down(name)
        except rtm.Error:
            pass
        stop(sim)


def write_script(tmp_path, name, body):
    path = tmp_path / name
    path.write_text("from rtm.motion import arm\n" + textwrap.dedent(body))
    return path


def rtm_script(path, naming, *args):
    return subprocess.Popen([RTM, "--naming", naming, "script", str(path), *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def finish(process, timeout=60):
    try:
        out, err = process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        process.send_signal(signal.SIGINT)
        out, err = process.communicate(timeout=20)
        pytest.fail(f"rtm script did not end within {timeout} s: {out} {err}")
    return process.returncode, out, err


def statistic(system, component, name):
    return system.describe(component)["statistics"][name]["value"]


def phases(path):
    lines = path.read_text().splitlines()
    assert lines[0].startswith("begin_ns,end_ns,motion,outcome,"), lines[0]
    return [line.split(",")[2:4] for line in lines[1:]]


def assert_braked(system):
    """The drives brake: the actuator's watchdog fired, and while the tool is watched for 0.3 s
    it does not move and the controller writes no command."""
    until(lambda: statistic(system, "actuator0", "watchdog_events") >= 1, what="the actuator's watchdog")
    commands = statistic(system, "controller0", "commands")
    with system.watch("actuator0.pose", timeout=2) as poses:
        seen = [d.values[:3].copy() for _, d in zip(range(150), poses)]
    assert len(seen) == 150
    assert np.max(np.linalg.norm(np.array(seen) - seen[0], axis=1)) < 5e-5  # m
    assert statistic(system, "controller0", "commands") == commands


def test_a_script_runs_its_motions_in_order_and_brakes_at_its_end(servo, naming, tmp_path):
    script = write_script(tmp_path, "short.py", """
        arm.approach("-z", speed=0.005, contact=2.0, timeout=15)
        arm.press(5, ramp=0.3, hold=0.5)
        pressed = arm.force
        arm.slide("x", distance=0.005, speed=0.005)
        arm.release(lift=0.002)
        print(f"pressed {pressed:.2f} N", flush=True)
    """)
    status, out, err = finish(rtm_script(script, naming, "--phases", str(tmp_path / "phases.csv"),
                                         "--log", str(tmp_path / "script0.log")))
    assert status == 0, out + err
    assert "short.py: done" in out
    cycles = int(re.search(r"script0 ran (\d+) cycles: lateness p99 [0-9.]+ us", out).group(1))
    assert cycles > 1000  # a few seconds on the 2 ms grid
    assert phases(tmp_path / "phases.csv") == [["approach", "done"], ["press", "done"], ["slide", "done"],
                                               ["unload", "done"], ["lift", "done"]]
    pressed = float(re.search(r"pressed ([0-9.]+) N", (tmp_path / "script0.log").read_text()).group(1))
    assert abs(pressed - 5) < 1.0
    assert "script0" not in servo.components()
    assert_braked(servo)


def test_a_script_stopped_mid_press_leaves_the_arm_braked(servo, naming, tmp_path):
    script = write_script(tmp_path, "long_press.py", """
        arm.approach("-z", speed=0.005, contact=2.0, timeout=15)
        arm.press(10, ramp=0.5, hold=60)
    """)
    process = rtm_script(script, naming)
    # Pressing: the wrist reads the table's reaction.
    until(lambda: process.poll() is not None or servo.get("sensor0.wrench")["fz"] > 8, timeout=30,
          what="the press")
    assert process.poll() is None, process.communicate()
    process.send_signal(signal.SIGINT)
    status, out, err = finish(process)
    assert status == 130, out + err
    assert "stopped during press 10 N" in err
    until(lambda: "script0" not in servo.components(), what="script0 gone")
    assert_braked(servo)


def test_a_script_that_raises_stops_safely_and_says_where(servo, naming, tmp_path):
    script = write_script(tmp_path, "fails.py", """
        arm.approach("-z", speed=0.005, contact=2.0, timeout=15)
        arm.press(5, ramp=0.3, hold=0.2)
        raise RuntimeError("asked to fail while pressing")
    """)
    status, out, err = finish(rtm_script(script, naming))
    assert status == 1, out + err
    assert "raised RuntimeError: asked to fail while pressing (at fails.py:5: raise RuntimeError" in err
    assert_braked(servo)


def test_a_motion_that_cannot_be_done_stops_the_script_and_says_which(servo, naming, tmp_path):
    script = write_script(tmp_path, "nowhere.py", """
        arm.approach("z", speed=0.005, contact=2.0, timeout=0.5)
    """)
    status, out, err = finish(rtm_script(script, naming))
    assert status == 1, out + err
    assert re.search(r"raised ScriptError: approach: no contact within 0.5 s .* \(at nowhere.py:3: arm.approach", err)
    assert_braked(servo)


def test_a_script_waits_on_a_port_it_watches(servo, naming, tmp_path, components):
    components("dbl0", "--on", command=[sys.executable, os.path.join(HERE, "doubler.py")])
    script = write_script(tmp_path, "waits.py", """
        arm.approach("-z", speed=0.005, contact=2.0, timeout=15)
        waited = arm.wait(until=lambda a: a.port("gate") is not None and a.port("gate")["fz"] > 10, timeout=20)
        print(f"waited {waited:.3f} s", flush=True)
    """)
    process = rtm_script(script, naming, "--watch", "gate=dbl0.out", "--log", str(tmp_path / "script0.log"))
    until(lambda: process.poll() is not None or servo.get("sensor0.wrench")["fz"] > 1.5, timeout=30,
          what="the touch-down")
    assert process.poll() is None, process.communicate()
    servo.put("dbl0.in0", [0, 0, 3, 0, 0, 0])   # doubled: 6, not enough
    servo.put("dbl0.in0", [0, 0, 6, 0, 0, 0])   # doubled: 12, the gate opens
    status, out, err = finish(process)
    assert status == 0, out + err
    assert re.search(r"waited [0-9.]+ s", (tmp_path / "script0.log").read_text())


def test_rtm_script_refuses_what_it_cannot_run(servo, naming, tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("from rtm.motion import arm\narm.press(10\n")
    status, _, err = finish(rtm_script(bad, naming))
    assert status == 2 and "bad.py:2" in err, err
    status, _, err = finish(rtm_script(tmp_path / "missing.py", naming))
    assert status == 2 and "missing.py: no such script file" in err, err
    ok = write_script(tmp_path, "ok.py", "arm.hold(0.1)\n")
    status, _, err = finish(rtm_script(ok, naming, "--controller", "sensor0"))
    assert status == 2 and "sensor0 has no parameter gain" in err, err
    status, _, err = finish(rtm_script(ok, naming, "--watch", "gate=sensor0.nothing"))
    assert status == 2 and "sensor0 has no OutPort nothing" in err, err


def test_a_script_whose_wrench_never_comes_fails_rather_than_waiting(servo, naming, tmp_path, components):
    components("quiet0", "--on", command=[sys.executable, os.path.join(HERE, "doubler.py")])  # writes nothing unfed
    script = write_script(tmp_path, "blind.py", """
        arm.approach("-z", speed=0.005, contact=2.0, timeout=15)
    """)
    status, out, err = finish(rtm_script(script, naming, "--wrench", "quiet0.out"))
    assert status == 1, out + err
    assert "no wrench came from the sensor for 250 cycles (none yet)" in err
    assert statistic(servo, "controller0", "commands") == 0  # the servo was never commanded
