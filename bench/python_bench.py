#!/usr/bin/python3
"""A state read from Python: lec6's Python module against the same read in
C++ (`lec bench`) and in python3-pymodbus, on one fast twin, in one run.

    /usr/bin/python3 bench/python_bench.py [--build DIR] [-n N] [--rounds R] [--json FILE]

Starts one `lec sim --pty --timing fast` (pure software cost, no line timing)
and runs, in interleaved rounds so that load drifting on a shared machine hits
every stack alike, N back-to-back reads per stack and op:

  * C++:      lec --no-silence-wait --json bench --op OP -n N
  * lec6 (Python): axis.read_state() / axis.read_flags() in a loop, the
              module from DIR/python (this file, --worker mode)
  * pymodbus: bench/pymodbus_bench.py (Debian's python3-pymodbus, sync RTU
              client), N / 20 reads (it is ~70x slower)

and prints, per op, the median over rounds of transactions/s and microseconds
per read, and each stack's time per read relative to C++'s (goal for lec6:
at most 1.2x). Each stack is its own process, as a user's program would be.
"""

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PY = "/usr/bin/python3"  # Debian's interpreter: python3-pymodbus, the module's ABI
OPS = ("read-state", "read-flags")
PYMODBUS_DIVISOR = 20


def worker(port, op, n):
    """lec6 from Python: the `lec bench` loop, timed the same way (wall time of N reads)."""
    import lec6

    with lec6.connect(port, silence_wait=False) as bus:
        axis = bus.axis(1)
        read = axis.read_state if op == "read-state" else axis.read_flags
        read()  # warm-up, as lec bench does
        clock = time.perf_counter
        start = clock()
        for _ in range(n):
            read()
        total = clock() - start
        stats = bus.stats()
    print(json.dumps({"stack": f"lec6 {lec6.__version__} (Python)", "op": op, "n": n,
                      "tx_per_s": n / total, "retries": stats["retries"]}))


def run_json(args, env=None):
    """Runs a program that prints one JSON object; adds its CPU time (user + system, wait4)."""
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        proc = subprocess.Popen(args, stdout=out, stderr=err, text=True, env=env)
        _, status, usage = os.wait4(proc.pid, 0)
        code = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        text, errors = out.read(), err.read()
    if code != 0:
        raise SystemExit(f"python_bench: {' '.join(args)} exited {code}:\n{text}\n{errors[-2000:]}")
    result = json.loads(text)
    result["cpu_s"] = usage.ru_utime + usage.ru_stime
    return result


def median(xs):
    xs = sorted(xs)
    n = len(xs)
    return xs[n // 2] if n % 2 else (xs[n // 2 - 1] + xs[n // 2]) / 2


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--build", default=os.environ.get("BUILD", os.path.join(REPO, "build")))
    ap.add_argument("-n", type=int, default=10000, help="reads per stack, op and round")
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--json", help="also write the raw results to this file")
    ap.add_argument("--worker", nargs=3, metavar=("PORT", "OP", "N"), help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.worker:
        worker(a.worker[0], a.worker[1], int(a.worker[2]))
        return 0

    lec = os.path.join(a.build, "lec")
    env = dict(os.environ, PYTHONPATH=os.path.join(a.build, "python"))
    with tempfile.TemporaryDirectory() as tmp:
        port = os.path.join(tmp, "twin")
        sim = subprocess.Popen([lec, "sim", "--pty", port, "--timing", "fast"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            line = sim.stdout.readline()
            if "ready" not in line:
                raise SystemExit(f"python_bench: the twin did not start: {line}{sim.stderr.read()}")
            commands = {
                "C++ (lec bench)": lambda op, n: [lec, "--port", port, "--no-silence-wait", "--json",
                                                  "bench", "--op", op, "-n", str(n or a.n)],
                "lec6 (Python)": lambda op, n: [PY, os.path.abspath(__file__), "--worker", port, op,
                                                str(n or a.n)],
                "pymodbus": lambda op, n: [PY, os.path.join(REPO, "bench", "pymodbus_bench.py"),
                                           port, "38400", op,
                                           str(n or max(200, a.n // PYMODBUS_DIVISOR))],
            }
            runs = {(s, op): [] for s in commands for op in OPS}
            startup = {}  # CPU of a run of one read: start-up, imports, opening the port
            for stack, command in commands.items():
                for op in OPS:
                    startup[(stack, op)] = run_json(command(op, 1), env=env)["cpu_s"]
            for _ in range(a.rounds):
                for op in OPS:
                    for stack, command in commands.items():
                        time.sleep(0.2)  # let the line drain
                        runs[(stack, op)].append(run_json(command(op, None), env=env))
        finally:
            sim.send_signal(signal.SIGTERM)
            sim.wait(timeout=10)

    with open("/proc/loadavg") as f:
        load = " ".join(f.read().split()[:3])
    print(f"One `lec sim --pty --timing fast` twin; {a.rounds} interleaved rounds of {a.n} reads "
          f"(pymodbus {max(200, a.n // PYMODBUS_DIVISOR)}); medians. {os.cpu_count()} CPUs, "
          f"load {load}.")
    print("tx/s: reads / wall time; CPU: the client process's user + system time per read, less")
    print("a one-read run's (start-up); 'vs C++': time per read relative to C++'s.")
    hdr = (f"{'op':10}  {'stack':16} {'tx/s':>9} {'us/read':>8} {'vs C++':>7}  {'CPU us/read':>11} "
           f"{'vs C++':>7}")
    print(hdr)
    print("-" * len(hdr))
    rows = []
    for op in OPS:
        def cpu_us(stack):
            rs = runs[(stack, op)]
            return max(0.0, sum(r["cpu_s"] - startup[(stack, op)] for r in rs)
                       / sum(r["n"] for r in rs) * 1e6)
        cpp = median([r["tx_per_s"] for r in runs[("C++ (lec bench)", op)]])
        cpp_cpu = cpu_us("C++ (lec bench)")
        for stack in commands:
            tx = median([r["tx_per_s"] for r in runs[(stack, op)]])
            cpu = cpu_us(stack)
            rows.append({"op": op, "stack": stack, "tx_per_s": tx, "us_per_read": 1e6 / tx,
                         "time_vs_cpp": cpp / tx, "cpu_us_per_read": cpu,
                         "cpu_vs_cpp": cpu / cpp_cpu if cpp_cpu else None,
                         "rounds": runs[(stack, op)]})
            print(f"{op:10}  {stack:16} {tx:9.0f} {1e6 / tx:8.1f} {cpp / tx:6.2f}x  {cpu:11.1f} "
                  f"{cpu / cpp_cpu if cpp_cpu else float('nan'):6.2f}x")
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"n": a.n, "rounds": a.rounds, "load": load, "rows": rows}, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
