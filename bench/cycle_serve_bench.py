#!/usr/bin/python3
"""A machine cycle on a real-timing twin behind a pseudo-terminal (issue 34,
BENCHMARKS.md "Machine cycles"): run straight on the port, then through
`lec serve` (Modbus TCP, unit id = controller ID), then through it while a
SCADA client (mbpoll) reads every axis's state back to back. For each: the
cycle time, the largest start skew of a parallel group, and the critical
path's motion and line shares (lec cycle's analysis). Every run is
`lec cycle run FILE --prepare` on a twin switched on for it.

    bench/cycle_serve_bench.py --lec build/lec examples/cycles/pick-place.yaml [--baud 38400]

The twin has no workpiece: a cycle's pushes miss and take their branches, the
same in every mode.
"""
import argparse
import json
import os
import re
import subprocess
import tempfile
import threading
import time


def start(cmd, ready, timeout=20.0):
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = p.stdout.readline()
        if not line:
            break
        if re.search(ready, line):
            threading.Thread(target=p.stdout.read, daemon=True).start()
            return p, line
    p.kill()
    raise SystemExit(f"{cmd[1]} did not get ready")


def run_cycle(lec, cycle, port, baud):
    out = subprocess.run([lec, "--json", "--baud", str(baud), "cycle", "run", cycle, "--port", port, "--prepare"],
                         capture_output=True, text=True, check=False)
    if out.returncode not in (0, 1):
        raise SystemExit(f"lec cycle run on {port}: exit {out.returncode}: {out.stderr.strip()}")
    return json.loads(out.stdout)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("cycle")
    ap.add_argument("--lec", default="build/lec")
    ap.add_argument("--baud", type=int, default=38400)
    a = ap.parse_args()
    with open(a.cycle) as f:
        ids = sorted({int(m) for m in re.findall(r"\bid: (\d+)", f.read())})
    idlist = ",".join(map(str, ids))
    print(f"| mode | baud | cycle time (s) | start skew max (ms) | critical path: motion / line (s) | completed |")
    print("|---|---|---|---|---|---|")
    for mode in ("direct", "through lec serve", "through lec serve + SCADA polling"):
        with tempfile.TemporaryDirectory() as tmp:
            pty = os.path.join(tmp, "line")
            twin, _ = start([a.lec, "sim", "--pty", pty, "--ids", idlist, "--baud", str(a.baud)], "ready")
            procs = [twin]
            try:
                port = pty
                if mode != "direct":
                    serve, line = start([a.lec, "serve", "--port", pty, "--baud", str(a.baud), "--ids", idlist,
                                         "--modbus-tcp", "127.0.0.1:0", "--http", ""], "ready on")
                    procs.append(serve)
                    port = re.search(r"tcp://127\.0\.0\.1:\d+", line).group(0)
                if mode.endswith("polling"):
                    tcp_port = port.rsplit(":", 1)[1]
                    scada = subprocess.Popen(
                        ["bash", "-c", f"while :; do mbpoll -m tcp -a {ids[0]}:{ids[-1]} -p {tcp_port} -t 4 "
                                       f"-r 36864 -c 7 -0 -1 127.0.0.1 >/dev/null 2>&1; done"])
                    procs.append(scada)
                d = run_cycle(a.lec, a.cycle, port, a.baud)
                an = d["analysis"]
                skew = an["max_start_skew_s"]
                print(f"| {mode} | {a.baud} | {d['cycle_time_s']:.3f} | "
                      f"{'-' if skew is None else f'{skew * 1000:.1f}'} | "
                      f"{an['motion_s']:.3f} / {an['line_s']:.3f} | {d['completed']} |", flush=True)
            finally:
                for p in reversed(procs):
                    p.terminate()
                    try:
                        p.wait(timeout=10)
                    except subprocess.TimeoutExpired:
                        p.kill()


if __name__ == "__main__":
    main()
