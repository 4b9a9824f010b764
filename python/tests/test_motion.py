"""Every operation of the manual on the in-process twin."""

import time

import pytest

import lec6
from conftest import at_rest, wait_for


def test_servo_on_and_off(quick_twin):
    with quick_twin.connect() as bus:
        a = bus.axis(1)
        a.set_serial_mode(True)
        a.servo_on(timeout=2.0)
        assert a.status().svre
        a.servo_off()
        assert not a.status().svre


def test_home_returns_to_origin(quick_twin):
    with quick_twin.connect() as bus:
        a = bus.axis(1)
        a.set_serial_mode(True)
        a.servo_on()
        seen = []
        r = a.home(progress=lambda s, t: seen.append((s.busy, t)))
    assert r.operation == "home" and r.in_position and r.outcome == "reached"
    assert r.position_mm == 0.0 and r.status.seton
    assert any(busy for busy, _ in seen) and seen[-1][1] <= r.elapsed_s


def test_move_absolute_reaches_target(ready):
    r = ready.move(to=150.0, speed=1000, accel=5000, decel=5000)
    assert r.in_position and r.outcome == "reached" and r.position_mm == 150.0
    assert not r.status.busy and r.status.inp and r.elapsed_s > 0
    assert "outcome='reached'" in repr(r)


def test_in_position_zero_is_accepted(ready):
    # Issue 24: real controllers accept in position 0; INP exactly at the target.
    r = ready.move(to=12.0, speed=16, in_position=0)
    assert r.in_position and r.outcome == "reached" and r.position_mm == 12.0


def test_move_relative_adds_to_last_target(ready):
    ready.move(to=20.0, speed=1000)
    r = ready.move(to=-5.5, relative=True, speed=1000)
    assert r.position_mm == 14.5 and r.status.target_mm == 14.5


def test_pushing_move_stops_on_the_workpiece(twin_factory):
    t = twin_factory(initial_position_mm=1.0, workpiece_mm=30.0)
    with t.connect() as bus:
        a = bus.axis(1)
        a.set_serial_mode(True)
        a.servo_on()
        a.home()
        r = a.move(to=25.0, speed=500, push=50, trigger=40, push_speed=20, in_position=10.0)
    assert r.in_position and abs(r.position_mm - 30.0) < 0.05
    assert r.status.thrust_pct == 50


def test_pushing_move_that_misses_is_not_in_position(ready):
    r = ready.move(to=25.0, speed=500, push=50, push_speed=50, in_position=2.0)
    assert not r.in_position and r.outcome == "push_missed" and not r.succeeded


def test_move_without_waiting_returns_at_the_start(ready):
    r = ready.move(to=100.0, speed=200, wait=False)
    # BUSY may not have risen yet (the default twin's, like a real LECP6's,
    # rises ~20 ms after the start): the outcome says the move runs.
    assert r.outcome == "running" and r.status.target_mm == 100.0
    # "At rest" alone would be true before BUSY rises: wait for the target.
    s = wait_for(lambda: (s := at_rest(ready)) and s.position_mm == 100.0 and s,
                 what="the move to end at 100 mm")
    assert s.inp


def test_wait_judges_a_move_started_without_waiting(ready):
    started = ready.move(to=100.0, speed=200, wait=False)
    r = ready.wait(started)
    # Judged by the completion rule, not by "at rest" (which the default
    # twin's late BUSY makes true right after the start).
    assert r.operation == "move" and r.outcome == "reached" and r.succeeded
    assert r.position_mm == 100.0 and r.status.inp and not r.status.busy
    assert ready.wait(r) is not None and ready.wait(r).position_mm == 100.0  # already ended


def test_wait_after_the_move_ended_unseen_still_says_reached(ready):
    started = ready.move(to=60.0, speed=500, wait=False)
    wait_for(lambda: (s := at_rest(ready)) and s.position_mm == 60.0 and s, what="the move")
    r = ready.wait(started)
    assert r.outcome == "reached" and r.position_mm == 60.0


def test_a_wait_that_times_out_leaves_the_move_to_a_second_wait(ready):
    started = ready.move(to=400.0, speed=100, wait=False)
    with pytest.raises(lec6.DeadlineError) as e:
        ready.wait(started, timeout=0.3)
    # As move(timeout=...): the deadline ends the wait, not the move.
    assert e.value.result.position_mm < 390 and e.value.result.status.busy
    r = ready.wait(started)
    assert r.outcome == "reached" and r.position_mm == 400.0


def test_a_cancelled_wait_stops_the_axis(ready):
    started = ready.move(to=400.0, speed=100, wait=False)
    with pytest.raises(lec6.Cancelled, match="stopped"):
        ready.wait(started, cancel=lambda: ready.status().position_mm > 20)
    s = wait_for(lambda: at_rest(ready), what="the stop")
    assert 20 < s.position_mm < 390 and not s.inp


def test_wait_after_a_stop_says_stopped_and_sends_nothing_more(ready):
    started = ready.move(to=300.0, speed=100, wait=False)
    wait_for(lambda: ready.status().position_mm > 10, what="motion")
    ready.stop()
    r = ready.wait(started)  # the run ended unseen, short of its target
    assert r.outcome == "stopped" and not r.succeeded and 10 < r.position_mm < 290


