"""Step data: records, tables in the CLI's CSV/JSON formats, and the
controller's step table (read, write, backup, restore, diff)."""

import json
import subprocess

import pytest

import lec6

PUSH = dict(position_mm=25.0, pushing_force_pct=50, trigger_level_pct=40, pushing_speed_mm_s=20,
            in_position_mm=5.0)


def test_step_defaults_and_fields():
    s = lec6.Step(position_mm=150.0, speed_mm_s=500)
    assert (s.mode, s.position_mm, s.speed_mm_s) == ("abs", 150.0, 500)
    assert s.accel_mm_s2 == 1000 and s.in_position_mm == 0.5  # gentle defaults
    assert not s.is_blank and not s.is_pushing and s.validate() == []
    assert lec6.Step.blank().is_blank and lec6.Step.blank().mode == "blank"
    assert s.replace(speed=600).speed_mm_s == 600  # CLI names work too
    assert lec6.Step(**PUSH).is_pushing
    assert s == lec6.Step(position_mm=150, speed_mm_s=500) and hash(s) == hash(s.replace())
    assert s.to_dict()["position_mm"] == 150.0
    assert repr(s).startswith("Step(mode='abs', speed_mm_s=500, position_mm=150.00")


def test_step_values_are_checked():
    with pytest.raises(ValueError, match=r"speed 0 mm/s is out of range: allowed 1 to 65535"):
        lec6.Step(speed_mm_s=0)
    with pytest.raises(lec6.InvalidRequest, match="trigger level 60 % exceeds pushing force 50 %"):
        lec6.Step(**{**PUSH, "trigger_level_pct": 60})
    with pytest.raises(ValueError, match="did you mean 'speed'"):
        lec6.Step(sped=10)


def test_table_round_trips_through_csv_and_json(tmp_path):
    t = lec6.StepTable({0: lec6.Step(position_mm=150.0), 5: lec6.Step(**PUSH)},
                       equipment_name="AXIS-1", controller_id=1)
    assert list(t) == [0, 5] and len(t) == 2 and 5 in t and 1 not in t
    assert t[5].pushing_force_pct == 50
    for name in ("steps.csv", "steps.json"):
        t.save(tmp_path / name)
        assert lec6.StepTable.load(tmp_path / name) == t
    assert lec6.StepTable.parse(t.to_csv()) == t
    assert lec6.StepTable.parse(t.to_json(), format="json") == t
    assert json.loads(t.to_json())["equipment_name"] == "AXIS-1"
    other = lec6.StepTable({0: lec6.Step(position_mm=160.0)})
    d = t.diff(other)
    assert not d.equal and [(x.step, x.field, x.a, x.b) for x in d.differences] == [
        (0, "position_mm", "150.00", "160.00")]


def test_a_bad_file_lists_every_error(tmp_path):
    f = tmp_path / "bad.csv"
    good = lec6.StepTable({0: lec6.Step(), 1: lec6.Step()}).to_csv().splitlines()
    good[-2] = good[-2].replace(",100,", ",70000,", 1)  # step 0's speed
    good[-1] = good[-1].replace("abs", "sideways")
    f.write_text("\n".join(good) + "\n")
    with pytest.raises(lec6.InvalidRequest) as e:
        lec6.StepTable.load(f)
    assert len(e.value.errors) == 2 and "bad.csv: 2 errors" in str(e.value)


def test_read_and_write_steps(ready, quick_twin):
    report = ready.write_step(1, lec6.Step(position_mm=50.0, speed_mm_s=400))
    assert report.ok and report.written == [1] and report.verified
    assert ready.read_step(1).position_mm == 50.0
    # Only the fields given; only what differs is written.
    report = ready.write_step(1, speed_mm_s=600, position_mm=50.0)
    assert report.written == [1] and report.results[0]["fields"] == ["speed_mm_s"]
    assert ready.write_step(1, speed_mm_s=600).unchanged == [1]
    line = quick_twin.connect()
    before = line.stats()["transactions"]
    with pytest.raises(ValueError, match="speed 0"):
        ready.write_step(1, speed_mm_s=0)
    with pytest.raises(ValueError, match="did you mean"):
        ready.write_step(1, sped=5)
    with pytest.raises(ValueError, match="step 64"):
        ready.write_step(64, speed_mm_s=5)
    assert line.stats()["transactions"] == before
    with pytest.raises(ValueError, match="not both"):
        ready.write_step(1, lec6.Step(), speed_mm_s=5)



