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
"""

from ._rtm import Datum, Error, Port
from ._rtm import System as _System
from ._rtm import Watch as _Watch

__all__ = ["System", "Datum", "Port", "Watch", "Error"]


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

    def watch(self, address: str, capacity: int = 1024, timeout=None) -> Watch:
        """Subscribes to an OutPort and returns its data as they come (a Watch)."""
        return Watch(self._watch(address, capacity), timeout)
