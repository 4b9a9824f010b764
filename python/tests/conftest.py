"""Shared fixtures. The suite runs on the module built in the build tree
(PYTHONPATH), where the package is not installed: its pytest plugin is loaded
explicitly here (installed, it is a pytest11 entry point)."""

import os
import shutil
import subprocess
import time

import pytest

import lec6

pytest_plugins = ["lec6.pytest_plugin", "pytester"]


def wait_for(predicate, timeout=10.0, what="condition"):
    """Polls predicate() until it is true; fails after `timeout` s."""
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() > deadline:
            pytest.fail(f"timed out after {timeout} s waiting for {what}")
        time.sleep(0.005)


def at_rest(axis):
    s = axis.status()
    return s if not s.busy and s.speed_mm_s == 0 else None


@pytest.fixture
def quick_twin(twin_factory):
    """A twin whose homing is short (the carriage starts 1 mm from the origin)."""
    return twin_factory(initial_position_mm=1.0)


@pytest.fixture
def ready(quick_twin):
    """Axis 1 of quick_twin, serial mode, servo on, homed."""
    with quick_twin.connect() as bus:
        a = bus.axis(1)
        a.set_serial_mode(True)
        a.servo_on()
        a.home()
        yield a


@pytest.fixture
def lec_binary():
    path = os.environ.get("LEC") or shutil.which("lec")
    if not path:
        pytest.fail("set LEC to the lec binary (ctest does)")
    return path


@pytest.fixture
def lec_sim(lec_binary, tmp_path):
    """`lec sim --pty` in its own process (fast timing); yields the pty path."""
    link = tmp_path / "lec0"
    proc = subprocess.Popen([lec_binary, "sim", "--pty", str(link), "--timing", "fast",
                             "--initial-position", "1"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline()
        assert "ready" in line, line + proc.stderr.read()
        yield str(link)
    finally:
        proc.terminate()
        proc.wait(timeout=10)
