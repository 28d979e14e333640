# SPDX-License-Identifier: Apache-2.0
"""import rtm against a real system: omniNames and rtm-test-talker processes (its force port is
a ramp: value i of cycle n is n + i + offset; fx..tz in N and N·m; pos3 takes x y z in m)."""

import os
import subprocess
import sys

import numpy as np
import pytest

import rtm
from conftest import TEST_BIN_DIR, free_port, until


def port_of(description, name):
    return next(p for p in description["ports"] if p["name"] == name)


def test_components_are_listed_and_describe_their_ports_with_elements_and_units(system, components):
    components("talk0")
    components("talk1")
    assert sorted(system.components()) == ["talk0", "talk1"]
    d = system.describe("talk0")
    assert d["kind"] == "talker"
    force = port_of(d, "force")
    assert force["type"] == "RTM::TimedFloat6"
    assert [e["name"] for e in force["elements"]] == ["fx", "fy", "fz", "tx", "ty", "tz"]
    assert [e["unit"] for e in force["elements"]] == ["N", "N", "N", "N·m", "N·m", "N·m"]
    assert d["parameters"]["offset"]["unit"] == "N"
    listed = system.ls(long=True)
    assert [c["name"] for c in listed] == ["talk0", "talk1"]


def test_on_off_and_reset_switch_a_component_as_rtm_does(system, components):
    components("talk0")
    assert system.describe("talk0")["state"] == "off"
    system.on("talk0")
    assert system.describe("talk0")["state"] == "on"
    system.off("talk0")
    assert system.describe("talk0")["state"] == "off"


def test_get_gives_a_datum_by_element_name_and_as_a_numpy_array(system, components):
    components("talk0", "--on")
    until(lambda: system.describe("talk0")["timing"]["cycles"] > 2, what="talk0's cycles")
    d = system.get("talk0.force")
    assert d.type == "RTM::TimedFloat6"
    assert d.port == "talk0.force"
    assert d.time_ns > 0
    assert isinstance(d.values, np.ndarray) and d.values.shape == (6,)
    n = d.values[0]  # the cycle's number: value i is n + i
    assert list(d.values) == [n + i for i in range(6)]
    assert d["fz"] == n + 2 and d["tz"] == n + 5
    assert d.labels == ["fx", "fy", "fz", "tx", "ty", "tz"]
    assert d.units == ["N", "N", "N", "N·m", "N·m", "N·m"]
    assert d.fields == {"val": [n + i for i in range(6)]}
    assert d.as_dict()["port"] == "talk0.force"
    with pytest.raises(KeyError, match="talk0.force has no value fw"):
        d["fw"]


def test_put_takes_a_sequence_a_numpy_array_or_the_ports_element_names(system, components):
    components("talk0")
    accepted = lambda: port_of(system.describe("talk0"), "pos3")["counters"]["accepted"]
    system.put("talk0.pos3", [1, 2.5, -3])
    system.put("talk0.pos3", np.array([0.1, 0.2, 0.3]))
    put = system.put("talk0.pos3", {"x": 1, "y": 2, "z": 3})
    assert list(put.values) == [1, 2, 3] and put.type == "RTM::TimedFloat3"
    assert accepted() == 3
    with pytest.raises(rtm.Error, match="talk0.pos3 has no element w"):
        system.put("talk0.pos3", {"x": 1, "y": 2, "w": 3})
    with pytest.raises(rtm.Error, match="takes 3 values, got 2"):
        system.put("talk0.pos3", [1, 2])
    with pytest.raises(rtm.Error, match="talk0.pos3: .*nan"):
        system.put("talk0.pos3", [1, 2, float("nan")])
    assert accepted() == 3, "nothing refused reached the port"


def test_a_type_of_a_projects_own_idl_is_got_and_put_by_its_fields(system, components):
    components("pose0", "--on", command=os.path.join(TEST_BIN_DIR, "rtm-test-pose-relay"))
    put = system.put("pose0.pose_in", {"x": 0.5, "y": -1.5, "z": 2, "qw": 1, "qx": 0, "qy": 0, "qz": 0})
    assert put.type == "RtmTest::TimedPose"
    until(lambda: _has_data(system), what="the pose passed on")
    pose = system.get("pose0.pose_out")
    assert pose.type == "RtmTest::TimedPose"
    assert pose.fields == {"p": {"x": 0.5, "y": -1.5, "z": 2.0}, "q": [1.0, 0.0, 0.0, 0.0]}
    assert pose.labels == ["x", "y", "z", "qw", "qx", "qy", "qz"]
    assert list(pose.values) == [0.5, -1.5, 2.0, 1.0, 0.0, 0.0, 0.0]
    assert pose["y"] == -1.5 and pose.units[:3] == ["m", "m", "m"]
    assert pose.time_ns == put.time_ns, "the stamp put is the stamp passed on"
    with pytest.raises(rtm.Error, match="pose0.pose_in: .*7"):
        system.put("pose0.pose_in", [1, 2, 3])


def _has_data(system):
    try:
        system.get("pose0.pose_out")
        return True
    except rtm.Error as e:
        assert "no data yet" in str(e), e
        return False


def test_a_datum_of_another_type_is_refused_with_the_inports_own_words(system, components):
    components("talk0", "--on")
    until(lambda: system.describe("talk0")["timing"]["cycles"] > 0, what="talk0's cycles")
    wrench = system.get("talk0.force")
    with pytest.raises(rtm.Error, match=r"talk0.pos3 refused the datum: .*RTM::TimedFloat6"):
        system.put("talk0.pos3", wrench)
    assert port_of(system.describe("talk0"), "pos3")["counters"]["rejected"] == 1


