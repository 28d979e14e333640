# SPDX-License-Identifier: Apache-2.0
"""docs/python.md's examples, run as written: the component example taken out of the page,
started as a component and fed a wrench it must double; the system, data and watch examples in
order against the demo's system on pa10-sim; the motion scripts with `rtm script`."""

import os
import re
import subprocess
import sys

import pytest

from conftest import BIN_DIR, until
from rtm_processes import stop

SYSTEM_FILE = os.path.join(os.path.dirname(__file__), "..", "..", "examples", "force-servo", "system.yaml")


@pytest.fixture
def servo_files(naming, tmp_path, monkeypatch):
    """A folder whose examples/force-servo/system.yaml is the demo's system file on the bus of a
    pa10-sim this fixture starts (and stops), with RTM_NAMING and a private XDG_RUNTIME_DIR."""
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))
    monkeypatch.setenv("RTM_NAMING", naming)
    bus = tmp_path / "pa10.bus"
    sim = subprocess.Popen([os.path.join(BIN_DIR, "..", "sim", "pa10-sim"), "--bus", f"local:{bus}", "--quiet"],
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        until(lambda: bus.exists() or sim.poll() is not None, what="pa10-sim's bus")
        assert sim.poll() is None, "pa10-sim exited"
        folder = tmp_path / "examples" / "force-servo"
        folder.mkdir(parents=True)
        with open(SYSTEM_FILE, encoding="utf-8") as f:
            (folder / "system.yaml").write_text(f.read().replace("local:/tmp/rtm-pa10.bus", f"local:{bus}"))
        yield tmp_path
    finally:
        stop(sim)

DOCS = os.path.join(os.path.dirname(__file__), "..", "..", "docs", "python.md")


def python_blocks():
    with open(DOCS, encoding="utf-8") as f:
        return re.findall(r"```python\n(.*?)```", f.read(), re.S)


def test_the_pages_component_example_runs_as_written(system, components, tmp_path):
    doubler = next(b for b in python_blocks() if b.startswith("# doubler.py\n"))
    script = tmp_path / "doubler.py"
    script.write_text(doubler)
    components("dbl0", "--on", command=[sys.executable, str(script)])
    d = system.describe("dbl0")
    assert (d["kind"], d["contract"]["budget_ns"]) == ("doubler", 1_000_000)
    system.put("dbl0.in0", [1, 2, 3, 4, 5, 6])
    until(lambda: _out(system) == [2, 4, 6, 8, 10, 12], what="the doubled wrench")


def _out(system):
    try:
        return list(system.get("dbl0.out").values)
    except Exception as e:  # rtm.Error: no data yet
        assert "no data yet" in str(e), e
        return None


def _blocks_between(first_heading, next_heading):
    with open(DOCS, encoding="utf-8") as f:
        text = f.read()
    part = text[text.index(first_heading):text.index(next_heading)]
    return re.findall(r"```python\n(.*?)```", part, re.S)


def test_the_pages_system_data_and_watch_examples_run_in_order(servo_files, system, naming, tmp_path, monkeypatch):
    """The blocks of "The system", "Data" and "Watching a port", run as written, one after the
    other in one namespace, where examples/force-servo/system.yaml is the demo's system on this
    test's simulator (its private bus)."""
    blocks = _blocks_between("## The system", "## A component in Python")
    assert len(blocks) == 3
    monkeypatch.chdir(servo_files)
    namespace = {}
    try:
        for block in blocks:
            exec(compile(block, "docs/python.md", "exec"), namespace)
        assert namespace["system"].components() == ["actuator0", "controller0", "joystick0", "sensor0", "servo0"]
        assert namespace["data"].received >= 500 or namespace["wrench"]["fz"] > 20
    finally:
        system.down("force-servo")


def test_the_pages_motion_scripts_run_as_written(servo_files, system, naming, tmp_path, monkeypatch):
    """Each motion script of "Motion scripts", run with `rtm script` on the demo's system in
    this test's simulator, the joystick turned off (the script takes its place)."""
    scripts = _blocks_between("## Motion scripts", "## A project of your own")
    assert [s.splitlines()[0].split(":")[0] for s in scripts] == ["# slide.py", "# rub.py"]
    monkeypatch.chdir(servo_files)
    system.up("examples/force-servo/system.yaml", timeout=20.0)
    try:
        system.off("joystick0")
        for script in scripts:
            name = script.splitlines()[0].split(":")[0][2:]
            (tmp_path / name).write_text(script)
            result = subprocess.run([os.path.join(BIN_DIR, "rtm"), "--naming", naming, "script", str(tmp_path / name),
                                     "--phases", str(tmp_path / (name + ".csv"))],
                                    capture_output=True, text=True, timeout=120)
            assert result.returncode == 0, result.stdout + result.stderr
            outcomes = [line.split(",")[3] for line in (tmp_path / (name + ".csv")).read_text().splitlines()[1:]]
            assert outcomes and set(outcomes) == {"done"}, outcomes
    finally:
        system.down("force-servo")
