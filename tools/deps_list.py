"""Reads tools/deps.txt, the one list of the Debian packages lec6 needs.

Shared by tools/check-deps and tools/lec6_preflight.py (tools/install-deps.sh
reads the same format in bash). Format: see the head of tools/deps.txt.
"""

import re
from dataclasses import dataclass, field
from pathlib import Path

DEFAULT_LIST = Path(__file__).resolve().parent / "deps.txt"
_ANNOTATION = re.compile(r"\[(py|bin|file):\s*([^\]\s]+)\s*\]")
_NAME = re.compile(r"^[a-z0-9][a-z0-9+.-]+(:[a-z0-9-]+)?$")


@dataclass
class Entry:
    alternatives: list  # package names, in order of preference
    reason: str
    line: int
    modules: list = field(default_factory=list)  # [py: NAME]
    programs: list = field(default_factory=list)  # [bin: NAME]
    files: list = field(default_factory=list)  # [file: GLOB]: data a test reads (wheels, ...)

    def __str__(self):
        return " | ".join(self.alternatives)


def _annotate(entry, reason):
    for kind, name in _ANNOTATION.findall(reason):
        {"py": entry.modules, "bin": entry.programs, "file": entry.files}[kind].append(name)


def read_list(path=DEFAULT_LIST):
    """The entries of the list; raises ValueError on a line that is not one."""
    entries = []
    for number, raw in enumerate(Path(path).read_text().splitlines(), 1):
        text, _, reason = raw.partition("#")
        names = [n.strip() for n in text.split("|")]
        if not text.strip():
            if raw[:1].isspace() and reason and entries:  # an indented comment goes on
                entries[-1].reason += " " + reason.strip()
                _annotate(entries[-1], reason)
            continue
        if not all(_NAME.match(n) for n in names):
            raise ValueError(f"{path}:{number}: not a package or `a | b`: {raw.strip()!r}")
        entry = Entry(names, reason.strip(), number)
        _annotate(entry, reason)
        entries.append(entry)
    return entries


def package_for(kind, name, path=DEFAULT_LIST):
    """The entry annotated `[kind: name]` (or for a module, its top-level
    package), or None."""
    try:
        entries = read_list(path)
    except (OSError, ValueError):
        return None
    for entry in entries:
        names = entry.modules if kind == "py" else entry.programs
        if name in names or (kind == "py" and name.split(".")[0] in names):
            return entry
    return None
