#!/usr/bin/env python3
"""Step table backup and restore, in the files of `lec step backup`.

Backs the controller's 64 steps up to FILE (CSV, or JSON for *.json), changes
step 0, shows the difference, and restores the file: only the steps (and
registers) that differ are written, each read back, to spare the EEPROM.

    backup_restore.py [PORT] [FILE]        (default: sim, steps.csv)
"""
import sys

import lec6

port = sys.argv[1] if len(sys.argv) > 1 else "sim"
path = sys.argv[2] if len(sys.argv) > 2 else "steps.csv"
with lec6.connect(port) as bus:
    axis = bus.axis(1)
    table = axis.backup_steps(path)
    print(f"saved {len(table)} steps of '{table.equipment_name}' to {path}")

    axis.write_step(0, lec6.Step(position_mm=42.0, speed_mm_s=250))
    diff = axis.diff_steps(path)
    print(diff)                               # the side-by-side table of `lec step diff`

    try:
        report = axis.restore_steps(path)     # a file with errors raises lec6.InvalidRequest
    except lec6.Error as e:                   # a failure part-way: e.report says what was written
        print(f"restore failed: {e}")
        sys.exit(1)
    print(report.summary)
    assert axis.diff_steps(path).equal
