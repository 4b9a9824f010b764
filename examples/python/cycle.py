#!/usr/bin/env python3
"""The pick-and-place cycle of examples/cycles/pick-place.yaml, run from Python:
the same file, checks and runner as `lec cycle run` (docs/cycles.md).

Both axes are put in serial mode, servo on and homed first (what
`lec cycle run --prepare` does), then the cycle runs; each step is printed as
it ends, then where the cycle's time went. Ctrl-C stops every axis.

    cycle.py [PORT]      (default: sim: a twin of IDs 1 and 2 in this process,
                          a part under z at 78 mm; real time, about 14 s)
"""
import os
import sys

import lec6

here = os.path.dirname(os.path.abspath(__file__))
cycle = lec6.Cycle(os.path.join(here, "..", "cycles", "pick-place.yaml"))

port = sys.argv[1] if len(sys.argv) > 1 else "sim"
twin = None
if port == "sim":
    twin = lec6.Twin(ids=[1, 2])
    twin.set_workpiece(2, 78.0)  # the part z presses into its nest
with twin.connect() if twin else lec6.connect(port) as bus:
    for name, where in cycle.axes.items():
        axis = bus.axis(where["id"])
        axis.set_serial_mode(True)
        axis.servo_on()
        axis.home()

    def show(step):
        print(f"step {step.path:<8} {step.text:<50} {step.end_s - step.start_s:6.3f} s  {step.decision}")

    report = cycle.run(bus, on_step=show)

split = report.time_split
print(f"cycle '{cycle.name}': {'completed' if report.completed else report.ended} "
      f"in {report.cycle_time_s:.3f} s (motion {split['motion']:.3f} s, the line {split['line']:.3f} s, "
      f"dwells and waits {split['program']:.3f} s)")
sys.exit(0 if report.completed else 1)
