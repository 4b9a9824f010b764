"""lec6.Cycle: a cycle file read, checked and run from Python on the in-process
twin, with the same rules as `lec cycle run` (docs/cycles.md): a bad file is
refused before anything moves, every step's outcome is in the report, and a
stop (cancel, an error in on_step) stops every axis of the cycle."""

import os
import time

import pytest

import lec6

CELL = """\
cycle: cell
axes:
  x: {id: 1, soft_limits: [0, 400], points: {pick: 20, place: 60}}
  z: {id: 2, soft_limits: [0, 120], points: {up: 5, nest: 70}}
interlocks:
  - {before_moving: x, axis: z, below_mm: 45}
steps:
  - parallel:
      - move: {axis: x, to: pick, speed: 500}
      - move: {axis: z, to: up, speed: 500}
  - push: {axis: z, to: nest, force: 50, trigger: 40, push_speed: 20, distance: 15,
           on_miss: no_part}
  - move: {axis: z, to: up, speed: 500}
  - move: {axis: x, to: place, speed: 500}
branches:
  no_part:
    - move: {axis: z, to: up, speed: 500}
"""


def prepared(twin):
    """A bus to the twin, both axes in serial mode, servo on, homed."""
    bus = twin.connect()
    for i in (1, 2):
        a = bus.axis(i)
        a.set_serial_mode(True)
        a.servo_on()
        a.home()
    return bus


@pytest.fixture
def cell_twin(twin_factory):
    twin = twin_factory(ids=[1, 2], initial_position_mm=1.0)
    twin.set_workpiece(2, 78.0)  # under z only: x passes 78 mm
    return twin


def test_a_cycle_runs_and_reports_each_step(cell_twin):
    cycle = lec6.Cycle.from_yaml(CELL, "cell.yaml")
    assert cycle.name == "cell" and cycle.axes == {"x": {"line": "", "id": 1},
                                                   "z": {"line": "", "id": 2}}
    seen = []
    with prepared(cell_twin) as bus:
        report = cycle.run(bus, on_step=lambda s: seen.append(s.path))
        x_end = cell_twin.carriage_mm(1)
    assert report.completed and report.ended == "completed", report
    assert [s.path for s in report.steps] == ["1", "2", "3", "4"] == seen
    group = report.steps[0]
    assert sorted(span.axis for span in group.axes) == ["x", "z"]
    assert all(span.outcome == "reached" for span in group.axes)
    push = report.steps[1].axes[0]
    assert push.axis == "z" and push.outcome == "pushed" and push.position_mm == pytest.approx(78.0, abs=0.5)
    assert report.steps[3].axes[0].position_mm == pytest.approx(60.0, abs=0.5)
    assert x_end == pytest.approx(60.0, abs=0.5)
    # The critical path tiles the cycle time.
    split = report.time_split
    assert sum(split.values()) == pytest.approx(report.cycle_time_s, abs=1e-6)
    assert split["motion"] > 0 and split["line"] > 0
    assert report.max_start_skew_s is not None and report.max_start_skew_s >= 0
    assert report.stood == []


def test_a_missed_push_takes_its_branch(twin_factory):
    twin = twin_factory(ids=[1, 2], initial_position_mm=1.0)  # no workpiece
    with prepared(twin) as bus:
        report = lec6.Cycle.from_yaml(CELL, "cell.yaml").run(bus)
    assert report.completed, report
    push = next(s for s in report.steps if s.path == "2")
    assert push.axes[0].outcome == "push_missed" and push.decision == "branch no_part"
    assert "no_part.1" in [s.path for s in report.steps]


