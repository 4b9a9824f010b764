"""lec6.Twin's profile (issue 33): the default twin follows the field's
evidence, 'ideal' is the manual's controller, a profile file (lec sim
--profile's, e.g. from --calibrate) is read over the default, and a keyword
given replaces the profile's value."""

import pytest

import lec6


def started(twin):
    with twin.connect() as bus:
        a = bus.axis(1)
        a.set_serial_mode(True)
        a.servo_on()
        a.home()
        return a.move(to=100.0, speed=200, wait=False)


def test_the_default_twin_raises_busy_late_and_the_ideal_at_once():
    with lec6.Twin(initial_position_mm=1.0) as t:
        assert t.profile == "default" and "profile='default'" in repr(t)
        r = started(t)
        assert r.outcome == "running" and not r.status.busy  # BUSY 20 ms late
    with lec6.Twin(initial_position_mm=1.0, profile="ideal") as t:
        assert t.profile == "ideal"
        r = started(t)
        assert r.outcome == "running" and r.status.busy


def test_a_profile_file_is_read_over_the_default(tmp_path):
    f = tmp_path / "bench.yaml"
    f.write_text("name: bench\nactuator:\n  busy_delay_ms: 0\n  max_speed_mm_s: 300\n")
    with lec6.Twin(initial_position_mm=1.0, profile=f) as t:
        assert t.profile == "bench"
        r = started(t)
        assert r.status.busy  # the file's busy_delay_ms: 0
    # A keyword given wins over the file's value.
    with lec6.Twin(initial_position_mm=1.0, profile=str(f), max_speed_mm_s=900) as t:
        with t.connect() as bus:
            a = bus.axis(1)
            a.set_serial_mode(True)
            a.servo_on()
            a.home()
            r = a.move(to=300.0, speed=800)
            assert r.in_position and r.position_mm == 300.0


def test_a_bad_profile_names_the_file_and_the_rule(tmp_path):
    f = tmp_path / "bad.yaml"
    f.write_text("actuator:\n  busy_delay_ms: -5\n")
    with pytest.raises(lec6.InvalidRequest) as e:
        lec6.Twin(profile=f)
    assert "bad.yaml" in str(e.value) and "busy_delay_ms" in str(e.value)
    with pytest.raises(lec6.InvalidRequest) as e:
        lec6.Twin(profile=tmp_path / "missing.yaml")
    assert "missing.yaml" in str(e.value) and "'default', 'ideal'" in str(e.value)
