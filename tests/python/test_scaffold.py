# SPDX-License-Identifier: Apache-2.0
"""`rtm new component --python`: the project it writes passes its own test and runs under
`rtm up` as a component of its own, wired like any other."""

import os
import subprocess
import sys

import rtm
from conftest import BIN_DIR, until


def test_a_scaffolded_python_component_passes_its_test_and_runs_under_rtm_up(system, tmp_path):
    made = subprocess.run([os.path.join(BIN_DIR, "rtm"), "new", "component", "smoother", "--python",
                           "--in", "wrench:TimedFloat6", "--out", "smooth:TimedFloat6", "--param", "alpha::0.5",
                           "--description", "smooths a wrench", "--dir", str(tmp_path)],
                          capture_output=True, text=True, timeout=60)
    assert made.returncode == 0, made.stderr
    assert "next: cd" in made.stdout and "python3 -m pytest" in made.stdout
    project = tmp_path / "smoother"
    tests = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider"], cwd=project,
                           capture_output=True, text=True, timeout=120)
    assert tests.returncode == 0, tests.stdout + tests.stderr
    assert "2 passed" in tests.stdout, tests.stdout
    try:
        up = system.up(str(project / "smoother.yaml"))
        assert [p["name"] for p in up["processes"]] == ["smoother0"]
        d = system.describe("smoother0")
        assert (d["kind"], d["description"], d["state"]) == ("smoother", "smooths a wrench", "on")
        assert d["parameters"]["alpha"]["value"] == "0.5"
        system.put("smoother0.wrench", [1, 2, 3, 4, 5, 6])
        until(lambda: _latest(system) is not None, what="smoother0.smooth's first datum")
        assert list(_latest(system).values) == [1, 2, 3, 4, 5, 6], "passed on as made"
    finally:
        system.down("smoother")


def _latest(system):
    try:
        return system.get("smoother0.smooth")
    except rtm.Error:  # no data yet
        return None

