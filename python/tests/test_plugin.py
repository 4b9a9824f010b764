"""The pytest plugin users get: fixtures twin, twin_factory, bus, axis and the
lec6_twin marker, in a test file of their own."""

USER_TESTS = '''
import pytest
import lec6

def test_axis_is_ready(axis):
    s = axis.status()
    assert s.svre and s.seton and not s.busy

def test_bus_and_twin(twin, bus):
    assert twin.ids == [1] and twin.timing == "fast" and bus.axis(1).name() == "LEC6-TWIN"

@pytest.mark.lec6_twin(ids=[3, 4], workpiece_mm=30.0, initial_position_mm=1.0)
def test_marker_sets_the_twin(twin, axis):
    assert twin.ids == [3, 4] and axis.id == 3
    r = axis.move(to=25.0, speed=500, push=50, push_speed=20, in_position=10.0)
    assert r.in_position

def test_factory(twin_factory):
    t = twin_factory(ids=[9])
    assert t.connect().axis(9).status().position_mm == 0.0

def test_failing_on_purpose(axis):
    assert axis.status().position_mm == 123.0
'''


def test_plugin_fixtures_in_a_users_suite(pytester):
    pytester.makeconftest('pytest_plugins = ["lec6.pytest_plugin"]\n')
    pytester.makepyfile(test_user=USER_TESTS)
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider")
    result.assert_outcomes(passed=4, failed=1)
    result.stdout.fnmatch_lines(["*test_failing_on_purpose*"])