def test_fields_on_a_blank_step_take_the_defaults(ready):
    # One set of defaults everywhere (issue 27): the CLI's, the API's, a move's.
    ready.write_step(9, position_mm=10.0, speed_mm_s=500)
    s = ready.read_step(9)
    assert (s.position_mm, s.speed_mm_s, s.mode) == (10.0, 500, "abs")
    assert (s.accel_mm_s2, s.moving_force_pct, s.in_position_mm) == (1000, 100, 0.5)


def test_backup_restore_diff(ready, tmp_path):
    ready.write_step(0, lec6.Step(position_mm=10.0))
    ready.write_step(1, lec6.Step(position_mm=20.0))
    backup = ready.backup_steps(tmp_path / "backup.csv")
    assert backup.steps == list(range(64)) and backup.controller_id == 1
    assert backup.equipment_name == "LEC6-TWIN" and backup[1].position_mm == 20.0
    assert lec6.StepTable.load(tmp_path / "backup.csv") == backup
    assert ready.diff_steps(tmp_path / "backup.csv").equal

    ready.write_step(1, position_mm=25.0)
    ready.write_step(2, lec6.Step(position_mm=30.0))
    d = ready.diff_steps(tmp_path / "backup.csv")
    assert not d.equal and d.steps_differing == 2 and len(d) > 1
    assert "controller 1" in str(d) and "backup.csv" in str(d)

    dry = ready.restore_steps(tmp_path / "backup.csv", dry_run=True)
    assert dry.dry_run and dry.planned == [1, 2] and ready.read_step(2).position_mm == 30.0
    report = ready.restore_steps(tmp_path / "backup.csv")
    assert report.ok and report.written == [1, 2] and len(report.unchanged) == 62
    assert report.summary.startswith("2 steps written, 62 unchanged")
    assert ready.read_step(2).is_blank and ready.read_step(1).position_mm == 20.0
    assert ready.restore_steps(backup).written == []  # idempotent: nothing left to write


def test_restore_failure_raises_with_the_report(twin_factory):
    t = twin_factory(initial_position_mm=1.0)
    table = lec6.StepTable({n: lec6.Step(position_mm=n) for n in range(4)})
    asked = []

    def pull_the_plug_after_two_steps():
        asked.append(1)
        if len(asked) == 3:
            t.close()
        return False

    with t.connect(retries=0) as bus:
        with pytest.raises(lec6.TransportError) as e:
            bus.axis(1).restore_steps(table, cancel=pull_the_plug_after_two_steps)
    report = e.value.report
    assert report.written == [0, 1] and report.failed == [2] and report.not_attempted == [3]
    assert "step 2:" in str(e.value) and "written before the failure: 0-1" in str(e.value)


def test_restore_cancelled_between_steps(ready):
    table = lec6.StepTable({n: lec6.Step(position_mm=n) for n in range(6)})
    asked = []
    with pytest.raises(lec6.Cancelled) as e:
        ready.restore_steps(table, cancel=lambda: asked.append(1) or len(asked) > 2)
    report = e.value.report
    assert not report.ok and report.written == [0, 1] and report.not_attempted == [2, 3, 4, 5]


def test_files_of_the_cli_and_of_python_are_the_same(lec_binary, lec_sim, tmp_path):
    port = lec_sim
    cli = lambda *args: subprocess.run([lec_binary, "--port", port, *args],  # noqa: E731
                                       capture_output=True, text=True, timeout=60)
    r = cli("step", "set", "4", "mode=abs", "speed=300", "position=123.45", "accel=2000",
            "decel=2000", "push-speed=20", "in-position=0.5", "moving-force=100")
    assert r.returncode == 0, r.stderr
    assert cli("step", "backup", str(tmp_path / "cli.csv")).returncode == 0
    assert cli("step", "backup", str(tmp_path / "cli.json")).returncode == 0

    with lec6.connect(port) as bus:
        a = bus.axis(1)
        for f in ("cli.csv", "cli.json"):
            t = lec6.StepTable.load(tmp_path / f)
            assert t[4].position_mm == 123.45 and a.diff_steps(t).equal
        a.write_step(4, speed_mm_s=310)
        a.backup_steps(tmp_path / "py.csv")
        a.backup_steps(tmp_path / "py.json")

    for f in ("py.csv", "py.json"):
        r = cli("step", "diff", str(tmp_path / f))
        assert r.returncode == 0, r.stdout + r.stderr
    r = cli("step", "diff", str(tmp_path / "cli.csv"))
    assert r.returncode == 1 and "310" in r.stdout
    assert (tmp_path / "py.csv").read_text().splitlines()[2:] != []
