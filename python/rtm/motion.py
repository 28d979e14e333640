# SPDX-License-Identifier: Apache-2.0
"""Motion scripts: the servo's reference written as a program (docs/python.md, "Motion scripts").

A motion script is a plain Python file that drives the force servo through ``arm``::

    from rtm.motion import arm

    arm.approach("-z", speed=0.005, contact=2.0, timeout=20)   # down until it touches
    arm.press(10, ramp=1.0, hold=2.0)                          # 10 N along the approach
    arm.slide("x", distance=0.05, speed=0.01, force=10)        # 5 cm along x, holding 10 N
    arm.press(20, ramp=1.0, hold=2.0)
    arm.release(lift=0.01)                                     # to 0 N, then 1 cm up

It runs as a component of its own (kind "script") in place of the joystick: InPorts ``wrench``
(the wrist sensor's reading) and ``pose`` (the tool's measured pose, the actuator's ``pose``),
OutPort ``reference`` (the servo's reference, wired to ``servo0.reference``). Each call of
``arm`` blocks the script until it is done, while the component's step evaluates it on the
servo's 2 ms grid. ``rtm script FILE`` starts it, wires it and runs it (rtm/script.py).

The servo is the paper's P controller, ``twist = gain * (reference + wrench)``, so the
reference is a force. Along the contact's normal the script asks for the force it wants the
tool to apply; to move (in free space, or along the surface while pressing) it asks for the
force that makes the controller command the velocity it wants: ``velocity / gain - wrench``.
It knows the controller's gains from its parameters (``rtm script`` copies the controller's).

When the script returns, raises, or is stopped (``rtm off``, Ctrl-C on ``rtm script``), the
component writes no more references. The controller then withholds its command (its reference
goes stale after a few cycles) and the actuator's watchdog brakes the drives: nothing is left
commanding the arm.
"""

import math
import os
import runpy
import sys
import threading
import time
import traceback

import numpy as np

import rtm

__all__ = ["arm", "Arm", "ScriptError", "Stopped", "ScriptComponent", "direction"]

# Tangential position feedback, 1/s: how fast a hold or a slide pulls the tool back onto its
# path (a time constant of 0.2 s: slow beside the servo's loop and its delays).
POSITION_GAIN = 5.0
# A slide is done when its path's end is reached and the tool is this close to it, m.
ARRIVED_M = 0.0005
# ... or at the latest this long after its path's end, s.
SETTLE_S = 1.0
# Along the surface the controller's command is gain * (reference + wrench): the reference
# cancels the wrench there (friction, mostly) so that the command is the velocity asked for. It
# cancels the wrench low-passed with this time constant, s: the cancellation of a wrench one
# period old would feed each stick-slip jolt of the friction straight back into the command.
# A pose port's feedback takes up what the filter leaves.
FRICTION_FILTER_S = float(os.environ.get("RTM_MOTION_FRICTION_FILTER_S", "0.1"))
# Cycles without a new wrench after which the script writes nothing (the servo brakes).
STALE_CYCLES = 10
# Cycles without a wrench (none yet, or none new) after which the motion in progress fails: the
# sensor's data stopped coming, and the script must not wait for it for ever (0.5 s at 2 ms).
LOST_CYCLES = 250


class ScriptError(Exception):
    """A motion that cannot be done as asked: no contact within the timeout, an unexpected
    contact while moving in free space, a press without a contact. The script stops there."""


class Stopped(Exception):
    """The script was stopped (the component turned off, Ctrl-C on rtm script, arm.stop())."""


def direction(value) -> np.ndarray:
    """A unit 3-vector from "x", "-z", ... or three numbers."""
    if isinstance(value, str):
        text = value.strip().lower()
        sign = -1.0 if text.startswith("-") else 1.0
        axis = text.lstrip("+-")
        if axis not in ("x", "y", "z"):
            raise ValueError(f"direction '{value}': want x, y, z, -x, -y, -z or three numbers")
        v = np.zeros(3)
        v["xyz".index(axis)] = sign
        return v
    v = np.asarray(value, dtype=float).reshape(-1)
    if v.size != 3 or not np.all(np.isfinite(v)) or np.linalg.norm(v) < 1e-9:
        raise ValueError(f"direction {value!r}: want three finite numbers, not all zero")
    return v / np.linalg.norm(v)


