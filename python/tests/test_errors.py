"""One error class per failure kind, all under lec6.Error."""

import pytest

import lec6

KINDS = [lec6.TransportError, lec6.ControllerException, lec6.AlarmError, lec6.DeadlineError,
         lec6.InvalidRequest, lec6.Cancelled, lec6.VerifyError]


def test_one_hierarchy():
    for cls in KINDS:
        assert issubclass(cls, lec6.Error) and cls.__module__ == "lec6"
    assert issubclass(lec6.Error, Exception)
    assert issubclass(lec6.InvalidRequest, ValueError)
    assert len(set(KINDS)) == len(KINDS)


def test_transport_error_no_reply(twin_factory):
    with twin_factory(drop_rate=1.0).connect(retries=1) as bus:
        with pytest.raises(lec6.TransportError, match="no reply") as e:
            bus.axis(1).status()
        assert e.value.kind == "timeout"
        assert bus.stats()["timeouts"] == 2


def test_transport_error_no_such_controller(twin):
    with twin.connect(retries=0) as bus:
        with pytest.raises(lec6.TransportError) as e:
            bus.axis(7).status()
    assert e.value.kind == "timeout"


def test_transport_error_port_missing(tmp_path):
    with pytest.raises(lec6.TransportError) as e:
        lec6.connect(str(tmp_path / "ttyUSB9"))
    assert e.value.kind == "port" and "ttyUSB9" in str(e.value)


def test_transport_error_closed_bus(twin):
    bus = twin.connect()
    bus.close()
    with pytest.raises(lec6.TransportError, match="closed"):
        bus.axis(1).status()


def test_controller_exception_parallel_mode(twin):
    with twin.connect() as bus:
        with pytest.raises(lec6.ControllerException) as e:
            bus.axis(1).hold(True)  # Y18 refused in parallel input mode (Y30 = 0)
    assert e.value.code == 2


def test_abs_move_before_homing_is_refused(twin):
    with twin.connect() as bus:
        a = bus.axis(1)
        a.set_serial_mode(True)
        a.servo_on()
        before = a.status()
        with pytest.raises(lec6.InvalidRequest, match=r"needs the axis homed \(SETON = 0\)"):
            a.move(to=10.0)  # ABS before the first return to origin: refused, nothing sent
        after = a.status()
    assert not after.busy and after.position_mm == before.position_mm and not after.alarm


def test_alarm_error_estop(twin):
    with twin.connect() as bus:
        a = bus.axis(1)
        a.set_serial_mode(True)
        twin.set_estop(1, True)
        with pytest.raises(lec6.AlarmError, match="ESTOP"):
            a.servo_on()
        assert a.status().estop


def test_deadline_error(ready):
    with pytest.raises(lec6.DeadlineError, match="deadline"):
        ready.move(to=300.0, speed=20, timeout=0.1)
    ready.stop()


def test_invalid_request(twin):
    with pytest.raises(lec6.InvalidRequest, match="unknown port"):
        lec6.connect("foo")
    with pytest.raises(ValueError, match="baud=12345"):
        lec6.connect("sim", baud=12345)
    with pytest.raises(ValueError, match="1-255"):
        twin.connect().axis(0)
    with twin.connect() as bus:
        with pytest.raises(lec6.InvalidRequest, match="parallel input mode"):
            bus.axis(1).servo_on()  # Y30 = 0: refused before the SVON write


def test_twin_settings_are_checked():
    with pytest.raises(ValueError, match="drop_rate=1.5"):
        lec6.Twin(drop_rate=1.5)
    with pytest.raises(ValueError, match="timing='slow'"):
        lec6.Twin(timing="slow")
    with pytest.raises(ValueError, match="ids: 0"):
        lec6.Twin(ids=[0])
    with pytest.raises(ValueError):
        lec6.Twin(ids=[1, 1])
    with pytest.raises(ValueError, match="stroke"):
        lec6.Twin(stroke_mm=(10.0, 400.0))


def test_cancelled(ready):
    with pytest.raises(lec6.Cancelled):
        ready.move(to=300.0, speed=100, cancel=lambda: True)
