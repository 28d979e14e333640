# SPDX-License-Identifier: Apache-2.0
"""rtm script FILE: runs a motion script (rtm/motion.py) as the servo's reference generator.

It starts the script as a component of its own process (python3 -m rtm.motion FILE), with the
controller's gains as its parameters, wires the wrist wrench and the tool's pose into it and its
reference into the servo, turns it on, and waits for the script to end. Then it unwires it and
stops it; the servo, given no more references, brakes. Ctrl-C (or SIGTERM) stops the script
where it is, the same way. The exit status is 0 when the script ran to its end, 1 when it
raised (the error and the line of the script are said), 130 when it was stopped, 2 when it
could not start.
"""

import argparse
import os
import select
import signal
import subprocess
import sys
import time

import rtm

CONTROLLER_PARAMETERS = ("gain", "free_gain", "contact_force", "approach_speed")


def parse(argv):
    p = argparse.ArgumentParser(
        prog="rtm script",
        description="Runs a motion script (docs/python.md, \"Motion scripts\") as the servo's reference "
        "generator, in place of the joystick, until it ends.")
    p.add_argument("file", help="the script: plain Python using rtm.motion's arm")
    p.add_argument("--name", default="script0", help="the script component's name (default script0)")
    p.add_argument("--naming", default=None, help="host:port of the naming service (default $RTM_NAMING)")
    p.add_argument("--tls", default=None, help="TLS folder (rtm tls init), as rtm --tls")
    p.add_argument("--timeout", type=float, default=5.0, help="bound on each remote call, s (default 5)")
    p.add_argument("--reference", default="servo0.reference",
                   help="the InPort the script's reference goes to (default servo0.reference)")
    p.add_argument("--wrench", default="sensor0.wrench", help="the wrist wrench's OutPort (default sensor0.wrench)")
    p.add_argument("--pose", default="actuator0.pose",
                   help="the tool pose's OutPort (default actuator0.pose; \"\" for none: distances become times)")
    p.add_argument("--controller", default="controller0",
                   help="the controller whose gains the script commands through (default controller0)")
    p.add_argument("--watch", action="append", default=[], metavar="NAME=COMPONENT.PORT",
                   help="wire another OutPort into the script, read there as arm.port(NAME) (repeatable)")
    p.add_argument("--phases", default="", help="write each motion's begin and end (CSV) to this file")
    p.add_argument("--log", default="", help="the script component's output to this file (default: this terminal)")
    p.epilog = ("After --, the component's own options: --period, --rt-priority, --cpu, --phase, ... "
                "(rtm script FILE -- --help lists them).")
    argv = list(argv)
    rest = []
    if "--" in argv:
        at = argv.index("--")
        argv, rest = argv[:at], argv[at + 1:]
    args = p.parse_args(argv)
    args.component_options = rest
    return args


def fail(message, status=2):
    print(f"rtm script: {message}", file=sys.stderr)
    return status


def _parameter(description, name):
    """A parameter's value as `rtm cat --json` gives it: a list of its numbers, or None."""
    entry = description.get("parameters", {}).get(name)
    if entry is None:
        return None
    value = entry.get("value")
    return [float(v) for v in str(value).split()] if not isinstance(value, (list, tuple)) else list(value)