# Each cycle's arithmetic is on 3 floats (lists), not numpy arrays: on a 3-vector each numpy
# operation costs a few µs, ten times the arithmetic it does.
def _dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _across(v, n) -> list:
    """v without its part along the unit vector n."""
    k = _dot(v, n)
    return [v[i] - k * n[i] for i in range(3)]


def _positive(name, value, allow_zero=False, allow_none=False):
    if value is None and allow_none:
        return None
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} {value!r}: want a number") from None
    if not math.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        raise ValueError(f"{name} {value!r}: want a finite number {'>= 0' if allow_zero else '> 0'}")
    return v


class State:
    """What one cycle sees: time (s since the script began), the wrench as the sensor reads it
    (the reaction), the tool's pose (None without a pose port) and the contact as the
    controller judges it. ``applied`` is the force the tool applies (the reading negated)."""

    __slots__ = ("time", "wrench", "pose", "in_contact", "normal")

    def __init__(self):
        self.time = 0.0
        self.wrench = np.zeros(6)
        self.pose = None
        self.in_contact = False
        self.normal = None

    @property
    def applied(self) -> np.ndarray:
        return -self.wrench[:3]

    @property
    def position(self):
        return None if self.pose is None else self.pose[:3]

    @property
    def force(self) -> float:
        """The force the tool applies along the contact's normal (N); its magnitude before any
        contact was made."""
        if self.normal is None:
            return float(np.linalg.norm(self.applied))
        return float(self.applied @ self.normal)


class _Motion:
    """One call of the vocabulary, evaluated on the component's cycle. Subclasses set what the
    cycle commands: ``force`` (N along the normal, or None: no force control) and ``velocity``
    (m/s, base frame), and say when they are done."""

    name = "motion"

    def __init__(self):
        self.started_s = None
        self.done = threading.Event()
        self.error = None
        self.result = None
        self.begin_ns = 0  # CLOCK_REALTIME, for the phase log
        self.end_ns = 0

    def describe(self) -> str:
        return self.name

    def start(self, state: State, arm: "Arm"):
        """The first cycle."""

    def figures(self):
        """(force N, normal, along): what the phase log records of it for the demo's report:
        the force it pressed with along the normal, and the direction it moved in (None each
        when it has none)."""
        return None, None, None

    def command(self, state: State, t: float, arm: "Arm"):
        """(force or None, velocity 3-vector, finished) for this cycle; t: s since start."""
        raise NotImplementedError


