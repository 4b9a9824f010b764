"""examples/python run as shipped, on the built-in twin ("sim")."""

import os
import subprocess
import sys

import pytest

EXAMPLES = os.path.join(os.path.dirname(__file__), "..", "..", "examples", "python")

EXPECTED = {
    "example1_step.py": "step 2: reached at 100.00 mm",
    "example2_edit_step.py": "position_mm=150.00",
    "example3_read_position.py": "position 0.00 mm, speed 0 mm/s",
    "example4_direct.py": "move: reached at 300.00 mm",
    "backup_restore.py": "1 step written, 63 unchanged",
    "cycle.py": "cycle 'pick-place': completed in",
}


def test_every_example_is_checked():
    assert sorted(f for f in os.listdir(EXAMPLES) if f.endswith(".py")) == sorted(EXPECTED)


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_example(name, tmp_path):
    r = subprocess.run([sys.executable, os.path.join(EXAMPLES, name), "sim"], cwd=tmp_path,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    assert EXPECTED[name] in r.stdout, r.stdout
