"""ALARM polarity (issue 33): a controller that reports X4F inverted, played
by `lec sim --profile` with alarm_polarity: active-low. Told so
(connect(..., alarm_polarity=) or bus.axis(id, alarm_polarity=)), the Python
API reports no alarm when there is none and the alarm when there is one;
told nothing, the same controller reads as an alarm at rest."""

import subprocess

import pytest

import lec6


@pytest.fixture
def inverted_sim(lec_binary, tmp_path):
    """`lec sim --pty` whose controller reports ALARM active-low."""
    profile = tmp_path / "active-low.yaml"
    profile.write_text("actuator:\n  alarm_polarity: active-low\n")
    link = tmp_path / "lec0"
    proc = subprocess.Popen([lec_binary, "sim", "--pty", str(link), "--timing", "fast",
                             "--initial-position", "1", "--profile", str(profile)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline()
        assert "ready" in line, line + proc.stderr.read()
        yield str(link)
    finally:
        proc.terminate()
        proc.wait(timeout=10)


def test_inverted_controller_with_its_polarity(inverted_sim):
    with lec6.connect(inverted_sim, alarm_polarity="active-low") as bus:
        assert bus.alarm_polarity == "active-low"
        ax = bus.axis(1)
        assert ax.alarm_polarity == "active-low"
        assert not ax.read_flags().alarm
        s = ax.status()
        assert not s.alarm and s.alarms == [] and ax.alarms() == []
        # The waits read X4F the same way: serial, servo, home and a move work.
        ax.set_serial_mode(True)
        ax.servo_on()
        ax.home()
        assert ax.move(to=50.0).outcome == "reached"
        with pytest.raises(lec6.AlarmError):
            ax.move(to=500.0)  # beyond the 400 mm stroke: alarm 62
        s = ax.status()
        assert s.alarm and [a.code for a in s.alarms] == [62]
        assert [a.code for a in ax.alarms()] == [62]
        ax.reset()
        assert not ax.status().alarm and ax.alarms() == []


def test_inverted_controller_unconfigured_reads_as_alarm(inverted_sim):
    # What the setting fixes: without it the healthy controller shows ALARM.
    with lec6.connect(inverted_sim) as bus:
        assert bus.axis(1).alarm_polarity == "active-high"
        assert bus.axis(1).read_flags().alarm
        # Per axis over the bus's setting.
        assert not bus.axis(1, alarm_polarity="active-low").read_flags().alarm


def test_a_bad_polarity_is_refused(inverted_sim):
    with pytest.raises(lec6.InvalidRequest, match="active-high .* or active-low"):
        lec6.connect(inverted_sim, alarm_polarity="inverted")
    with lec6.connect(inverted_sim) as bus:
        with pytest.raises(lec6.InvalidRequest, match="alarm_polarity='low'"):
            bus.axis(1, alarm_polarity="low")