class Arm:
    """The servo as a script sees it. Each method blocks until its motion is done (or raises
    ScriptError, or Stopped), and returns what it reached. Between two calls the arm holds:
    the force of the last press (or none in free space) and the tool where it is."""

    def __init__(self, gain, free_gain, contact_force, approach_speed):
        self.gain = np.asarray(gain, dtype=float)[:3]
        self.free_gain = np.asarray(free_gain, dtype=float)[:3]
        self.contact_force = float(contact_force)
        self.approach_speed = float(approach_speed)
        self._lock = threading.Lock()
        self._state = State()
        self._current = None
        self._stopping = threading.Event()
        self._hold_force = None  # N along the normal while holding, or None (free space)
        self._hold_point = None  # where the tool is held (tangentially, in contact), or None
        self._below_cycles = 0
        self._lost = None  # why the inputs are gone, once they are
        self._ports = {}  # the newest datum of each port rtm script --watch wired in, by name
        self._filtered = None  # the wrench's force, low-passed (FRICTION_FILTER_S): 3 floats
        self._last_s = None
        self.phases = []  # (begin_ns, end_ns, name, description, outcome, figures()) of each call

    # ------------------------------------------------------------ what the script reads
    @property
    def wrench(self) -> np.ndarray:
        """The wrist wrench as the sensor reads it (the reaction), N and N·m."""
        return self._state.wrench.copy()

    @property
    def force(self) -> float:
        """The force the tool applies along the contact's normal, N (its magnitude before any
        contact)."""
        return self._state.force

    @property
    def pose(self):
        """The tool's measured pose (x y z m, rotation vector rad, base frame), or None."""
        return None if self._state.pose is None else self._state.pose.copy()

    @property
    def position(self):
        return None if self._state.pose is None else self._state.pose[:3].copy()

    @property
    def in_contact(self) -> bool:
        return self._state.in_contact

    @property
    def normal(self):
        """The direction the tool presses in (the last approach's), or None."""
        return None if self._state.normal is None else self._state.normal.copy()

    @property
    def time(self) -> float:
        """Seconds since the script began."""
        return self._state.time

    def port(self, name: str):
        """The newest datum (an rtm.Datum) of a port `rtm script --watch NAME=COMPONENT.PORT`
        wired into the script, or None before the first; e.g. in a condition:
        ``arm.wait(until=lambda a: (a.port("grip") or {"v0": 0})["v0"] > 0.5)``."""
        if name not in self._ports:
            raise KeyError(f"no port {name} is watched (rtm script --watch {name}=COMPONENT.PORT); watched: "
                           f"{', '.join(sorted(self._ports)) or 'none'}")
        return self._ports[name]

    # ------------------------------------------------------------ the vocabulary
    def move(self, towards, speed=0.005, distance=None, duration=None, contact_ok=False):
        """Moves in free space along ``towards`` at ``speed`` m/s, for ``distance`` m (measured
        on the pose port; without one, distance/speed seconds) or ``duration`` s. A contact on
        the way raises ScriptError unless ``contact_ok``. The controller's approach speed bounds
        the speed in free space. Returns the distance moved (m; None without a pose)."""
        return self._do(_Move(direction(towards), _positive("speed", speed), _positive("distance", distance,
                              allow_none=True), _positive("duration", duration, allow_none=True), contact_ok))

    def approach(self, towards="-z", speed=0.005, contact=2.0, timeout=10.0):
        """Moves along ``towards`` until the tool pushes ``contact`` N along it, then holds that
        force; ``towards`` becomes the normal later presses and slides use. ScriptError when no
        contact comes within ``timeout`` s. Returns the force on contact."""
        return self._do(_Approach(direction(towards), _positive("speed", speed), _positive("contact", contact),
                                  _positive("timeout", timeout)))

    def press(self, force, hold=0.0, ramp=0.5):
        """Ramps the force along the normal from the one held to ``force`` N over ``ramp`` s,
        then holds it ``hold`` s, the tool kept where it is along the surface. Needs a contact
        (approach first). Returns the force applied at the end."""
        return self._do(_Press(None, _positive("force", force, allow_zero=True),
                               _positive("ramp", ramp, allow_zero=True), _positive("hold", hold, allow_zero=True)))

    def ramp(self, start, end, duration):
        """Ramps the force along the normal from ``start`` to ``end`` N over ``duration`` s.
        Returns the force applied at the end."""
        return self._do(_Press(_positive("start", start, allow_zero=True), _positive("end", end, allow_zero=True),
                               _positive("duration", duration), 0.0))

    def hold(self, duration):
        """Keeps what the last call left (its force, the tool where it is) for ``duration`` s."""
        return self._do(_Wait(_positive("duration", duration, allow_zero=True), None))

    def slide(self, along, distance, speed=0.01, force=None):
        """Moves ``distance`` m along the surface in the direction ``along`` (its part across the
        normal) at ``speed`` m/s, pressing ``force`` N along the normal (default: the force
        held): force control along the normal, motion control along the surface. With a pose
        port the tool follows the straight line from where it starts. Returns the distance
        slid (m; None without a pose)."""
        return self._do(_Slide(direction(along), _positive("distance", distance), _positive("speed", speed),
                               _positive("force", force, allow_zero=True, allow_none=True)))

    def wait(self, duration=None, until=None, timeout=None):
        """Holds until ``until(arm)`` is true (checked each cycle, so keep it cheap: e.g.
        ``lambda a: a.force > 5``) or for ``duration`` s. With ``until``, ScriptError after
        ``timeout`` s. Returns the time waited (s)."""
        if until is None and duration is None:
            raise ValueError("wait(): give a duration or an until condition")
        if until is not None and not callable(until):
            raise ValueError("wait(until=...): want a function of the arm, e.g. lambda a: a.force > 5")
        limit = _positive("timeout", timeout, allow_none=True) if until is not None else _positive("duration", duration,
                                                                                                   allow_zero=True)
        return self._do(_Wait(limit, until))

    def release(self, lift=0.01, speed=0.005, ramp=0.5):
        """Ramps the force to 0 over ``ramp`` s, then lifts the tool ``lift`` m against the
        normal at ``speed`` m/s. Returns the height lifted (m; None without a pose)."""
        self._do(_Press(None, 0.0, _positive("ramp", ramp, allow_zero=True), 0.0))
        normal = self._state.normal if self._state.normal is not None else direction("-z")
        lifted = self._do(_Move(-normal, _positive("speed", speed), _positive("lift", lift), None, True, name="lift"))
        self._state.normal = None
        return lifted

    def stop(self, why="the script stopped"):
        """Ends the script here, safely: the servo brakes."""
        raise Stopped(why)

    # ------------------------------------------------------------ the machinery
    def _do(self, motion: _Motion):
        if self._stopping.is_set():
            raise Stopped("the script was stopped")
        if self._lost is not None:
            raise ScriptError(f"{motion.describe()}: {self._lost}")
        with self._lock:
            self._current = motion
        try:
            while not motion.done.wait(0.1):
                if self._stopping.is_set():
                    raise Stopped(f"stopped during {motion.describe()}")
        finally:
            with self._lock:
                if self._current is motion:
                    self._current = None
                self.phases.append((motion.begin_ns, motion.end_ns or time.time_ns(), motion.name, motion.describe(),
                                    "error" if motion.error else ("done" if motion.done.is_set() else "stopped"),
                                    motion.figures()))
        if motion.error is not None:
            raise motion.error
        return motion.result

    def _stop(self):
        self._stopping.set()  # the script's call in progress sees it within 0.1 s

    def _lose(self, why):
        """The inputs are gone: the motion in progress (and the next) fails with ScriptError."""
        with self._lock:
            motion = self._current
        self._lost = why
        if motion is not None and not motion.done.is_set():
            self._end(motion, ScriptError(f"{motion.describe()}: {why}"))

    def _contact(self, wrench) -> bool:
        """The controller's contact judgement (its ContactDetector), mirrored."""
        magnitude = math.hypot(wrench[0], wrench[1], wrench[2])
        if not self._state.in_contact:
            self._below_cycles = 0
            return magnitude >= self.contact_force
        if magnitude >= 0.5 * self.contact_force:
            self._below_cycles = 0
            return True
        self._below_cycles += 1
        return self._below_cycles < 10

    def _reference(self, force, velocity) -> np.ndarray:
        """The reference that makes the controller press ``force`` N along the normal (None:
        no force control) and move at ``velocity`` m/s across it (all of it without force)."""
        s = self._state
        gain = (self.gain if s.in_contact else self.free_gain).tolist()
        v, f = velocity.tolist(), self._filtered
        m = [(v[i] / gain[i] if gain[i] > 0 else 0.0) - f[i] for i in range(3)]
        if force is None or s.normal is None:
            return np.array((m[0], m[1], m[2], 0.0, 0.0, 0.0))
        n = s.normal.tolist()
        surface = _across(m, n)  # along the normal, the force takes the motion's place
        return np.array([force * n[i] + surface[i] for i in range(3)] + [0.0, 0.0, 0.0])

    def _hold_velocity(self):
        s = self._state
        if self._hold_point is None or s.pose is None:
            return np.zeros(3)
        h, p = self._hold_point.tolist(), s.pose.tolist()
        error = [h[i] - p[i] for i in range(3)]
        if s.normal is not None and self._hold_force is not None:  # along the surface only
            error = _across(error, s.normal.tolist())
        return np.array([POSITION_GAIN * e for e in error])

    def _cycle(self, now_s, wrench, pose):
        """One cycle (the component's step): the reference to write."""
        s = self._state
        s.time = now_s
        s.wrench = wrench
        s.pose = pose
        s.in_contact = self._contact(wrench)
        w = wrench[:3].tolist()
        if self._filtered is None or FRICTION_FILTER_S <= 0:
            self._filtered = w
        else:
            share = min(1.0, (now_s - self._last_s) / FRICTION_FILTER_S) if now_s > self._last_s else 0.0
            f = self._filtered
            self._filtered = [f[i] + share * (w[i] - f[i]) for i in range(3)]
        self._last_s = now_s
        with self._lock:
            motion = self._current
        if motion is not None and not motion.done.is_set():
            if motion.started_s is None:
                motion.started_s = now_s
                motion.begin_ns = time.time_ns()
                try:
                    motion.start(s, self)
                except ScriptError as e:
                    return self._finish(motion, error=e)
            try:
                force, velocity, finished = motion.command(s, now_s - motion.started_s, self)
            except ScriptError as e:
                return self._finish(motion, error=e)
            if finished:
                self._finish(motion)
            else:
                return self._reference(force, velocity)
        return self._reference(self._hold_force, self._hold_velocity())

    def _finish(self, motion, error=None):
        """Ends the motion on the cycle; the reference of the hold it leaves."""
        self._end(motion, error)
        return self._reference(self._hold_force, self._hold_velocity())

    @staticmethod
    def _end(motion, error):
        motion.end_ns = time.time_ns()
        motion.error = error
        motion.done.set()  # the script's call returns (or raises error)


