# SPDX-License-Identifier: Apache-2.0
"""Components written in Python (rtm.Component, rtm.run) as real processes beside C++ ones
(rtm-test-talker: its force port is a ramp, value i of cycle n is n + i), told apart by no tool."""

import json
import os
import subprocess
import sys

import pytest

import rtm
from conftest import BIN_DIR, TEST_BIN_DIR, until

DOUBLER = [sys.executable, os.path.join(os.path.dirname(__file__), "doubler.py")]


def port_of(description, name):
    return next(p for p in description["ports"] if p["name"] == name)


def test_a_python_component_is_named_described_and_runs_its_step_on_the_runners_activity(system, components):
    components("dbl0", "--on", "--period", "2ms", command=DOUBLER)
    d = system.describe("dbl0")
    assert d["kind"] == "doubler"
    assert d["description"] == "multiplies a wrench (a test component in Python)"
    assert d["state"] == "on"
    assert [(p["name"], p["type"]) for p in d["ports"]] == [
        ("in0", "RTM::TimedFloat6"), ("pos", "RTM::TimedFloat3"), ("out", "RTM::TimedFloat6")]
    assert [e["unit"] for e in port_of(d, "pos")["elements"]] == ["m", "m", "m"]
    assert d["parameters"]["factor"]["value"] == "2"
    until(lambda: system.describe("dbl0")["timing"]["cycles"] > 50, what="dbl0's cycles")
    d = system.describe("dbl0")
    assert d["timing"]["overruns"] >= 0
    assert d["statistics"]["python.step_max"]["value"] > 0, "the step's hold of the GIL is measured"
    assert "python.gil_wait_p99" in d["statistics"]
    assert d["contract"]["budget_ns"] == 1_000_000, "its class's budget is its contract's"


def test_a_python_component_wired_to_cpp_ones_both_ways(system, components):
    components("a", "--on")
    components("dbl0", "--on", command=DOUBLER)
    components("b", "--on")
    system.connect("a.force", "dbl0.in0")
    system.connect("dbl0.out", "b.in0")
    until(lambda: port_of(system.describe("b"), "in0")["counters"]["accepted"] > 5, what="doubled data at b")
    doubled = system.get("dbl0.out")
    assert doubled.values[1] - doubled.values[0] == 2, "a's ramp (n + i), doubled"
    assert doubled.labels == ["fx", "fy", "fz", "tx", "ty", "tz"]
    system.set("dbl0", "factor", 3)
    until(lambda: system.get("dbl0.out").values[1] - system.get("dbl0.out").values[0] == 3, what="factor 3")
    system.set("dbl0", "light", 1)  # read_values(): the same values, in order, without a Datum
    system.set("dbl0", "factor", 4)
    until(lambda: system.get("dbl0.out").values[1] - system.get("dbl0.out").values[0] == 4, what="factor 4")
    light = system.get("dbl0.out").values
    assert list(light) == [4 * (light[0] / 4 + i) for i in range(6)], "a's ramp n + i, times 4, from read_values"
    with pytest.raises(rtm.Error, match=r"a.force \(RTM::TimedFloat6\) -> dbl0.pos \(RTM::TimedFloat3\): types differ"):
        system.connect("a.force", "dbl0.pos")
    with pytest.raises(rtm.Error, match=r"dbl0.pos refused the datum: .*RTM::TimedFloat6"):
        system.put("dbl0.pos", system.get("a.force"))


def test_a_step_that_raises_stops_the_component_saying_what_and_where(system, components):
    components("dbl0", "--on", command=DOUBLER)
    system.set("dbl0", "fail", 1)
    until(lambda: system.describe("dbl0")["state"] == "error", what="dbl0 in error")
    why = system.describe("dbl0")["last_error"]
    assert "step() raised ValueError: asked to fail at cycle" in why, why
    assert "doubler.py" in why, "where it was raised: " + why
    system.set("dbl0", "fail", 0)
    system.reset("dbl0")
    system.on("dbl0")
    assert system.describe("dbl0")["state"] == "on"


