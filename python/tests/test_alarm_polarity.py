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


def test_a_reset_that_leaves_an_old_code_names_the_polarity(inverted_sim, lec_binary):
    # The case the cross-check cannot judge from one read: a healthy inverted
    # controller whose alarm history still holds a code that RESET cleared
    # (62, after a move beyond the stroke). Read active-high it shows ALARM
    # with code 62 - and a RESET "leaves" it: that RESET clears 62 is the clue.
    with lec6.connect(inverted_sim, alarm_polarity="active-low") as bus:
        ax = bus.axis(1)
        ax.set_serial_mode(True)
        ax.servo_on()
        ax.home()
        with pytest.raises(lec6.AlarmError):
            ax.move(to=500.0)
        ax.reset()
        assert not ax.status().alarm
    with lec6.connect(inverted_sim) as bus:
        ax = bus.axis(1)
        assert [a.code for a in ax.status().alarms] == [62]
        with pytest.raises(lec6.AlarmError, match="set `alarm_polarity: active-low`") as e:
            ax.reset()
        assert e.value.codes == [62] and "RESET clears this code" in str(e.value)
    out = subprocess.run([lec_binary, "--port", inverted_sim, "reset"], capture_output=True,
                         text=True, timeout=30)
    assert out.returncode != 0 and "set `alarm_polarity: active-low`" in out.stderr, out.stderr
    # Told the polarity, the same RESET finds nothing active.
    out = subprocess.run([lec_binary, "--port", inverted_sim, "--alarm-polarity", "active-low",
                          "reset"], capture_output=True, text=True, timeout=30)
    assert out.returncode == 0, out.stderr
