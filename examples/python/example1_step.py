#!/usr/bin/env python3
"""Manual, operation example 1: running with specified step data (§4).

Serial mode (Y30), servo on (Y19, wait SVRE), return to origin (Y1C, wait
SETON), then select step No.2 on IN0-IN5 and DRIVE it; completion is BUSY
falling, success INP = 1.

    example1_step.py [PORT]        PORT: /dev/ttyUSB0, tcp://host:502, ... (default: sim)
"""
import sys

import lec6

port = sys.argv[1] if len(sys.argv) > 1 else "sim"
with lec6.connect(port, baud=38400) as bus:
    axis = bus.axis(1)
    axis.set_serial_mode(True)                 # 4.1.1  Y30 = 1
    axis.servo_on(timeout=5)                   # 4.1.2-3  Y19 = 1, wait X49 SVRE
    axis.home(timeout=60)                      # 4.2  Y1C = 1, wait X4A SETON, Y1C = 0
    if axis.read_step(2).is_blank:             # the twin (or a new controller) has no step 2
        axis.write_step(2, lec6.Step(position_mm=100.0, speed_mm_s=500, accel_mm_s2=5000,
                                     decel_mm_s2=5000, in_position_mm=1.0))
    result = axis.run_step(2, timeout=60)      # 4.3-4.4  IN0-IN5 = 2, DRIVE, BUSY falls, DRIVE = 0
    print(f"step 2: {result.outcome} at {result.position_mm:.2f} mm in {result.elapsed_s:.2f} s")
    sys.exit(0 if result.in_position else 1)