# ---------------------------------------------------------------- the motions
class _Move(_Motion):
    name = "move"

    def __init__(self, towards, speed, distance, duration, contact_ok, name="move"):
        super().__init__()
        self.name = name
        self.towards, self.speed, self.distance, self.duration, self.contact_ok = (towards, speed, distance, duration,
                                                                                   contact_ok)
        self.origin = None

    def describe(self):
        how = f"{self.distance * 1000:g} mm" if self.distance else (f"{self.duration:g} s" if self.duration else "")
        return f"{self.name} {_axis_text(self.towards)} {how} at {self.speed * 1000:g} mm/s".replace("  ", " ")

    def start(self, state, arm):
        self.origin = None if state.pose is None else state.pose[:3].copy()
        if not self.contact_ok and state.in_contact:
            raise ScriptError(f"{self.name}: the tool is in contact ({state.force:.1f} N): move is for free space "
                              "(slide along a surface, release to leave it)")
        arm._hold_force = None
        arm._hold_point = None

    def command(self, state, t, arm):
        if not self.contact_ok and state.in_contact:
            raise ScriptError(f"{self.name}: touched something after {t:.2f} s ({state.force:.1f} N): stopped")
        moved = None if self.origin is None else float((state.pose[:3] - self.origin) @ self.towards)
        self.result = moved
        if self.distance is not None:
            finished = moved >= self.distance if moved is not None else t >= self.distance / self.speed
        elif self.duration is not None:
            finished = t >= self.duration
        else:
            finished = False
        if finished:
            arm._hold_point = None if state.pose is None else state.pose[:3].copy()
            return None, np.zeros(3), True
        velocity = self.speed * self.towards
        if self.origin is not None:  # back onto the line from where it started
            off = state.pose[:3] - self.origin
            velocity = velocity - POSITION_GAIN * (off - (off @ self.towards) * self.towards)
        return None, velocity, False


