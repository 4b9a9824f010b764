#!/usr/bin/python3
"""Machine cycles on the twin (issue 34): for a cycle file, at each baud,
the start skew of every parallel group (its members' starts, acknowledged on
the wire), the cycle time, and the motion time it holds (per step, its
longest member's start-to-end): what the line and the steps between cost.

    bench/cycle_bench.py --lec build/lec examples/cycles/pick-place.yaml
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
    ap.add_argument("cycle")
    ap.add_argument("--lec", default="build/lec")
    ap.add_argument("--bauds", default="38400,115200")
    a = ap.parse_args()
    print("| baud | groups | start skew max (ms) | cycle time (s) | motion (s) | rest (s) |")
    print("|---|---|---|---|---|---|")
    for baud in [int(b) for b in a.bauds.split(",")]:
        d = run(a.lec, a.cycle, baud)
        skews, motion = [], 0.0
        for s in d["steps"]:
            moving = [x for x in s.get("axes", []) if x["what"].split()[0] in ("move", "push")]
            if len(moving) > 1:
                starts = [x["start_s"] for x in moving]
                skews.append((max(starts) - min(starts)) * 1000)
            spans = [x["end_s"] - x["start_s"] for x in s.get("axes", [])]
            motion += max(spans, default=0.0)
        print(f"| {baud} | {len(skews)} | {max(skews, default=0):.1f} | {d['cycle_time_s']:.3f} | "
              f"{motion:.3f} | {d['cycle_time_s'] - motion:.3f} |")


if __name__ == "__main__":
    main()
