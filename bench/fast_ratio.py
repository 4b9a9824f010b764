#!/usr/bin/python3
"""lec6 against libmodbus in fast mode, as one ratio with its spread.

  bench/fast_ratio.py [--build DIR] [--lec PATH ...] [--libmodbus PATH] [--baud 230400] [-n 300]
                      [--reply-spin 150us]
                      [--rounds 9] [--rt PRIO]

One `lec sim --pty --timing fast` twin; each round runs every stack once, in
turn (lec6 with --no-silence-wait --reply-spin 150us, then Debian's libmodbus through
lec6_libmodbus_bench; the order alternates from round to round), N reads of
D9000 x7 each, and takes the ratio lec6 tx/s / libmodbus tx/s of that round.
Prints every round and the median ratio (BENCHMARKS.md, "Fast mode"). The
pty round trip in the kernel dominates both stacks, and a shared machine moves
it by +-20 % from run to run: only the median of many alternating rounds
says anything. With several --lec binaries (e.g. before and after a change)
each gets its own ratio against the same libmodbus runs.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


RT = []  # ["chrt", "-f", PRIO] with --rt


def run(args):
    r = subprocess.run([*RT, *args], capture_output=True, text=True, timeout=600)
    if r.returncode != 0:
        sys.exit(f"fast_ratio: {' '.join(args)} failed: {r.stderr.strip()}")
    return json.loads(r.stdout)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.environ.get("BUILD", "build"))
    ap.add_argument("--lec", action="append", help="lec binaries to measure (default: BUILD/lec)")
    ap.add_argument("--libmodbus", help="the libmodbus program (default: BUILD/lec6_libmodbus_bench)")
    ap.add_argument("--baud", type=int, default=230400)
    ap.add_argument("--reply-spin", default="150us",
                    help="lec's --reply-spin (client::kFastReplySpin); 0 for none, 'none' for a lec "
                         "older than the option")
    ap.add_argument("-n", type=int, default=300)
    ap.add_argument("--rounds", type=int, default=9)
    ap.add_argument("--json", help="also write the raw rounds to this file")
    ap.add_argument("--rt", type=int, help="run the twin and the clients SCHED_FIFO at this priority (chrt -f; "
                    "needs CAP_SYS_NICE): other work on a shared machine then cannot sit between the two "
                    "processes of a transaction")
    a = ap.parse_args()
    if a.rt:
        RT.extend(["chrt", "-f", str(a.rt)])
    build = a.build if os.path.isabs(a.build) else os.path.join(REPO, a.build)
    lecs = a.lec or [os.path.join(build, "lec")]
    libmodbus = a.libmodbus or os.path.join(build, "lec6_libmodbus_bench")
    with tempfile.TemporaryDirectory() as tmp:
        pty = os.path.join(tmp, "twin")
        twin = subprocess.Popen([*RT, lecs[0], "sim", "--pty", pty, "--timing", "fast", "--baud", str(a.baud),
                                 "--ids", "1"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            if "ready" not in twin.stdout.readline():
                sys.exit(f"fast_ratio: the twin did not start: {twin.stderr.read()}")

            def lec6(path):
                spin = [] if a.reply_spin == "none" else ["--reply-spin", a.reply_spin]
                return run([path, "--port", pty, "--baud", str(a.baud), "--no-silence-wait", *spin,
                            "--json", "bench", "--op", "read-state", "-n", str(a.n)])["tx_per_s"]

            def lm():
                return run([libmodbus, pty, str(a.baud), "read-state", str(a.n)])["tx_per_s"]

            rounds = []
            for i in range(a.rounds):
                stacks = [("libmodbus", lm)] + [(p, (lambda p=p: lec6(p))) for p in lecs]
                if i % 2:
                    stacks.reverse()
                got = {}
                for name, f in stacks:
                    time.sleep(0.1)
                    got[name] = f()
                rounds.append(got)
                print(f"round {i + 1}: libmodbus {got['libmodbus']:.0f} tx/s; "
                      + "; ".join(f"{os.path.relpath(p, REPO) if p.startswith(REPO) else p} {got[p]:.0f} tx/s "
                                  f"({got[p] / got['libmodbus']:.2f}x)" for p in lecs), flush=True)
        finally:
            twin.terminate()
            twin.wait(timeout=10)
    print(f"{a.rounds} alternating rounds of {a.n} reads of D9000 x7, fast twin at {a.baud} baud, "
          f"load {open('/proc/loadavg').read().split()[0]}{', SCHED_FIFO ' + str(a.rt) if a.rt else ''}:")
    for p in lecs:
        ratios = sorted(r[p] / r["libmodbus"] for r in rounds)
        print(f"  {p}: median {statistics.median(ratios):.2f}x libmodbus "
              f"(rounds {', '.join(f'{x:.2f}' for x in ratios)})")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rounds, f, indent=1)


if __name__ == "__main__":
    main()