def main(argv=None):
    args = parse(sys.argv[1:] if argv is None else argv)
    if not os.path.isfile(args.file):
        return fail(f"{args.file}: no such script file")
    try:
        with open(args.file, encoding="utf-8") as f:
            compile(f.read(), args.file, "exec")
    except SyntaxError as e:
        return fail(f"{args.file}:{e.lineno}: {e.msg}")
    try:
        system = rtm.System(naming=args.naming, tls=args.tls, timeout=args.timeout)
        controller = system.describe(args.controller)
    except rtm.Error as e:
        return fail(f"the controller {args.controller}: {e}")
    params = []
    for name in CONTROLLER_PARAMETERS:
        value = _parameter(controller, name)
        if value is None:
            return fail(f"{args.controller} has no parameter {name}: is it the servo's controller (--controller)?")
        values = value
        if name in ("gain", "free_gain"):
            values = values[:3]
        params += ["--param", f"{name}={' '.join(str(v) for v in values)}"]
    watched = []
    for text in args.watch:
        name, _, address = text.partition("=")
        component, _, port = address.partition(".")
        if not name.isidentifier() or not component or not port:
            return fail(f"--watch '{text}': want NAME=COMPONENT.PORT, NAME an identifier")
        try:
            ports = system.describe(component).get("ports", [])
        except rtm.Error as e:
            return fail(f"--watch {text}: {e}")
        found = [p for p in ports if p.get("name") == port and p.get("direction") == "out"]
        if not found:
            return fail(f"--watch {text}: {component} has no OutPort {port}")
        # The InPort as the OutPort describes its data: type, element names and units.
        elements = found[0].get("elements", [])
        spec = found[0]["type"].split("::")[-1]
        if elements:
            spec += ":" + " ".join(e["name"] for e in elements) + ":" + " ".join(e["unit"] or "-" for e in elements)
        watched.append((name, address, spec))
    if args.name in system.components():
        return fail(f"a component named {args.name} is running already (--name)")

    read_fd, write_fd = os.pipe()
    command = [sys.executable, "-m", "rtm.motion", os.path.abspath(args.file), "--status-fd", str(write_fd),
               "--name", args.name, "--naming", system.naming]
    if args.tls:
        command += ["--tls", os.path.expanduser(args.tls)]
    if args.phases:
        command += ["--phases", os.path.abspath(args.phases)]
    for name, _, type_name in watched:
        command += ["--input", f"{name}:{type_name}"]
    command += params + args.component_options
    args.watched = watched
    log = open(args.log, "w", encoding="utf-8") if args.log else None
    # Its own process group: Ctrl-C reaches this process, which turns the script off in order.
    # PR_SET_PDEATHSIG: were this process killed, the script's runner stops too.
    child = subprocess.Popen(command, pass_fds=(write_fd,), start_new_session=True, stdout=log, stderr=log,
                             preexec_fn=_die_with_parent)
    os.close(write_fd)
    stop = {"signal": None}

    def on_signal(number, _frame):
        stop["signal"] = number

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    wired = []
    status = 2
    try:
        status = _run(args, system, child, read_fd, wired, stop)
    finally:
        for out, in_ in reversed(wired):
            try:
                system.disconnect(out, in_)
            except rtm.Error as e:
                print(f"rtm script: disconnecting {out} -> {in_}: {e}", file=sys.stderr)
        if child.poll() is None:
            child.send_signal(signal.SIGTERM)
            try:
                child.wait(10)
            except subprocess.TimeoutExpired:
                child.kill()
                child.wait()
        os.close(read_fd)
        if log:
            log.close()
    return status


def _die_with_parent():
    try:
        import ctypes
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


def _run(args, system, child, read_fd, wired, stop):
    deadline = time.monotonic() + 10 * args.timeout
    while args.name not in system.components():
        if child.poll() is not None:
            return fail(f"the script component exited with {child.returncode} before it was named")
        if stop["signal"] is not None:
            return 130
        if time.monotonic() > deadline:
            return fail(f"{args.name} was not named within {10 * args.timeout:g} s")
        select.select([read_fd], [], [], 0.05)
    try:
        for out, in_ in ((args.wrench, f"{args.name}.wrench"), (args.pose, f"{args.name}.pose"),
                         *((address, f"{args.name}.{name}") for name, address, _ in args.watched),
                         (f"{args.name}.reference", args.reference)):
            if not out:
                continue
            system.connect(out, in_)
            wired.append((out, in_))
        system.on(args.name)
    except rtm.Error as e:
        return fail(str(e))
    print(f"rtm script: {os.path.basename(args.file)} running as {args.name} "
          f"({args.wrench}{' + ' + args.pose if args.pose else ''} -> {args.reference}); Ctrl-C stops it", flush=True)
    line = b""
    while True:
        if stop["signal"] is not None:
            try:
                system.off(args.name)  # the script stops where it is and says where
            except rtm.Error as e:
                print(f"rtm script: turning {args.name} off: {e}", file=sys.stderr)
            stop["signal"] = None
            stop["off"] = True
        ready, _, _ = select.select([read_fd], [], [], 0.1)
        if ready:
            chunk = os.read(read_fd, 4096)
            line += chunk
            if b"\n" in line or not chunk:
                break
        if child.poll() is not None:
            return fail(f"the script component exited with {child.returncode} before the script ended", 1)
    text = line.decode(errors="replace").strip()
    code, _, outcome = text.partition(" ")
    _print_timing(system, args.name)
    print(f"rtm script: {os.path.basename(args.file)}: {outcome}", file=sys.stderr if code != "0" else sys.stdout,
          flush=True)
    try:
        return int(code)
    except ValueError:
        return 1


def _print_timing(system, name):
    """One line of the script component's loop, as it ran (rtm ls -l's figures)."""
    try:
        d = system.describe(name)
    except rtm.Error:
        return
    t = d.get("timing") or {}
    stats = d.get("statistics", {})
    step50 = stats.get("python.step_p50", {}).get("value")
    step = stats.get("python.step_p99", {}).get("value")
    gil = stats.get("python.gil_wait_p99", {}).get("value")
    if not t:
        return
    print(f"rtm script: {name} ran {t['cycles']} cycles: lateness p99 {t['lateness_p99_ns'] / 1000:.1f} us, max "
          f"{t['lateness_max_ns'] / 1000:.1f} us, {t['overruns']} overruns; step p50 {step50} us, p99 {step} us, "
          f"GIL wait p99 {gil} us", flush=True)


if __name__ == "__main__":
    sys.exit(main())
