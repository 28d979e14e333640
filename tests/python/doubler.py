# SPDX-License-Identifier: Apache-2.0
"""A component written in Python for the tests: out = factor * in0 (a wrench), and a position
input of another type. Its parameter fail makes the next step raise; expire and light choose
how it reads in0."""

import rtm

WRENCH = ("fx fy fz tx ty tz", "N N N N·m N·m N·m")


class Doubler(rtm.Component):
    kind = "doubler"
    description = "multiplies a wrench (a test component in Python)"
    inputs = {"in0": rtm.In("TimedFloat6", "a wrench", *WRENCH),
              "pos": rtm.In("TimedFloat3", "a position", "x y z", "m m m")}
    outputs = {"out": rtm.Out("TimedFloat6", "the wrench times factor", *WRENCH)}
    parameters = {"factor": rtm.Parameter(2.0, description="what it multiplies by"),
                  "fail": rtm.Parameter(0, description="1: the next step raises"),
                  "expire": rtm.Parameter(0, description="1: it stops acting on in0's data (expire_last)"),
                  "light": rtm.Parameter(0, description="1: it reads in0's values alone (read_values)")}
    budget = "1ms"

    def step(self, cycle):
        if self.parameter("fail"):
            raise ValueError(f"asked to fail at cycle {cycle.number}")
        if self.parameter("light"):
            values = self.inputs.in0.read_values()
        else:
            wrench = self.inputs.in0.read()
            values = None if wrench is None else wrench.values
        if self.parameter("expire"):
            self.inputs.in0.expire_last()
        elif values is not None:
            self.outputs.out.write(values * self.parameter("factor"))


if __name__ == "__main__":
    rtm.run(Doubler)
