"""Reading: status, state, flags, alarms, name; the result objects."""

import lec6


def test_status_at_power_on_is_the_manuals(twin):
    with twin.connect() as bus:
        s = bus.axis(1).status()
    assert (s.busy, s.svre, s.seton, s.inp, s.area, s.warea, s.estop, s.alarm) == (False,) * 8
    assert s.position_mm == 0.0 and s.speed_mm_s == 0 and s.thrust_pct == 0
    assert s.alarms == [] and s.out == 0 and s.step == 0


def test_status_after_homing_has_svre_seton_inp(ready):
    s = ready.status()
    assert (s.svre, s.seton, s.inp, s.busy) == (True, True, True, False)
    assert s.flags.bits == 0x0E00  # the manual's reply after homing: 01 02 02 00 0E
    assert s.state == ready.read_state()
    assert s.flags == ready.read_flags()


def test_status_is_a_value(ready):
    a, b = ready.status(), ready.status()
    assert a == b and hash(a) == hash(b)
    assert {a, b} == {a}
    d = a.to_dict()
    assert d["position_mm"] == 0.0 and d["seton"] is True and d["alarms"] == []
    assert repr(a).startswith("Status(position_mm=0.00, speed_mm_s=0")
    assert "SVRE SETON INP" in repr(a)


def test_position_is_in_mm_with_hundredths(ready):
    ready.move(to=12.34, speed=500)
    s = ready.status()
    assert s.position_mm == 12.34 and s.target_mm == 12.34
    assert repr(ready.read_state()) == (
        "State(position_mm=12.34, speed_mm_s=0, thrust_pct=0, target_mm=12.34, step=0)")


def test_alarm_is_listed_with_its_meaning(ready):
    try:
        ready.move(to=500.0)  # beyond the 400 mm stroke
    except lec6.AlarmError:
        pass
    s = ready.status()
    assert s.alarm and [a.code for a in s.alarms] == [62]
    assert ready.alarms() == s.alarms
    alarm = s.alarms[0]
    assert int(alarm) == 62 and alarm.resettable and "stroke" in alarm.meaning
    history = ready.alarm_history()
    assert len(history) == 16 and [a.code for a in history[0]] == [62]
    ready.reset()
    assert not ready.status().alarm


def test_equipment_name(twin_factory):
    with twin_factory(name="PRESS-3").connect() as bus:
        assert bus.axis(1).name() == "PRESS-3"


def test_bus_counts_transactions(twin):
    with twin.connect() as bus:
        a = bus.axis(1)
        for _ in range(5):
            a.read_state()
        stats = bus.stats()
    assert stats["transactions"] == 5 and stats["retries"] == 0 and stats["timeouts"] == 0
    assert "in-process" in bus.port and bus.closed


def test_connect_sim_is_the_clis_twin():
    with lec6.connect("sim") as bus:
        s = bus.axis(1).status()
    assert not s.svre and not s.alarm


def test_two_controllers_on_one_twin(twin_factory):
    t = twin_factory(ids=[1, 2], initial_position_mm=1.0)
    with lec6.connect(t) as bus:
        one, two = bus.axis(1), bus.axis(2)
        for a in (one, two):
            a.set_serial_mode(True)
            a.servo_on()
        one.home()
        assert one.status().seton and not two.status().seton
        assert repr(two) == "Axis(2 on in-process twin)"


def test_faulty_line_is_retried(twin_factory):
    t = twin_factory(drop_rate=0.2, corrupt_rate=0.1, garbage_rate=0.1, seed=7)
    with t.connect(retries=5) as bus:
        a = bus.axis(1)
        for _ in range(40):
            assert a.status().position_mm == 0.0
        stats = bus.stats()
    assert stats["retries"] > 0 and stats["timeouts"] + stats["crc_errors"] > 0


def test_a_bus_keeps_its_twin_alive():
    import gc

    bus = lec6.Twin(name="KEPT").connect()  # nothing else holds the twin
    gc.collect()
    assert bus.axis(1).name() == "KEPT"
    bus.close()
