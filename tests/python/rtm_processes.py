# SPDX-License-Identifier: Apache-2.0
"""Real processes for the Python package's tests and benchmarks: omniNames on a free loopback
port, and component programs bound in it. Whoever starts one stops it (stop())."""

import os
import shutil
import signal
import socket
import subprocess
import tempfile
import time


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def accepts(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        return s.connect_ex(("127.0.0.1", port)) == 0


def wait_for(predicate, timeout=10.0) -> bool:
    """Polls predicate until it holds (True) or timeout seconds passed (False)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.02)
    return predicate()


def stop(process: subprocess.Popen, timeout=5.0):
    if process.poll() is not None:
        return
    process.send_signal(signal.SIGTERM)
    try:
        process.wait(timeout)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()


class NamingService:
    """A fresh omniNames on a free loopback port, its data in a folder of its own."""

    def __init__(self):
        self.log_dir = tempfile.mkdtemp(prefix="rtm-py-names-")
        self.process = None
        for _ in range(20):  # a port just freed may be taken again before omniNames binds it
            port = free_port()
            process = subprocess.Popen(
                ["omniNames", "-start", str(port), "-logdir", self.log_dir, "-ignoreport",
                 "-ORBendPoint", f"giop:tcp:127.0.0.1:{port}"],
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            if wait_for(lambda: process.poll() is not None or accepts(port)) and process.poll() is None:
                self.process, self.address = process, f"127.0.0.1:{port}"
                return
            stop(process)
            for entry in os.listdir(self.log_dir):
                os.remove(os.path.join(self.log_dir, entry))
        shutil.rmtree(self.log_dir, ignore_errors=True)
        raise RuntimeError("omniNames did not come up")

    def stop(self):
        if self.process is not None:
            stop(self.process)
            self.process = None
        shutil.rmtree(self.log_dir, ignore_errors=True)


def start_component(command, name, naming, *args) -> subprocess.Popen:
    """Starts a component (command: a program, or a list such as [python3, script.py]) as NAME
    bound in naming; the caller waits for it and stops it."""
    command = [command] if isinstance(command, str) else list(command)
    return subprocess.Popen([*command, "--name", name, "--naming", naming, *args],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
