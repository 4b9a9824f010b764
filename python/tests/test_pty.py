"""The same operations over a pseudo-terminal: lec6.Twin(pty=True) served from
this process, and `lec sim` in another; RTU over TCP to `lec sim --tcp`."""

import os
import subprocess

import pytest

import lec6


def exercise(axis):
    """Every kind of operation once: reads, servo, home, move, step table, jog, alarm."""
    axis.set_serial_mode(True)
    axis.servo_on()
    assert axis.home().in_position
    r = axis.move(to=20.0, speed=500)
    assert r.in_position and r.position_mm == 20.0
    assert axis.write_step(2, lec6.Step(position_mm=5.0, speed_mm_s=500)).written == [2]
    assert axis.run_step(2).position_mm == 5.0
    assert axis.jog("+", 0.1).position_mm > 5.0
    with pytest.raises(lec6.AlarmError):
        axis.move(to=1000.0)
    axis.reset()
    s = axis.status()
    assert not s.alarm and s.svre and s.seton
    assert axis.backup_steps()[2].position_mm == 5.0


@pytest.mark.parametrize("timing", ["fast", "real"])
def test_pty_twin_in_this_process(twin_factory, timing):
    t = twin_factory(pty=True, timing=timing, initial_position_mm=1.0)
    assert t.port.startswith("/dev/pts/") and os.path.exists(t.port)
    with lec6.connect(t) as bus:  # the pty, with the line settings of the twin
        assert bus.port.startswith(t.port)
        exercise(bus.axis(1))
    port = t.port
    t.close()
    assert not os.path.exists(port)  # the pty is gone


def test_pty_twin_with_a_symlink(twin_factory, tmp_path):
    link = tmp_path / "lec0"
    t = twin_factory(pty=link)
    assert t.port == str(link) and os.path.islink(link)
    with lec6.connect(str(link), silence_wait=False) as bus:
        assert bus.axis(1).name() == "LEC6-TWIN"
    t.close()
    assert not os.path.exists(link)


def test_lec_sim_in_another_process(lec_sim):
    with lec6.connect(lec_sim, silence_wait=False) as bus:
        exercise(bus.axis(1))


def test_rtu_over_tcp_to_lec_sim(lec_binary):
    proc = subprocess.Popen([lec_binary, "sim", "--tcp", "127.0.0.1:0", "--timing", "fast",
                             "--initial-position", "1"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline()
        assert "ready on" in line, line + proc.stderr.read()
        url = next(w for w in line.split() if w.startswith("rtu+tcp://")).rstrip(",")
        with lec6.connect(url, silence_wait=False) as bus:
            exercise(bus.axis(1))
    finally:
        proc.terminate()
        proc.wait(timeout=10)
