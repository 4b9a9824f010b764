#!/usr/bin/env python3
"""Manual, operation example 4: direct instruction of position and speed (§7).

Serial mode, servo on, return to origin, then direct operation to 300.00 mm
with §7.3.1's data (D9102-D9111, then D9100 = 0100h). Completion is BUSY
falling; success is INP = 1 after it.

    example4_direct.py [PORT]        (default: sim)
"""
import sys

import lec6

port = sys.argv[1] if len(sys.argv) > 1 else "sim"
with lec6.connect(port) as bus:
    axis = bus.axis(1)
    axis.set_serial_mode(True)                                   # 7.1.1
    axis.servo_on()                                              # 7.1.2-3
    axis.home()                                                  # 7.2
    result = axis.move(to=300.0, speed=500, accel=5000, decel=5000,   # 7.3.1 (1)-(5)
                       push=0, push_speed=20, moving_force=100,        # (6)-(9)
                       area=(0.0, 0.0), in_position=1.0,               # (10)-(12)
                       progress=lambda s, t: print(f"\r{s.position_mm:7.2f} mm", end=""))
    print(f"\rmove: {result.outcome} at {result.position_mm:.2f} mm in {result.elapsed_s:.2f} s")
    sys.exit(0 if result.in_position else 1)
