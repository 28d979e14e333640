# SPDX-License-Identifier: Apache-2.0
"""RTM from Python: a running system of RT components, as the ``rtm`` command line sees it.

Everything here goes through RTM's C++ core (the module ``rtm._rtm``): the same type checks,
refusals, access screen and TLS as ``rtm`` and the components, and the same words when
something is refused (``rtm.Error``). docs/python.md shows its use::

    import rtm
    system = rtm.System()                      # $RTM_NAMING, else 127.0.0.1:2809
    print(system.components())                 # ['actuator0', 'controller0', ...]
    wrench = system.get("sensor0.wrench")      # an rtm.Datum
    print(wrench["fz"], wrench.values)         # by element name, or as a numpy array
    system.put("servo0.reference", {"fx": 0, "fy": 0, "fz": -10, "tx": 0, "ty": 0, "tz": 0})
    with system.watch("sensor0.wrench") as data:
        for datum in data:
            ...

A component in Python runs on the same C++ runner as every RTM component::

    class Doubler(rtm.Component):
        kind = "doubler"
        inputs = {"in0": rtm.In("TimedFloat6", "a wrench", "fx fy fz tx ty tz", "N N N N·m N·m N·m")}
        outputs = {"out": rtm.Out("TimedFloat6", "twice the wrench", "fx fy fz tx ty tz", "N N N N·m N·m N·m")}
        parameters = {"factor": rtm.Parameter(2.0, description="what it multiplies by")}

        def step(self, cycle):
            wrench = self.inputs.in0.read()           # the new datum, or None
            if wrench is not None:
                self.outputs.out.write(wrench.values * self.parameter("factor"))

    if __name__ == "__main__":
        rtm.run(Doubler)                              # --name, --naming, --period, --on, ...
"""

import os
import sys

from ._rtm import Cycle, Datum, Error, InPort, OutPort, Port
from ._rtm import System as _System
from ._rtm import Watch as _Watch
from ._rtm import _run

__all__ = ["System", "Datum", "Port", "Watch", "Error", "Component", "In", "Out", "Parameter", "Cycle", "InPort",
           "OutPort", "run"]


class Watch:
    """An OutPort's data as they come, oldest first: iterate over it, or call each().

    The watch holds at most ``capacity`` data this loop has not taken; when the loop falls
    behind, the oldest are lost and counted in ``dropped`` (with those the publisher dropped
    for it). Iteration ends when ``timeout`` seconds pass without a datum (never, without one)
    or after close(). A ``with`` block closes it.
    """

    def __init__(self, inner: _Watch, timeout):
        self._watch = inner
        self._timeout = timeout

    def __iter__(self):
        return self

    def __next__(self) -> Datum:
        datum = self._watch.next(self._timeout)
        if datum is None:
            raise StopIteration
        return datum

    def next(self, timeout=None):
        """The next datum, or None when ``timeout`` seconds passed first."""
        return self._watch.next(timeout)

    def each(self, callback, count=None):
        """Calls ``callback(datum)`` for each datum until it returns False, ``count`` data were
        taken or the watch's timeout passed without one. Returns how many it took."""
        taken = 0
        for datum in self:
            taken += 1
            if callback(datum) is False or (count is not None and taken >= count):
                break
        return taken

    @property
    def address(self) -> str:
        return self._watch.address

    @property
    def received(self) -> int:
        return self._watch.received

    @property
    def dropped(self) -> int:
        return self._watch.dropped

    @property
    def late(self) -> int:
        return self._watch.late

    @property
    def shared_memory(self) -> bool:
        return self._watch.shared_memory

    def close(self):
        self._watch.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


class System(_System):
    """The components of one naming service.

    ``naming``: "host:port" (default: $RTM_NAMING, else 127.0.0.1:2809); ``tls``: a TLS folder
    (``rtm tls init``) to reach components serving giop:ssl:; ``timeout``: the bound on each
    remote call, in seconds.
    """

    def __init__(self, naming=None, tls=None, timeout: float = 5.0):
        super().__init__(naming, None if tls is None else os.path.expanduser(str(tls)), timeout)

    def watch(self, address: str, capacity: int = 1024, timeout=None) -> Watch:
        """Subscribes to an OutPort and returns its data as they come (a Watch)."""
        return Watch(self._watch(address, capacity), timeout)


class In:
    """An InPort a Component declares: its data type (a built-in one: "TimedFloat6",
    "TimedFloat3", "TimedFloat", "TimedDouble", "TimedLong", "TimedBoolean", "TimedFloatSeq",
    "TimedDoubleSeq"), what it carries, and its elements' names and units (space-separated; "-"
    for none; units default to "-" each)."""

    def __init__(self, type: str, description: str = "", elements: str = "", units: str = ""):
        self.type = type
        self.description = description
        self.elements = elements
        self.units = units or " ".join("-" for _ in elements.split())


class Out(In):
    """An OutPort a Component declares (as In)."""


class Parameter:
    """A parameter a Component declares: its value at start (a number, or a list of them: it
    keeps that many), its unit, what it means, and when `rtm set` may change it: "live" (any
    time), "when off" or "fixed" (only at start, with --param NAME=VALUE)."""

    def __init__(self, value, unit: str = "", description: str = "", access: str = "live"):
        self.value = value
        self.unit = unit
        self.description = description
        self.access = access


class Component:
    """A component written in Python. Declare its ports and parameters as class attributes,
    and compute in step(); rtm.run() runs it as an RTM component of its own process.

    Class attributes:
      kind         what it is ("filter"): its default name is <kind>0
      description  one line: what it does (rtm cat, --help)
      inputs       {name: rtm.In(...)}, outputs {name: rtm.Out(...)}
      parameters   {name: rtm.Parameter(...)}
      budget       the longest one step takes, e.g. "0.3ms": its timing contract's budget

    While it runs: self.name; self.inputs.NAME.read() (a Datum, or None when nothing new came),
    .read_values() (its values alone, a numpy array, or None), .expire_last() (the step no longer
    acts on the last datum: a chain ending there counts it no more); self.outputs.NAME.write(values);
    self.parameter(NAME) (a number, or a list).
    """

    kind = "python"
    description = ""
    inputs = {}
    outputs = {}
    parameters = {}
    budget = ""

    def on_start(self):
        """Before the first step after on()."""

    def step(self, cycle: Cycle):
        """One cycle: read the inputs, write the outputs. An exception puts the component in
        COMPONENT_ERROR, saying what and where, and on_stop() runs."""
        raise NotImplementedError(f"{type(self).__name__}.step()")

    def on_stop(self):
        """After the last step before off(), or after a step raised."""

    def parameter(self, name: str):
        """A parameter's value now: a number, or a list of them."""
        return self._parameter(name)


def run(component_class, argv=None):
    """Runs component_class as a component of this process until SIGINT or SIGTERM, with the
    command line every RTM component takes (--name, --naming, --period, --rt-priority, --on,
    the contract's options, --param NAME=VALUE, --help), and exits with the runner's status."""
    if not (isinstance(component_class, type) and issubclass(component_class, Component)):
        raise TypeError("rtm.run() takes a subclass of rtm.Component")
    sys.exit(_run(component_class, list(sys.argv if argv is None else argv)))