def test_a_bad_file_is_refused_with_where_and_which_rule(tmp_path, cell_twin):
    bad = CELL.replace("move: {axis: x, to: place", "move: {axis: y, to: place")
    path = tmp_path / "cell.yaml"
    path.write_text(bad)
    with pytest.raises(lec6.CycleError) as e:
        lec6.Cycle(str(path))
    err = e.value
    assert isinstance(err, ValueError) and isinstance(err, lec6.InvalidRequest)
    assert err.file == str(path) and err.line == 14 and err.column > 0
    assert "axis" in err.field and "unknown axis 'y'" in err.rule, (err.field, err.rule)
    assert f"{path}:14:" in str(err)
    with pytest.raises(lec6.CycleError, match="cannot read the file: No such file or directory"):
        lec6.Cycle(os.fspath(tmp_path / "missing.yaml"))


def test_a_target_outside_the_soft_limits_is_refused_before_anything_moves(cell_twin):
    bad = CELL.replace("place: 60", "place: 600")
    with pytest.raises(lec6.CycleError, match="soft"):
        lec6.Cycle.from_yaml(bad, "cell.yaml")


def test_a_broken_interlock_refuses_the_cycle_and_nothing_moves(cell_twin):
    with prepared(cell_twin) as bus:
        bus.axis(2).move(to=60.0, speed=500)  # z down: x may not move
        report = lec6.Cycle.from_yaml(CELL, "cell.yaml").run(bus)
        x = cell_twin.carriage_mm(1)
    assert not report.completed and "interlock" in report.ended, report.ended
    assert x == pytest.approx(0.0, abs=0.01)


def test_cancel_stops_every_axis_of_the_cycle(cell_twin):
    slow = CELL.replace("speed: 500}\n      - move: {axis: z, to: up, speed: 500}",
                        "speed: 20}\n      - move: {axis: z, to: up, speed: 5}")
    t0 = time.monotonic()
    with prepared(cell_twin) as bus:
        report = lec6.Cycle.from_yaml(slow, "cell.yaml").run(
            bus, cancel=lambda: time.monotonic() - t0 > 0.4)
        # Both at rest where they stood: neither moves on.
        x, z = cell_twin.carriage_mm(1), cell_twin.carriage_mm(2)
        time.sleep(0.3)
        assert cell_twin.carriage_mm(1) == pytest.approx(x, abs=0.01)
        assert cell_twin.carriage_mm(2) == pytest.approx(z, abs=0.01)
    assert not report.completed and "stopped" in report.ended, report.ended
    assert 0 < x < 20 and 0 < z < 5, (x, z)  # stopped on the way, not at the targets
    assert sorted(s.axis for s in report.stood) == ["x", "z"]
    assert all(s.stopped and s.position_mm is not None for s in report.stood), report.stood
    assert report.steps[-1].decision == "stopped"


def test_an_error_in_on_step_stops_the_cycle_and_is_raised(cell_twin):
    def fail(step):
        if step.path == "2":
            raise RuntimeError("the vision check failed")

    with prepared(cell_twin) as bus:
        with pytest.raises(RuntimeError, match="vision"):
            lec6.Cycle.from_yaml(CELL, "cell.yaml").run(bus, on_step=fail)
        x = cell_twin.carriage_mm(1)
    assert x == pytest.approx(20.0, abs=0.5)  # step 4 (x to place) never ran


def test_buses_by_line_name_every_axis_or_nothing_runs(cell_twin):
    lined = CELL.replace("x: {id: 1,", "x: {line: /dev/ttyUSB0, id: 1,").replace(
        "z: {id: 2,", "z: {line: /dev/ttyUSB0, id: 2,")
    cycle = lec6.Cycle.from_yaml(lined, "cell.yaml")
    assert cycle.axes["x"] == {"line": "/dev/ttyUSB0", "id": 1}
    with prepared(cell_twin) as bus:
        with pytest.raises(lec6.InvalidRequest, match="axis 'x' is on line '/dev/ttyUSB0'"):
            cycle.run({"/dev/ttyUSB1": bus})
        with pytest.raises(lec6.InvalidRequest, match="expected a lec6.Bus"):
            cycle.run("sim")
        assert cell_twin.carriage_mm(1) == pytest.approx(0.0, abs=0.01)  # nothing ran
        assert cycle.run({"/dev/ttyUSB0": bus}).completed