def test_a_bad_declaration_or_command_line_is_refused_before_anything_is_bound(naming, tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("import rtm\n"
                   "class Bad(rtm.Component):\n"
                   "    kind = 'bad'\n"
                   "    inputs = {'in0': rtm.In('TimedFloat7')}\n"
                   "    def step(self, cycle): pass\n"
                   "rtm.run(Bad)\n")
    run = subprocess.run([sys.executable, str(bad), "--naming", naming], capture_output=True, text=True, timeout=60)
    assert run.returncode == 1
    assert "port in0: no data type TimedFloat7 (the built-in ones: TimedFloat6, TimedFloat," in run.stderr, run.stderr
    run = subprocess.run([*DOUBLER, "--param", "factor", "--naming", naming], capture_output=True, text=True, timeout=60)
    assert run.returncode == 1 and "--param 'factor': want NAME=VALUE" in run.stderr, run.stderr
    run = subprocess.run([*DOUBLER, "--period", "1x"], capture_output=True, text=True, timeout=60)
    assert run.returncode == 2, run.stderr
    with pytest.raises(TypeError, match="subclass of rtm.Component"):
        rtm.run(object)


def test_its_contract_is_printed_as_a_cpp_components_is(naming):
    run = subprocess.run([*DOUBLER, "--print-contract", "--period", "4ms", "--deadline", "3ms"],
                         capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    contract = json.loads(run.stdout)
    assert (contract["component"], contract["period_ns"], contract["deadline_ns"], contract["budget_ns"]) == (
        "doubler0", 4_000_000, 3_000_000, 1_000_000)


def test_a_chain_through_a_python_component_keeps_the_sample_stamp(system, naming, tmp_path):
    file = tmp_path / "chain.yaml"
    file.write_text(f"""
name: pychain
naming: {naming}
components:
  - {{name: a, command: [rtm-test-talker, --stamp-age-ms, "50"]}}
  - {{name: dbl0, command: {json.dumps(DOUBLER)}}}
  - {{name: c, command: rtm-test-talker}}
connections:
  - {{from: a.force, to: dbl0.in0}}
  - {{from: dbl0.out, to: c.in0}}
activate: [a, dbl0, c]
chains:
  - {{name: a_to_c, path: [a.force, dbl0.in0, c.in0], deadline: 20ms}}
""")
    env_path = os.environ.get("RTM_BIN_PATH", "")
    assert TEST_BIN_DIR in env_path and BIN_DIR in env_path
    try:
        system.up(str(file))
        until(lambda: system.describe("c")["statistics"].get("chain.a_to_c.late", {}).get("value", 0) >= 10,
              what="late data at the chain's end")
        stats = system.describe("c")["statistics"]
        # The doubler stamps what it writes now; rtm up declared its out to derive from in0
        # (--stamp-from out=in0), so the stamp a set 50 ms before reaches c.
        assert stats["chain.a_to_c.latency_p50"]["value"] >= 50_000, stats["chain.a_to_c.latency_p50"]
    finally:
        system.down("pychain")


def test_a_python_chain_end_that_stops_acting_on_its_data_counts_no_stale_cycle_until_it_acts_again(system,
                                                                                                  components):
    components("a", "--on", "--stamp-age-ms", "50")
    components("dbl0", "--on", "--watch-chain", "a_to_dbl:in0:0ns:10ms", command=DOUBLER)
    system.connect("a.force", "dbl0.in0")

    def stale():
        return system.describe("dbl0")["statistics"]["chain.a_to_dbl.stale"]["value"]

    def cycles():
        return system.describe("dbl0")["timing"]["cycles"]

    until(lambda: stale() >= 5, what="stale cycles: a's data are 50 ms old, the chain tolerates 10 ms")
    system.set("dbl0", "expire", 1)
    held, since = stale(), cycles()
    until(lambda: cycles() >= since + 50, what="50 cycles of dbl0")
    assert stale() <= held + 1, "a cycle that does not act on its data is not stale (one may have run before the set)"
    system.set("dbl0", "expire", 0)
    until(lambda: stale() >= held + 10, what="stale cycles again, once it acts on its data")