class _Approach(_Motion):
    name = "approach"

    def __init__(self, towards, speed, contact, timeout):
        super().__init__()
        self.towards, self.speed, self.contact, self.timeout = towards, speed, contact, timeout
        self.origin = None

    def describe(self):
        return f"approach {_axis_text(self.towards)} at {self.speed * 1000:g} mm/s until {self.contact:g} N"

    def start(self, state, arm):
        self.origin = None if state.pose is None else state.pose[:3].copy()
        arm._hold_force = None
        arm._hold_point = None

    def command(self, state, t, arm):
        pushed = float(state.applied @ self.towards)
        if pushed >= self.contact:
            state.normal = self.towards.copy()
            arm._hold_force = self.contact
            arm._hold_point = None if state.pose is None else state.pose[:3].copy()
            self.result = pushed
            return self.contact, np.zeros(3), True
        if t >= self.timeout:
            moved = "" if self.origin is None else f", {abs((state.pose[:3] - self.origin) @ self.towards) * 1000:.1f} mm"
            raise ScriptError(f"approach: no contact within {self.timeout:g} s ({pushed:.2f} N{moved})")
        return None, self.speed * self.towards, False


class _Press(_Motion):
    name = "press"

    def __init__(self, start_force, force, ramp, hold):
        super().__init__()
        self.start_force, self.force, self.ramp, self.hold = start_force, force, ramp, hold
        self.from_force = 0.0
        self.normal = None

    def describe(self):
        if self.start_force is not None:
            return f"ramp {self.start_force:g} N to {self.force:g} N over {self.ramp:g} s"
        if self.force == 0 and self.hold == 0:
            return f"unload to 0 N over {self.ramp:g} s"
        return f"press {self.force:g} N (ramp {self.ramp:g} s, hold {self.hold:g} s)"

    def start(self, state, arm):
        if state.normal is None:
            raise ScriptError(f"{self.describe()}: no contact to press on (approach a surface first)")
        self.normal = state.normal.copy()
        self.from_force = self.start_force if self.start_force is not None else (
            arm._hold_force if arm._hold_force is not None else state.force)
        if arm._hold_point is None and state.pose is not None:
            arm._hold_point = state.pose[:3].copy()
        self.name = "ramp" if self.start_force is not None else ("unload" if self.force == 0 and self.hold == 0
                                                                 else "press")

    def figures(self):
        return self.force, self.normal, None

    def command(self, state, t, arm):
        share = 1.0 if self.ramp <= 0 else min(t / self.ramp, 1.0)
        target = self.from_force + (self.force - self.from_force) * share
        arm._hold_force = target
        if t >= self.ramp + self.hold:
            self.result = state.force
            return target, np.zeros(3), True
        return target, arm._hold_velocity(), False


