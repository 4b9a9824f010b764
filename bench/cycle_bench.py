#!/usr/bin/python3
"""Machine cycles on the twin (issue 34): for each cycle file, at each baud,
the largest start skew of a parallel group (its members' starts,
acknowledged on the wire), the cycle time against the sum of the axes'
motion times, where the critical path's time went (lec cycle's analysis:
motion, the line, dwells) and how busy the line was.

    bench/cycle_bench.py --lec build/lec examples/cycles/pick-place.yaml examples/cycles/gantry-3-axis.yaml
"""

import argparse
import json
import subprocess
import sys


def run(lec, cycle, baud):
    out = subprocess.run([lec, "--json", "--baud", str(baud), "cycle", "run", cycle, "--port", "sim"],
                         capture_output=True, text=True, check=False)
    if out.returncode != 0:
        sys.exit(f"lec cycle run at {baud} baud: exit {out.returncode}: {out.stderr.strip()}")
    return json.loads(out.stdout)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("cycles", nargs="+")
    ap.add_argument("--lec", default="build/lec")
    ap.add_argument("--bauds", default="38400,115200")
    a = ap.parse_args()
    print("| cycle | baud | axes | start skew max (ms) | cycle time (s) | sum of the axes' motion (s) | "
          "critical path: motion / line / dwells (s) | line busy |")
    print("|---|---|---|---|---|---|---|---|")
    for cycle in a.cycles:
        for baud in [int(b) for b in a.bauds.split(",")]:
            d = run(a.lec, cycle, baud)
            an = d["analysis"]
            skew = an["max_start_skew_s"]
            moving = sum(x["moving_s"] for x in an["axes"])
            busy = ", ".join("not known" if l["utilisation"] is None else f"{100 * l['utilisation']:.0f} %"
                             for l in an["lines"])
            print(f"| {d.get('cycle', cycle.rsplit('/', 1)[-1])} | {baud} | {len(an['axes'])} | "
                  f"{'-' if skew is None else f'{skew * 1000:.1f}'} | {d['cycle_time_s']:.3f} | {moving:.3f} | "
                  f"{an['motion_s']:.3f} / {an['line_s']:.3f} / {an['program_s']:.3f} | {busy} |")


if __name__ == "__main__":
    main()
