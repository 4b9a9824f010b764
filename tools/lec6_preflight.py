#!/usr/bin/python3
"""Pre-flight for the tests: are the Python modules and programs a test needs
on this machine? When one is not, say which Debian package brings it (from the
`[py: …]`/`[bin: …]` notes of tools/deps.txt) and the command that installs it,
and exit 1, instead of a bare traceback halfway through the test.

    /usr/bin/python3 tools/lec6_preflight.py [--module M]... [--program P]...

From Python (before importing what it checks):

    sys.path.insert(0, ".../tools"); import lec6_preflight
    lec6_preflight.require(modules=["pymodbus.client"])

From the test scripts: `need --module M --program P` (tests/integration/harness.sh).
"""

import argparse
import importlib
import os
import shutil
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import deps_list  # noqa: E402

DEBIAN_PATH = "/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin"


def missing(modules=(), programs=()):
    """[(kind, name, why)] for each module that does not import and each program not found."""
    out = []
    for m in modules:
        try:
            importlib.import_module(m)
        except ImportError as e:
            name = getattr(e, "name", None) or m
            if name not in (n for _, n, _ in out):
                out.append(("py", name, f"`import {m}`: {type(e).__name__}: {e}"))
    for p in programs:
        found = os.access(p, os.X_OK) if os.path.isabs(p) else shutil.which(p, path=DEBIAN_PATH)
        if not found:
            out.append(("bin", p, "not found on the PATH"))
    return out


def message(items):
    lines, packages = ["lec6 pre-flight: this test needs what this machine does not have:"], []
    for kind, name, why in items:
        what = f"{'Python module' if kind == 'py' else 'program'} {name}"
        entry = deps_list.package_for(kind, name)
        if entry:
            packages.append(entry.alternatives[0])
            lines.append(f"  {what} ({why}): Debian package {entry}")
        else:
            lines.append(f"  {what} ({why}): no entry of tools/deps.txt names it; find its package "
                         f"(`dpkg -S` on a machine that has it) and add it there")
    if packages:
        unique = " ".join(dict.fromkeys(packages))
        lines.append(f"Install it with:  sudo apt-get install -y --no-install-recommends {unique}")
        lines.append("(or `make deps`, which installs everything in tools/deps.txt)")
    return "\n".join(lines)


def require(modules=(), programs=()):
    """Returns when everything is there; otherwise prints what to install and exits 1."""
    items = missing(modules, programs)
    if items:
        print(message(items), file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--module", action="append", default=[], help="a Python module to import")
    ap.add_argument("--program", action="append", default=[], help="a program to find")
    args = ap.parse_args()
    require(args.module, args.program)