class _Slide(_Motion):
    name = "slide"

    def __init__(self, along, distance, speed, force):
        super().__init__()
        self.along, self.distance, self.speed, self.force = along, distance, speed, force
        self.origin = None
        self.path = None
        self.normal = None

    def describe(self):
        f = "" if self.force is None else f" at {self.force:g} N"
        return f"slide {_axis_text(self.along)} {self.distance * 1000:g} mm at {self.speed * 1000:g} mm/s{f}"

    def start(self, state, arm):
        n = state.normal
        if n is None:
            raise ScriptError(f"{self.describe()}: no contact to slide on (approach a surface first)")
        d = self.along - (self.along @ n) * n
        if np.linalg.norm(d) < 1e-6:
            raise ScriptError(f"{self.describe()}: that direction is the normal itself, not along the surface")
        self.path = d / np.linalg.norm(d)
        self.normal = n.copy()
        if self.force is None:
            self.force = arm._hold_force if arm._hold_force is not None else state.force
        arm._hold_force = self.force
        self.origin = None if state.pose is None else (
            arm._hold_point.copy() if arm._hold_point is not None else state.pose[:3].copy())

    def figures(self):
        return self.force, self.normal, self.path

    def command(self, state, t, arm):
        length = self.distance / self.speed
        if self.origin is None:
            if t >= length:
                return self.force, np.zeros(3), True
            return self.force, self.speed * self.path, False
        along = min(self.speed * t, self.distance)
        o, d, n, p = self.origin.tolist(), self.path.tolist(), state.normal.tolist(), state.pose.tolist()
        target = [o[i] + along * d[i] for i in range(3)]
        error = _across([target[i] - p[i] for i in range(3)], n)  # along the surface only
        self.result = _dot([p[i] - o[i] for i in range(3)], d)
        if t >= length and (math.hypot(*error) <= ARRIVED_M or t >= length + SETTLE_S):
            arm._hold_point = np.array(target)
            return self.force, np.zeros(3), True
        feed = self.speed if t < length else 0.0
        return self.force, np.array([feed * d[i] + POSITION_GAIN * error[i] for i in range(3)]), False


class _Wait(_Motion):
    name = "wait"

    def __init__(self, limit, until):
        super().__init__()
        self.limit, self.until = limit, until

    def describe(self):
        if self.until is None:
            return f"hold {self.limit:g} s"
        return "wait until a condition" + ("" if self.limit is None else f" (at most {self.limit:g} s)")

    def start(self, state, arm):
        self.name = "hold" if self.until is None else "wait"

    def command(self, state, t, arm):
        if self.until is not None:
            try:
                met = bool(self.until(arm))
            except Exception as e:  # the condition itself failed: say so where the script waits
                raise ScriptError(f"wait: the condition raised {type(e).__name__}: {e}") from e
            if met:
                self.result = t
                return arm._hold_force, np.zeros(3), True
            if self.limit is not None and t >= self.limit:
                raise ScriptError(f"wait: the condition did not hold within {self.limit:g} s")
        elif t >= self.limit:
            self.result = t
            return arm._hold_force, np.zeros(3), True
        return arm._hold_force, arm._hold_velocity(), False


