#!/usr/bin/python3
"""lec doctor benchmark (BENCHMARKS.md, "lec doctor"): the time to a full report on a
clean line with one controller (ID 1), the twin in real timing and --strict-baud (it
answers only at its own rate):

  1. the controller at 38400 (lec's default: found at the first rate tried); goal < 15 s;
  2. the controller at 9600 (the doctor first tries 38400, then 9600); goal < 30 s;
  3. the controller at 230400 (the last rate tried: every rate searched); goal < 30 s;
  4. a dead line (a twin that drops every reply: every rate searched, nothing found).

Each `lec --port PTY doctor` runs with no other option (IDs 1-32), N times; median and max.

Usage: bench/doctor_bench.py BUILD_DIR [--runs N]
"""
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time

BUILD = sys.argv[1] if len(sys.argv) > 1 else "build"
RUNS = int(sys.argv[sys.argv.index("--runs") + 1]) if "--runs" in sys.argv else 3
LEC = os.path.join(BUILD, "lec")


def twin(pty, *args):
    p = subprocess.Popen([LEC, "sim", "--pty", pty, "--ids", "1", "--strict-baud", *args],
                         stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    line = p.stdout.readline()
    if not line.startswith("lec sim: ready on"):
        p.kill()
        raise RuntimeError(f"twin did not start: {line!r}")
    return p


def case(name, goal_s, *twin_args):
    with tempfile.TemporaryDirectory() as tmp:
        pty = os.path.join(tmp, "pty")
        t = twin(pty, *twin_args)
        try:
            times, health = [], ""
            for _ in range(RUNS):
                t0 = time.monotonic()
                out = subprocess.run([LEC, "--port", pty, "doctor"], capture_output=True,
                                     text=True, timeout=120)
                times.append(time.monotonic() - t0)
                m = re.search(r"^(healthy|degraded|broken) \(", out.stdout, re.M)
                health = m.group(1) if m else "?"
        finally:
            t.terminate()
            t.wait(10)
    med, mx = statistics.median(times), max(times)
    goal = f"< {goal_s} s: **{'met' if mx < goal_s else 'NOT met'}**"
    print(f"| {name} | {health} | {med:.1f} s | {mx:.1f} s | {goal} |")


print(f"| line | report | median of {RUNS} | max | goal |")
print("|---|---|---|---|---|")
case("ID 1 at 38400", 15, "--baud", "38400")
case("ID 1 at 9600", 30, "--baud", "9600")
case("ID 1 at 230400 (every rate searched)", 30, "--baud", "230400")
case("dead line (every rate, nothing)", 30, "--drop-rate", "1")
