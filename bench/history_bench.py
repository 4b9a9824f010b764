#!/usr/bin/python3
"""What the move history costs a running `lec serve` (BENCHMARKS.md, "Move history").

lec serve on its built-in twin (fast timing, 4 axes, telemetry 20 Hz each), an HTTP
move loop on every axis for SECONDS, twice: without the history, then with
--state-dir. Reported for each: moves/s, the daemon's CPU (user + system, all its
threads, from /proc) per second and per move, and the line's transactions/s. The
history adds no transaction by design (it only watches); the line figure shows it.

Usage: bench/history_bench.py BUILD_DIR [SECONDS]
"""
import json
import os
import re
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request

BUILD = sys.argv[1] if len(sys.argv) > 1 else "build"
SECONDS = float(sys.argv[2]) if len(sys.argv) > 2 else 20
LEC = os.path.join(BUILD, "lec")
TICK = os.sysconf("SC_CLK_TCK")


def cpu_s(pid):
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICK


def call(http, method, path, body=None):
    data = None if body is None else json.dumps(body).encode()
    req = urllib.request.Request(http + path, data=data, method=method)
    with urllib.request.urlopen(req, timeout=60) as r:
        return json.loads(r.read())


def run(state_dir):
    args = [LEC, "serve", "--port", "sim", "--sim-timing", "fast", "--ids", "1-4",
            "--telemetry-hz", "20", "--http", "127.0.0.1:0", "--modbus-tcp", ""]
    if state_dir:
        args += ["--state-dir", state_dir]
    p = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    ready = p.stdout.readline()
    http = re.search(r"http://[\d.]+:\d+", ready).group(0)
    threading.Thread(target=p.stdout.read, daemon=True).start()
    try:
        for a in range(1, 5):
            for op, body in [("serial", {"on": True}), ("servo", {"on": True}), ("home", {})]:
                call(http, "POST", f"/api/axes/axis{a}/{op}", body)
        moves = [0] * 4
        stop = threading.Event()

        def loop(i):
            n = 0
            while not stop.is_set():
                call(http, "POST", f"/api/axes/axis{i + 1}/move",
                     {"position_mm": 150 if n % 2 == 0 else 20, "speed_mm_s": 500})
                n += 1
                moves[i] += 1

        tx0 = call(http, "GET", "/api/lines")[0]["stats"]["transactions"]
        c0, t0 = cpu_s(p.pid), time.monotonic()
        threads = [threading.Thread(target=loop, args=(i,)) for i in range(4)]
        for t in threads:
            t.start()
        time.sleep(SECONDS)
        stop.set()
        for t in threads:
            t.join()
        c1, t1 = cpu_s(p.pid), time.monotonic()
        tx1 = call(http, "GET", "/api/lines")[0]["stats"]["transactions"]
        n = sum(moves)
        recorded = None
        if state_dir:
            recorded = sum(call(http, "GET", f"/api/axes/axis{a}/health")["odometer"]["moves"]
                           for a in range(1, 5))
        return {"moves_per_s": n / (t1 - t0), "cpu_pct": 100 * (c1 - c0) / (t1 - t0),
                "cpu_ms_per_move": 1000 * (c1 - c0) / max(n, 1),
                "line_tx_per_s": (tx1 - tx0) / (t1 - t0), "recorded": recorded}
    finally:
        p.terminate()
        p.wait(20)


def main():
    without = run(None)
    with tempfile.TemporaryDirectory() as d:
        with_history = run(d)
    for name, r in (("without history", without), ("with history", with_history)):
        print(f"{name:16} {r['moves_per_s']:6.1f} moves/s  daemon CPU {r['cpu_pct']:5.1f} % "
              f"({r['cpu_ms_per_move']:.2f} ms/move)  line {r['line_tx_per_s']:6.1f} tx/s"
              + (f"  recorded {r['recorded']}" if r["recorded"] is not None else ""))
    extra = with_history["cpu_ms_per_move"] - without["cpu_ms_per_move"]
    print(f"history: {extra:+.3f} ms CPU per move; at one move per second per axis that is "
          f"{extra / 10:+.3f} % of one core per axis")


if __name__ == "__main__":
    main()
