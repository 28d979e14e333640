#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""rtm serve's `off` under starvation, in one run: the latency of POST /api/components/src/off
(a fresh connection each call, as a page's fetch; the component turned on again between calls,
untimed), first with nothing else open, then while another client keeps 100 event streams (with
the token) and 100 requests sent by halves (without it) open, opening a new one for each the
server refuses, answers or closes, for ATTACK seconds before the calls and during them. p50, p99
and max over CALLS calls, for each rtm given (to compare a build before and after a change); a
call not answered within 30 s is counted as such and, after three of them, the phase stops.

usage: bench/tools/serve_starve.py [build folder (build/default)] [calls (50)] [attack seconds (10)]
                                   [LABEL=RTM ...]  (default: the build's bin/rtm, "this build")
"""
import http.client
import json
import os
import select
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time

from serve_harness import Processes, start_naming_service

build = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else "build/default")
calls = int(sys.argv[2]) if len(sys.argv) > 2 else 50
attack_s = float(sys.argv[3]) if len(sys.argv) > 3 else 10
servers = [a.split("=", 1) for a in sys.argv[4:]] or [["this build", os.path.join(build, "bin", "rtm")]]
talker = os.path.join(build, "tests", "bin", "rtm-test-talker")
STREAMS, HALF_SENT, HANG_S = 100, 100, 30
work = tempfile.mkdtemp(prefix="rtm-serve-starve-")
processes = Processes()


class Starver:
    """Keeps STREAMS event streams and HALF_SENT half-sent requests open against port."""

    def __init__(self, port, token):
        host = f"Host: 127.0.0.1:{port}\r\n"
        self.port = port
        self.stream_request = f"GET /api/events?token={token} HTTP/1.1\r\n{host}\r\n".encode()
        self.half_requests = [f"GET /api/system HTTP/1.1\r\n{host}".encode(),
                              f"POST /api/components/src/on HTTP/1.1\r\n{host}Content-Length: 40\r\n\r\n{{\"val".encode()]
        self.streams = [None] * STREAMS      # [socket, head bytes, admitted]
        self.half_sent = [None] * HALF_SENT  # socket
        self.admitted = self.refused = self.undecided = self.half_open = 0
        self.stop = False
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def connect(self, request):
        s = socket.create_connection(("127.0.0.1", self.port))
        s.sendall(request)
        s.setblocking(False)
        return s

    def look_at_stream(self, i):
        entry = self.streams[i]
        if entry is not None:
            s, head, admitted = entry
            closed = False
            try:
                while True:
                    data = s.recv(65536)
                    if not data:
                        closed = True
                        break
                    if len(head) < 4096:
                        head += data
            except BlockingIOError:
                pass
            except OSError:
                closed = True
            if not admitted and b"\r\n\r\n" in head:
                admitted = head.startswith(b"HTTP/1.1 200")
                if not admitted:
                    self.refused += 1
                    closed = True
            entry = None if closed else [s, head, admitted]
            if closed:
                s.close()
        if entry is None:
            entry = [self.connect(self.stream_request), b"", False]
        self.streams[i] = entry
        if entry[2]:
            self.admitted += 1
        else:
            self.undecided += 1

    def look_at_half_sent(self, i):
        s = self.half_sent[i]
        if s is not None and select.select([s], [], [], 0)[0]:  # answered or closed
            s.close()
            s = None
        if s is None:
            s = self.connect(self.half_requests[i % 2])
        self.half_sent[i] = s
        self.half_open += 1

    def run(self):
        while not self.stop:
            self.admitted = self.undecided = self.half_open = 0
            for i in range(STREAMS):
                self.look_at_stream(i)
            for i in range(HALF_SENT):
                self.look_at_half_sent(i)
            time.sleep(0.1)

    def settle(self):
        deadline = time.time() + 10
        while time.time() < deadline and self.admitted + self.refused < STREAMS:
            time.sleep(0.05)

    def close(self):
        self.stop = True
        self.thread.join()
        for entry in self.streams:
            if entry:
                entry[0].close()
        for s in self.half_sent:
            if s:
                s.close()


def post(port, token, path):
    """Seconds to the answer, or None when none came within HANG_S."""
    started = time.perf_counter()
    c = http.client.HTTPConnection("127.0.0.1", port, timeout=HANG_S)
    try:
        c.request("POST", path, body="{}", headers={"X-RTM-Token": token, "Content-Type": "application/json"})
        r = c.getresponse()
        r.read()
        if r.status != 200:
            raise RuntimeError(f"{path}: {r.status}")
        return time.perf_counter() - started
    except (socket.timeout, TimeoutError):
        return None
    finally:
        c.close()


def offs(port, token):
    """The off calls' latencies (s); None for each not answered."""
    out = []
    for _ in range(calls):
        post(port, token, "/api/components/src/on")
        out.append(post(port, token, "/api/components/src/off"))
        if out.count(None) >= 3:
            break
    return out


def figures(latencies):
    answered = sorted(x * 1000 for x in latencies if x is not None)
    missing = sum(1 for x in latencies if x is None)
    if not answered:
        return f"none answered within {HANG_S} s ({missing} tried)"
    p99 = answered[min(len(answered) - 1, round(0.99 * (len(answered) - 1)))]
    text = f"p50 {statistics.median(answered):.1f} ms, p99 {p99:.1f} ms, max {answered[-1]:.1f} ms ({len(answered)} calls)"
    return text + (f"; {missing} not answered within {HANG_S} s" if missing else "")


try:
    naming = start_naming_service(processes, work)
    processes.start([talker, "--name", "src", "--naming", naming, "--on"])
    time.sleep(1.0)
    rows = []
    for label, rtm in servers:
        serve = processes.start([rtm, "--naming", naming, "serve"])
        url = serve.stdout.readline().strip()
        port, token = int(url.split(":")[2].split("/")[0]), url.split("#token=")[1]
        idle = offs(port, token)
        starver = Starver(port, token)
        starver.settle()
        time.sleep(attack_s)
        loaded = offs(port, token)
        state = (starver.admitted, starver.refused, starver.half_open)
        starver.close()
        processes.stop([serve])
        rows.append((label, figures(idle), figures(loaded), state))
    print(f"`off` latency, {calls} calls each (a fresh connection each, as a page's fetch):\n")
    print("| rtm serve | nothing open | 100 event streams + 100 half-sent requests open | streams let in / refused, half-sent open |")
    print("| --- | --- | --- | --- |")
    for label, idle, loaded, (admitted, refused, half_open) in rows:
        print(f"| {label} | {idle} | {loaded} | {admitted} / {refused}, {half_open} |")
finally:
    processes.stop()
    shutil.rmtree(work, ignore_errors=True)