def test_ctrl_c_during_a_cycle_stops_every_axis_and_says_so(cell_twin):
    import os
    import signal
    import threading

    slow = CELL.replace("speed: 500}\n      - move: {axis: z, to: up, speed: 500}",
                        "speed: 20}\n      - move: {axis: z, to: up, speed: 5}")

    def interrupt():
        deadline = time.monotonic() + 10
        while cell_twin.carriage_mm(1) < 3.0 and time.monotonic() < deadline:
            time.sleep(0.005)
        os.kill(os.getpid(), signal.SIGINT)

    with prepared(cell_twin) as bus:
        t = threading.Thread(target=interrupt, daemon=True)
        t.start()
        with pytest.raises(KeyboardInterrupt, match="every axis of the cycle was stopped"):
            lec6.Cycle.from_yaml(slow, "cell.yaml").run(bus)
        t.join()
        x, z = cell_twin.carriage_mm(1), cell_twin.carriage_mm(2)
        time.sleep(0.3)
        assert cell_twin.carriage_mm(1) == pytest.approx(x, abs=0.01)
        assert cell_twin.carriage_mm(2) == pytest.approx(z, abs=0.01)
        assert 3.0 <= x < 20 and 0 < z < 5, (x, z)
        # Operable after: no alarm, the next move goes.
        assert bus.axis(1).move(to=10.0, speed=500).in_position


def test_two_axes_that_would_be_one_controller_are_refused_before_anything_moves(cell_twin):
    two_lines = CELL.replace("z: {id: 2,", "z: {line: /dev/ttyUSB1, id: 1,")
    cycle = lec6.Cycle.from_yaml(two_lines, "cell.yaml")
    with prepared(cell_twin) as bus:
        with pytest.raises(lec6.InvalidRequest, match="'x' and 'z' would be one controller: ID 1"):
            cycle.run(bus)
        with pytest.raises(lec6.InvalidRequest, match="would be one controller"):
            cycle.run({"": bus, "/dev/ttyUSB1": bus})
        assert cell_twin.carriage_mm(1) == pytest.approx(0.0, abs=0.01)


def test_a_cancel_during_a_dwell_ends_the_cycle_at_once(cell_twin):
    dwelling = CELL.replace("  - push: {axis: z", "  - dwell: 4s\n  - push: {axis: z")
    ended = []  # when step 1 ended: the 4 s dwell begins
    with prepared(cell_twin) as bus:
        report = lec6.Cycle.from_yaml(dwelling, "cell.yaml").run(
            bus, on_step=lambda s: ended.append(time.monotonic()),
            cancel=lambda: bool(ended) and time.monotonic() - ended[0] > 0.3)
        took = time.monotonic() - ended[0]
    assert not report.completed and "stopped" in report.ended, report.ended
    assert report.steps[-1].text.startswith("dwell"), report.steps[-1]
    assert took < 2.0, f"the 4 s dwell held the cancel: {took:.2f} s"


def test_a_cancel_whose_answer_has_no_truth_value_stops_the_cycle(cell_twin):
    class NoTruth:
        def __bool__(self):
            raise ValueError("the truth value is ambiguous")

    slow = CELL.replace("speed: 500}\n      - move: {axis: z, to: up, speed: 500}",
                        "speed: 20}\n      - move: {axis: z, to: up, speed: 5}")
    with prepared(cell_twin) as bus:
        t0 = time.monotonic()
        with pytest.raises((ValueError, TypeError)):
            lec6.Cycle.from_yaml(slow, "cell.yaml").run(
                bus, cancel=lambda: NoTruth() if time.monotonic() - t0 > 0.3 else False)
        x = cell_twin.carriage_mm(1)
        time.sleep(0.3)
        assert cell_twin.carriage_mm(1) == pytest.approx(x, abs=0.01), "x went on moving"
        assert x < 20


def test_a_cycle_file_given_as_a_path_object(tmp_path):
    path = tmp_path / "cell.yaml"
    path.write_text(CELL)
    assert lec6.Cycle(path).name == "cell"
