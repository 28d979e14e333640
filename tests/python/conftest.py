# SPDX-License-Identifier: Apache-2.0
"""Fixtures for the Python package's tests: a real omniNames on a free loopback port, and real
component processes (rtm-test-talker) bound in it. Everything a test starts, the fixture stops.

The build tree gives (ctest sets them): PYTHONPATH=<build>/python, RTM_BIN_DIR (the programs),
RTM_TEST_BIN_DIR (the test programs)."""

import os

import pytest

import rtm
from rtm_processes import NamingService, free_port, start_component, stop, wait_for  # noqa: F401

BIN_DIR = os.environ.get("RTM_BIN_DIR", "")
TEST_BIN_DIR = os.environ.get("RTM_TEST_BIN_DIR", "")


def until(predicate, timeout=10.0, what="the condition"):
    """Polls predicate until it holds; fails the test naming what did not come."""
    if not wait_for(predicate, timeout):
        pytest.fail(f"{what} did not come within {timeout} s")


@pytest.fixture
def naming():
    """A fresh omniNames on a free loopback port: its address, "127.0.0.1:PORT"."""
    service = NamingService()
    try:
        yield service.address
    finally:
        service.stop()


@pytest.fixture
def system(naming):
    return rtm.System(naming=naming)


@pytest.fixture
def components(naming, system):
    """start(name, *args): starts rtm-test-talker (or command=[...]) as NAME and returns once it
    is bound; every process started is stopped at the end of the test."""
    started = []

    def start(name, *args, command=None):
        process = start_component(command or os.path.join(TEST_BIN_DIR, "rtm-test-talker"), name, naming, *args)
        started.append(process)
        until(lambda: name in system.components() or process.poll() is not None, what=f"{name} bound")
        if process.poll() is not None:
            pytest.fail(f"{name} exited with {process.returncode}: {process.stderr.read()}")
        return process

    yield start
    for process in reversed(started):
        stop(process)
