"""pytest fixtures for scripts that drive LEC6 controllers: a twin per test.

Installed with the package as a pytest plugin (entry point `pytest11`), so the
fixtures are there in any test once lec6 is installed; without installing,
enable it in a conftest.py::

    pytest_plugins = ["lec6.pytest_plugin"]

Fixtures:
  twin          an in-process lec6.Twin (ID 1, fast timing), closed after the test
  twin_factory  make_twin(**Twin options) -> lec6.Twin, each closed after the test
  bus           twin.connect()
  axis          bus.axis(first ID) in serial mode, servo on and homed: ready to move

Tests can choose the twin's options with a marker::

    @pytest.mark.lec6_twin(ids=[1, 2], workpiece_mm=350)
    def test_push(axis): ...
"""

import pytest

import lec6


def pytest_configure(config):
    config.addinivalue_line(
        "markers", "lec6_twin(**options): options of the `twin` fixture's lec6.Twin")


@pytest.fixture
def twin_factory():
    made = []

    def make_twin(**options):
        options.setdefault("timing", "fast")
        t = lec6.Twin(**options)
        made.append(t)
        return t

    yield make_twin
    for t in made:
        t.close()


@pytest.fixture
def twin(request, twin_factory):
    marker = request.node.get_closest_marker("lec6_twin")
    return twin_factory(**(marker.kwargs if marker else {}))


@pytest.fixture
def bus(twin):
    with twin.connect() as b:
        yield b


@pytest.fixture
def axis(twin, bus):
    a = bus.axis(twin.ids[0])
    a.set_serial_mode(True)
    a.servo_on()
    a.home()
    return a
