#!/usr/bin/env python3
"""Manual, operation example 2: editing step data (§5).

Sets step No.1's position to 150.00 mm: one write of D0412-D0413 (only the
registers that change are written, then read back).

    example2_edit_step.py [PORT]        (default: sim)
"""
import sys

import lec6

port = sys.argv[1] if len(sys.argv) > 1 else "sim"
with lec6.connect(port) as bus:
    axis = bus.axis(1)
    if axis.read_step(1).is_blank:
        # A blank step needs every field; the manual's example only changes the
        # position of a step that exists. These are §7.3.1's values.
        report = axis.write_step(1, lec6.Step(position_mm=150.0, speed_mm_s=500,
                                              accel_mm_s2=5000, decel_mm_s2=5000,
                                              in_position_mm=1.0))
    else:
        report = axis.write_step(1, position_mm=150.0)
    print(report.summary)
    print(axis.read_step(1))
