# SPDX-License-Identifier: Apache-2.0
"""docs/python.md's component example, run as written: taken out of the page, started as a
component, and fed a wrench it must double."""

import os
import re
import sys

from conftest import until

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