def _axis_text(v) -> str:
    for i, axis in enumerate("xyz"):
        if abs(abs(v[i]) - 1) < 1e-9:
            return ("-" if v[i] < 0 else "+") + axis
    return "(" + " ".join(f"{c:.3g}" for c in v) + ")"


# ---------------------------------------------------------------- `arm` for the script file
class _ActiveArm:
    """``rtm.motion.arm``: the Arm of the script this process runs."""

    def __getattr__(self, name):
        current = _active.get("arm")
        if current is None:
            raise RuntimeError("rtm.motion.arm is the running script's arm: run the file with `rtm script FILE`")
        return getattr(current, name)


_active = {}
arm = _ActiveArm()


def where(error: BaseException, script_path: str) -> str:
    """"FILE:LINE: the line's text" of the deepest frame of the script file in the error's
    traceback ("" when none is)."""
    script = os.path.realpath(script_path)
    found = ""
    for frame in traceback.extract_tb(error.__traceback__):
        if os.path.realpath(frame.filename) == script:
            found = f"{os.path.basename(script_path)}:{frame.lineno}: {(frame.line or '').strip()}"
    return found


# ---------------------------------------------------------------- the component
_WRENCH = ("fx fy fz tx ty tz", "N N N N·m N·m N·m")
_POSE = ("x y z rx ry rz", "m m m rad rad rad")


class ScriptComponent(rtm.Component):
    """A motion script as an RT component: on() runs the script from its first line; the step
    evaluates its current motion each cycle and writes the reference."""

    kind = "script"
    description = "a motion script (docs/python.md): the servo's reference from a program"
    inputs = {
        "wrench": rtm.In("TimedFloat6", "the wrist wrench as the sensor reads it (the reaction)", *_WRENCH),
        "pose": rtm.In("TimedFloat6", "the tool's measured pose, base frame (position, rotation vector)", *_POSE),
    }
    outputs = {"reference": rtm.Out("TimedFloat6", "the servo's reference: the force the tool is to apply", *_WRENCH)}
    parameters = {
        "gain": rtm.Parameter([0.0004] * 3, "(m/s)/N", "the controller's gain in contact (x y z)", "when off"),
        "free_gain": rtm.Parameter([0.003] * 3, "(m/s)/N", "the controller's gain in free space (x y z)", "when off"),
        "contact_force": rtm.Parameter(1.0, "N", "the controller's contact threshold", "when off"),
        "approach_speed": rtm.Parameter(0.005, "m/s", "the controller's free-space speed limit", "when off"),
    }
    budget = "1ms"

    script_path = ""
    status_fd = -1
    phases_path = ""

    watched = ()  # the names of the InPorts --input added

    def on_start(self):
        self._arm = Arm(self.parameter("gain"), self.parameter("free_gain"), self.parameter("contact_force"),
                        self.parameter("approach_speed"))
        self._arm._ports = {name: None for name in self.watched}
        self._wrench = None
        self._pose = None
        self._fresh = 0
        self._missing = 0
        self._started_ns = None
        self._ended = threading.Event()
        self._thread = threading.Thread(target=self._run_script, name="script", daemon=True)
        self._thread.start()

    def step(self, cycle):
        w = self.inputs.wrench.read_values()  # the values alone: no Datum made
        if w is not None:
            self._wrench = w
            self._fresh = 0
        else:
            self._fresh += 1
        p = self.inputs.pose.read_values()
        if p is not None:
            self._pose = p
        for name in self.watched:
            datum = getattr(self.inputs, name).read()
            if datum is not None:
                self._arm._ports[name] = datum
        if self._wrench is None or self._fresh >= STALE_CYCLES:
            # Nothing written: the controller withholds its command, the drives brake. The
            # motion in progress fails once the wrench has been missing for LOST_CYCLES.
            self._missing += 1
            if self._missing == LOST_CYCLES:
                self._arm._lose(f"no wrench came from the sensor for {LOST_CYCLES} cycles "
                                f"({'none yet' if self._wrench is None else 'its data stopped'})")
            return
        self._missing = 0
        if self._ended.is_set():
            return
        if not all(map(math.isfinite, self._wrench.tolist())):
            return
        if self._started_ns is None:
            self._started_ns = cycle.wake_ns
        reference = self._arm._cycle((cycle.wake_ns - self._started_ns) * 1e-9, self._wrench, self._pose)
        if all(map(math.isfinite, reference.tolist())):
            self.outputs.reference.write(reference)

    def on_stop(self):
        self._arm._stop()
        self._ended.set()
        self._thread.join(5.0)

    def _run_script(self):
        arm = self._arm
        _active["arm"] = arm
        outcome, status = "done", 0
        try:
            runpy.run_path(self.script_path, run_name="__rtm_script__")
        except Stopped as e:
            outcome, status = f"stopped: {e}", 130
            spot = where(e, self.script_path)
            if spot:
                outcome += f" (at {spot})"
        except Exception as e:  # the script's own error: stop safely, say what and where
            spot = where(e, self.script_path)
            outcome, status = f"raised {type(e).__name__}: {e}" + (f" (at {spot})" if spot else ""), 1
            sys.stderr.write("".join(traceback.format_exception(e)))
        finally:
            self._ended.set()  # from the next cycle on, nothing is written: the servo brakes
            _active.pop("arm", None)
        self._write_phases(arm)
        if self.status_fd < 0:  # run by itself (rtm up): the log says how it ended
            print(f"{self.name}: script {os.path.basename(self.script_path)}: {outcome}; the servo brakes", flush=True)
        else:  # run by rtm script, which says it
            try:
                os.write(self.status_fd, f"{status} {outcome}\n".encode())
            except OSError:
                pass

    def _write_phases(self, arm):
        if not self.phases_path:
            return
        with open(self.phases_path, "w", encoding="utf-8") as f:
            f.write("begin_ns,end_ns,motion,outcome,force_N,normal_x,normal_y,normal_z,along_x,along_y,along_z,"
                    "description\n")
            for begin, end, name, text, outcome, (force, normal, along) in arm.phases:
                cells = [str(begin), str(end), name, outcome, "" if force is None else f"{force:g}"]
                for v in (normal, along):
                    cells += ["", "", ""] if v is None else [f"{c:.9g}" for c in v]
                f.write(",".join(cells) + f",\"{text}\"\n")


