#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""N components as N processes beside the same N as members of one rtm-container: the memory
they take (PSS, each shared page counted once across the processes that map it; and RSS) and
the time from the first fork until every name is bound. Rounds alternate the two ways, on one
private naming service (omniNames on a free loopback port).

    bench/tools/container_bench.py [build folder (build/default)] [components (4)] [rounds (5)]

The components are rtm-controller (no bus needed), off, one second after the last is bound.
"""
import os
import shutil
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time

build = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else "build/default")
count = int(sys.argv[2]) if len(sys.argv) > 2 else 4
rounds = int(sys.argv[3]) if len(sys.argv) > 3 else 5
bin_dir = os.path.join(build, "bin")


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def memory_kb(pid):
    """(PSS, RSS) of a process in kB, from smaps_rollup."""
    pss = rss = 0
    with open(f"/proc/{pid}/smaps_rollup") as f:
        for line in f:
            if line.startswith("Pss:"):
                pss = int(line.split()[1])
            elif line.startswith("Rss:"):
                rss = int(line.split()[1])
    return pss, rss


def bound(naming, names):
    out = subprocess.run([os.path.join(bin_dir, "rtm"), "--naming", naming, "ls"], capture_output=True, text=True).stdout
    return all(f"  {n} " in out for n in names)


def run(naming, as_container, tag):
    names = [f"{tag}{k}" for k in range(count)]
    devnull = subprocess.DEVNULL
    start = time.monotonic()
    if as_container:
        argv = [os.path.join(bin_dir, "rtm-container"), "--name", tag, "--naming", naming]
        for n in names:
            argv += ["--", n, os.path.join(bin_dir, "rtm-controller")]
        procs = [subprocess.Popen(argv, stdout=devnull, stderr=devnull)]
    else:
        procs = [subprocess.Popen([os.path.join(bin_dir, "rtm-controller"), "--name", n, "--naming", naming],
                                  stdout=devnull, stderr=devnull) for n in names]
    while not bound(naming, names):
        if time.monotonic() - start > 30:
            raise SystemExit("components did not come up")
        time.sleep(0.005)
    up_s = time.monotonic() - start
    time.sleep(1.0)
    pss = rss = 0
    for p in procs:
        a, b = memory_kb(p.pid)
        pss += a
        rss += b
    for p in procs:
        p.send_signal(signal.SIGTERM)
    for p in procs:
        p.wait(timeout=10)
    return up_s, pss, rss


def main():
    work = tempfile.mkdtemp()
    port = free_port()
    names = subprocess.Popen(["omniNames", "-start", str(port), "-datadir", work, "-logdir", work, "-ignoreport",
                              "-ORBendPoint", f"giop:tcp:127.0.0.1:{port}"],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    naming = f"127.0.0.1:{port}"
    try:
        time.sleep(0.5)
        results = {False: [], True: []}
        for r in range(rounds):
            for as_container in (False, True):
                results[as_container].append(run(naming, as_container, f"r{r}{'c' if as_container else 'p'}"))
        print(f"{count} rtm-controller components, {rounds} rounds, load {os.getloadavg()[0]:.1f}")
        print(f"{'as':<24} {'up p50 [ms]':>12} {'PSS [MB]':>10} {'RSS [MB]':>10}")
        for as_container, label in ((False, f"{count} processes"), (True, "1 rtm-container")):
            rows = results[as_container]
            print(f"{label:<24} {statistics.median(r[0] for r in rows) * 1e3:12.1f} "
                  f"{statistics.median(r[1] for r in rows) / 1024:10.2f} {statistics.median(r[2] for r in rows) / 1024:10.2f}")
        p, c = results[False], results[True]
        print(f"container / processes: up {statistics.median(x[0] for x in c) / statistics.median(x[0] for x in p):.2f}x, "
              f"PSS {statistics.median(x[1] for x in c) / statistics.median(x[1] for x in p):.2f}x")
    finally:
        names.terminate()
        names.wait()
        shutil.rmtree(work, ignore_errors=True)


main()