def test_a_move_of_a_closed_bus_is_refused(twin_factory):
    twin = twin_factory(initial_position_mm=1.0)
    bus = twin.connect()
    a = bus.axis(1)
    a.set_serial_mode(True)
    a.servo_on()
    a.home()
    started = a.move(to=50.0, wait=False)
    bus.close()
    del a, bus
    import gc
    gc.collect()
    # Another bus (another twin's), maybe at the freed one's address.
    with twin_factory(initial_position_mm=1.0).connect() as bus2:
        with pytest.raises(lec6.InvalidRequest, match="bus this move was started on is closed"):
            bus2.axis(1).wait(started)


def test_wait_on_another_axis_is_refused_with_its_id(twin_factory):
    twin = twin_factory(ids=[1, 2], initial_position_mm=1.0)
    bus = twin.connect()
    a1, a2 = bus.axis(1), bus.axis(2)
    for a in (a1, a2):
        a.set_serial_mode(True)
        a.servo_on()
        a.home()
    started = a1.move(to=20.0, wait=False)
    with pytest.raises(lec6.InvalidRequest, match="started on axis 1"):
        a2.wait(started)
    with pytest.raises(ValueError, match="timeout"):
        a1.wait(started, timeout=0)
    assert a1.wait(started).position_mm == 20.0


def test_run_step(ready):
    ready.write_step(3, lec6.Step(position_mm=40.0, speed_mm_s=800))
    r = ready.run_step(3)
    assert r.operation == "step 3" and r.in_position and r.position_mm == 40.0
    assert r.status.step == 3 and r.status.out == 3


def test_jog_for_a_time_and_until(ready):
    r = ready.jog("+", 0.2)
    assert r.position_mm > 2.0 and not r.status.busy
    before = r.position_mm
    polls = []
    end = time.monotonic() + 0.2
    r = ready.jog("-", until=lambda: time.monotonic() > end, progress=lambda s, t: polls.append(s))
    assert r.position_mm < before and r.status.speed_mm_s == 0
    assert any(s.busy for s in polls)


def test_hold_suspends_and_resumes(ready):
    ready.move(to=200.0, speed=200, wait=False)
    wait_for(lambda: ready.status().position_mm > 5, what="motion")
    ready.hold(True)
    held = wait_for(lambda: (lambda s: s if s.speed_mm_s == 0 else None)(ready.status()),
                    what="the hold")
    assert held.busy and held.position_mm < 150  # suspended, not finished
    ready.hold(False)
    s = wait_for(lambda: at_rest(ready), what="the resumed move")
    assert s.position_mm == 200.0 and s.inp


def test_stop_decelerates_and_cancels(ready):
    ready.move(to=300.0, speed=200, wait=False)
    wait_for(lambda: ready.status().position_mm > 5, what="motion")
    ready.stop()
    s = wait_for(lambda: at_rest(ready), what="the stop")
    assert s.position_mm < 290 and not s.inp


def test_reset_clears_an_alarm(ready):
    with pytest.raises(lec6.AlarmError) as e:
        ready.move(to=500.0)
    assert e.value.codes == [62]
    ready.reset()
    assert not ready.status().alarm
    assert ready.move(to=10.0).in_position  # operable again


def test_cancel_callback_stops_the_axis(ready):
    polls = []
    with pytest.raises(lec6.Cancelled, match="stopped"):
        ready.move(to=300.0, speed=200, cancel=lambda: len(polls) > 50,
                   progress=lambda s, t: polls.append(s.position_mm))
    s = wait_for(lambda: at_rest(ready), what="the stop")
    assert s.position_mm < 290


def test_an_error_in_progress_stops_the_axis_and_is_raised(ready):
    def progress(status, elapsed):
        if status.position_mm > 3:
            raise RuntimeError("seen enough")

    with pytest.raises(RuntimeError, match="seen enough"):
        ready.move(to=300.0, speed=200, progress=progress)
    s = wait_for(lambda: at_rest(ready), what="the stop")
    assert s.position_mm < 290


def test_values_are_checked_before_anything_is_sent(ready, quick_twin):
    line = quick_twin.connect()  # the same line as ready's: the same counters
    before = line.stats()["transactions"]
    with pytest.raises(ValueError, match=r"speed 70000 mm/s is out of range: allowed 1 to 65535"):
        ready.move(to=10.0, speed=70000)
    with pytest.raises(lec6.InvalidRequest, match=r"^to: position: .*10\.005.*decimals"):
        ready.move(to=10.005)
    with pytest.raises(ValueError, match=r"^push 101 % is out of range: allowed 0 to 100 %$"):
        ready.move(to=10.0, push=101)
    with pytest.raises(ValueError, match="trigger and push_speed belong to a pushing move"):
        ready.move(to=10.0, trigger=20)
    with pytest.raises(ValueError, match="area"):
        ready.move(to=10.0, area=(1.0,))
    with pytest.raises(ValueError, match="timeout"):
        ready.move(to=10.0, timeout=-1)
    with pytest.raises(TypeError, match="speed: expected a number"):
        ready.move(to=10.0, speed=[1])
    with pytest.raises(ValueError, match="direction"):
        ready.jog("up", 1.0)
    with pytest.raises(ValueError, match="step 64"):
        ready.run_step(64)
    assert line.stats()["transactions"] == before


def test_float_positions_mean_hundredths(ready):
    # 0.1 + 0.2 is 0.30000000000000004: within a hair of 0.30 mm, so 0.30 mm.
    assert ready.move(to=0.1 + 0.2, speed=1000).position_mm == 0.3