def test_set_changes_a_parameter_and_a_refusal_says_why(system, components):
    components("talk0", "--on")
    assert system.set("talk0", "offset", 0.5) == "0.5"
    until(lambda: system.get("talk0.force").values[0] % 1 == 0.5, what="the offset in the data")
    with pytest.raises(rtm.Error, match="nosuch"):
        system.set("talk0", "nosuch", 1)


def test_connect_and_disconnect_with_the_same_refusals_as_rtm(system, components):
    components("talk0", "--on")
    components("talk1")
    system.connect("talk0.force", "talk1.in0")
    subscriptions = port_of(system.describe("talk0"), "force")["subscriptions"]
    assert [s["peer"] for s in subscriptions] == ["talk1.in0"]
    until(lambda: port_of(system.describe("talk1"), "in0")["counters"]["accepted"] > 3, what="data at talk1.in0")
    with pytest.raises(rtm.Error, match=r"talk0.force \(RTM::TimedFloat6\) -> talk1.pos3 \(RTM::TimedFloat3\): types differ"):
        system.connect("talk0.force", "talk1.pos3")
    system.disconnect("talk0.force", "talk1.in0")
    assert port_of(system.describe("talk0"), "force")["subscriptions"] == []


def test_watch_gives_every_datum_in_order(system, components):
    components("talk0", "--on")
    with system.watch("talk0.force", timeout=5) as data:
        got = []
        assert data.each(lambda d: got.append(d.values[0]), count=100) == 100
        assert data.dropped == 0
        assert data.received >= 100
    assert got == [got[0] + k for k in range(100)], "one datum per cycle, none lost, in order"
    with pytest.raises(rtm.Error, match="closed"):
        data.next()


def test_unknown_names_and_a_naming_service_that_is_down_are_errors_that_say_so(system, components, naming):
    with pytest.raises(rtm.Error, match="ghost"):
        system.describe("ghost")
    with pytest.raises(rtm.Error, match="ghost"):
        system.get("ghost.force")
    components("talk0")
    with pytest.raises(rtm.Error, match="pos4"):
        system.get("talk0.pos4")
    with pytest.raises(rtm.Error, match="InPort; get reads OutPorts"):
        system.get("talk0.pos3")
    down = rtm.System(naming=f"127.0.0.1:{free_port()}", timeout=1)
    with pytest.raises(rtm.Error, match="naming"):
        down.components()
    with pytest.raises(rtm.Error, match="want above 0"):
        rtm.System(naming=naming, timeout=0)


def test_up_and_down_start_and_stop_a_system_file(system, naming, tmp_path):
    file = tmp_path / "pair.yaml"
    file.write_text(f"""
name: pypair
naming: {naming}
components:
  - {{name: a, command: rtm-test-talker}}
  - {{name: b, command: rtm-test-talker}}
connections:
  - {{from: a.force, to: b.in0}}
activate: [a, b]
""")
    try:
        up = system.up(str(file))
        assert up["system"] == "pypair"
        assert [p["name"] for p in up["processes"]] == ["a", "b"]
        assert sorted(system.components()) == ["a", "b"]
        until(lambda: port_of(system.describe("b"), "in0")["counters"]["accepted"] > 0, what="a's data at b")
    finally:
        assert system.down("pypair") == []
    until(lambda: system.components() == [], what="the system gone")


@pytest.mark.skipif(os.geteuid() != 0, reason="runs a process as another user (runuser): needs root")
def test_another_users_process_reads_but_is_refused_a_change_with_the_access_screens_words(system, components, naming):
    components("talk0")
    script = (
        "import rtm, sys\n"
        "s = rtm.System(naming=sys.argv[1])\n"
        "print('state', s.describe('talk0')['state'])\n"
        "try:\n"
        "    s.set('talk0', 'offset', 1)\n"
        "    print('changed')\n"
        "except rtm.Error as e:\n"
        "    print('refused:', e)\n")
    other = subprocess.run(["runuser", "-u", "nobody", "--", sys.executable, "-c", script, naming],
                           capture_output=True, text=True, timeout=60, env=os.environ)
    assert other.returncode == 0, other.stderr
    lines = other.stdout.splitlines()
    assert lines[0] == "state off", "reading is open to every local user"
    assert lines[1].startswith("refused: "), other.stdout
    assert "not allowed: only the user who started it may change it (this process runs as nobody" in lines[1], lines[1]
    assert system.describe("talk0")["parameters"]["offset"]["value"] == "0", "nothing changed"


def test_a_tls_folder_is_checked_and_one_process_keeps_the_tls_of_its_first_system(system, tmp_path):
    script = ("import rtm\n"
              "try:\n"
              "    rtm.System(naming='127.0.0.1:1', tls='~/rtm-no-such-tls')\n"
              "except rtm.Error as e:\n"
              "    print(e)\n")
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60,
                         env={**os.environ, "HOME": str(tmp_path)})
    assert run.stdout.strip() == f"{tmp_path}/rtm-no-such-tls: no such TLS folder (`rtm tls init` makes one)", run
    with pytest.raises(rtm.Error, match="already talks to components without TLS; a System with tls=.* needs a process"):
        rtm.System(naming=system.naming, tls=str(tmp_path))