def main(argv=None):
    """python3 -m rtm.motion FILE [--status-fd N] [--phases CSV] [--input NAME:TYPE[:ELEMENTS:UNITS]]...
    [component options]: the
    script as a component of this process (what `rtm up` can start)."""
    args = list(sys.argv[1:] if argv is None else argv)
    if not args or args[0] in ("-h", "--help"):
        print(main.__doc__)
        print("The component's own options follow FILE (--name, --naming, --period, --on, --param NAME=VALUE, ...).")
        return 0 if args else 2
    path = args.pop(0)
    if not os.path.isfile(path):
        print(f"rtm.motion: {path}: no such script file", file=sys.stderr)
        return 2
    try:
        with open(path, encoding="utf-8") as f:
            compile(f.read(), path, "exec")
    except SyntaxError as e:
        print(f"rtm.motion: {path}:{e.lineno}: {e.msg}", file=sys.stderr)
        return 2
    rest = []
    while args:
        a = args.pop(0)
        if a == "--status-fd" and args:
            ScriptComponent.status_fd = int(args.pop(0))
        elif a == "--phases" and args:
            ScriptComponent.phases_path = args.pop(0)
        elif a == "--input" and args:
            text = args.pop(0)
            name, type_name, elements, units = (text.split(":", 3) + ["", "", ""])[:4]
            if not name.isidentifier() or name in ScriptComponent.inputs or not type_name:
                print(f"rtm.motion: --input {text}: want NAME:TYPE[:ELEMENTS:UNITS], NAME a new identifier "
                      "(not wrench or pose)", file=sys.stderr)
                return 2
            ScriptComponent.inputs = dict(ScriptComponent.inputs)
            ScriptComponent.inputs[name] = rtm.In(type_name, "a port the script watches (rtm script --watch)",
                                                  elements, units)
            ScriptComponent.watched = ScriptComponent.watched + (name,)
        else:
            rest.append(a)
    ScriptComponent.script_path = os.path.abspath(path)
    return rtm._run(ScriptComponent, [sys.argv[0]] + rest)


if __name__ == "__main__":
    # The script imports rtm.motion: run that module's main, not this copy's (__main__), so the
    # script's `arm` is the one this process drives.
    from rtm.motion import main as _main

    sys.exit(_main())
