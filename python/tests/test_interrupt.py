"""Ctrl-C (SIGINT) during a wait stops the axis, as `lec` does, and raises
KeyboardInterrupt saying so."""

import os
import signal
import subprocess
import sys
import textwrap
import threading

import pytest

import lec6
from conftest import at_rest, wait_for


def sigint_when(predicate):
    """Sends this process SIGINT from another thread once predicate() holds."""
    def run():
        wait_for(predicate, what="the moment to interrupt")
        os.kill(os.getpid(), signal.SIGINT)
    t = threading.Thread(target=run, daemon=True)
    t.start()
    return t


def test_ctrl_c_during_a_move_stops_the_axis(quick_twin, ready):
    t = sigint_when(lambda: quick_twin.carriage_mm(1) > 5.0)
    with pytest.raises(KeyboardInterrupt, match="the axis was stopped"):
        ready.move(to=300.0, speed=200)
    t.join()
    s = wait_for(lambda: at_rest(ready), what="the axis to stop")
    assert 5.0 < s.position_mm < 290.0 and not s.inp
    assert ready.move(to=10.0, speed=500).in_position  # no alarm, operable


def test_ctrl_c_during_a_jog_releases_it(quick_twin, ready):
    t = sigint_when(lambda: quick_twin.carriage_mm(1) > 3.0)
    with pytest.raises(KeyboardInterrupt, match="jog was stopped"):
        ready.jog("+", until=lambda: False)
    t.join()
    s = wait_for(lambda: at_rest(ready), what="the jog to stop")
    assert s.position_mm > 3.0


SCRIPT = textwrap.dedent("""
    import sys, lec6
    told = []

    def progress(status, elapsed):
        if status.position_mm > 5.0 and not told:
            told.append(1)
            print("past 5 mm", flush=True)

    with lec6.connect(sys.argv[1], silence_wait=False) as bus:
        a = bus.axis(1)
        a.set_serial_mode(True)
        a.servo_on()
        a.home()
        try:
            a.move(to=300.0, speed=100, progress=progress)
        except KeyboardInterrupt as e:
            print(f"KeyboardInterrupt: {e}", flush=True)
            sys.exit(130)
    print("not interrupted", flush=True)
""")


def test_sigint_to_a_script_moving_an_axis_on_a_pty_twin(lec_sim):
    proc = subprocess.Popen([sys.executable, "-c", SCRIPT, lec_sim], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline()
        assert line.strip() == "past 5 mm", line + proc.stderr.read()
        proc.send_signal(signal.SIGINT)  # Ctrl-C, as a terminal sends it
        out, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 130, out + err
    assert "KeyboardInterrupt: interrupted: the axis was stopped (decelerating stop)" in out
    with lec6.connect(lec_sim, silence_wait=False) as bus:
        a = bus.axis(1)
        s = wait_for(lambda: at_rest(a), what="the axis to stop")
    assert 5.0 < s.position_mm < 290.0 and not s.inp
