#!/usr/bin/env python3
"""Manual, operation example 3: reading position and speed data (§6).

D9000-D9006 in one read: position (0.01 mm in the registers, mm here), speed,
thrust, target, step No.; status() adds the flags and active alarms.

    example3_read_position.py [PORT]        (default: sim)
"""
import sys

import lec6

port = sys.argv[1] if len(sys.argv) > 1 else "sim"
with lec6.connect(port) as bus:
    axis = bus.axis(1)
    state = axis.read_state()
    print(f"position {state.position_mm:.2f} mm, speed {state.speed_mm_s} mm/s, "
          f"thrust {state.thrust_pct} %")
    print(axis.status())
