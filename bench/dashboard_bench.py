#!/usr/bin/python3
"""What a dashboard browser costs `lec serve` (BENCHMARKS.md, "Dashboard").

A browser with the dashboard open holds one live stream (GET /api/events, server-sent
events) and reads the API on page changes; the stream is its steady cost. This starts
`lec serve` on the built-in twin (fast timing) with 4 axes at --hz telemetry each, then
measures over --seconds, with 0 streams and then with --browsers streams open (each read
to the end by its own thread, as a browser does):

  * the daemon's CPU (user + system, from /proc), and its difference per browser;
  * the line's transactions/s (lec6_line_transactions_per_second): the goal is equal with
    and without browsers, as they read the daemon's cache, never the line;
  * the events each stream received per second.

    bench/dashboard_bench.py [--lec build/lec] [--hz 50] [--browsers 10] [--seconds 10] [--json FILE]
"""
import argparse
import json
import os
import re
import subprocess
import threading
import time
import urllib.request


def cpu_seconds(pid):
    fields = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def metric(http, name):
    for line in urllib.request.urlopen(http + "/metrics").read().decode().splitlines():
        if line.startswith(name + "{"):
            return float(line.rsplit(" ", 1)[1])
    raise KeyError(name)


class Stream(threading.Thread):
    """One browser's live stream: counts the events it receives."""

    def __init__(self, http):
        super().__init__(daemon=True)
        self.http, self.events, self.stop = http, 0, threading.Event()

    def run(self):
        for path in ("/api/info", "/api/lines", "/api/axes"):  # what the page loads first
            urllib.request.urlopen(self.http + path).read()
        with urllib.request.urlopen(self.http + "/api/events") as r:
            while not self.stop.is_set():
                line = r.readline()
                if not line:
                    return
                if line.startswith(b"event:") or line.startswith(b"data:"):
                    self.events += line.startswith(b"data:")


def measure(pid, http, seconds):
    cpu0, t0 = cpu_seconds(pid), time.monotonic()
    time.sleep(seconds)
    cpu1, t1 = cpu_seconds(pid), time.monotonic()
    return (cpu1 - cpu0) / (t1 - t0), metric(http, "lec6_line_transactions_per_second")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--lec", default="build/lec")
    ap.add_argument("--hz", type=float, default=50)
    ap.add_argument("--browsers", type=int, default=10)
    ap.add_argument("--seconds", type=float, default=10)
    ap.add_argument("--json")
    a = ap.parse_args()
    p = subprocess.Popen([a.lec, "--port", "sim", "serve", "--ids", "1-4", "--telemetry-hz", str(a.hz),
                          "--sim-timing", "fast", "--http", "127.0.0.1:0", "--modbus-tcp", ""],
                         stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        ready = p.stdout.readline()
        http = "http://" + re.search(r"http://([0-9.:]+)", ready).group(1)
        time.sleep(2)  # telemetry at its rate
        idle_cpu, idle_tps = measure(p.pid, http, a.seconds)
        streams = [Stream(http) for _ in range(a.browsers)]
        for s in streams:
            s.start()
        time.sleep(2)
        before = [s.events for s in streams]
        busy_cpu, busy_tps = measure(p.pid, http, a.seconds)
        rates = [(s.events - b) / a.seconds for s, b in zip(streams, before)]
        for s in streams:
            s.stop.set()
    finally:
        p.terminate()
        p.wait(10)
    out = {
        "axes": 4, "telemetry_hz": a.hz, "browsers": a.browsers,
        "cpu_without": idle_cpu, "cpu_with": busy_cpu,
        "cpu_per_browser": (busy_cpu - idle_cpu) / a.browsers,
        "line_tps_without": idle_tps, "line_tps_with": busy_tps,
        "events_per_s_per_browser_min": min(rates), "events_per_s_per_browser_max": max(rates),
    }
    print(f"lec serve, 4 axes x {a.hz:g} Hz telemetry (fast twin), {a.seconds:g} s each:")
    print(f"  CPU without browsers {100 * idle_cpu:.2f} %, with {a.browsers}: {100 * busy_cpu:.2f} % "
          f"of one core -> {100 * out['cpu_per_browser']:.3f} % per browser")
    print(f"  line transactions/s without {idle_tps:.1f}, with {busy_tps:.1f} "
          f"(ratio {busy_tps / idle_tps:.3f})")
    print(f"  events/s per browser: {min(rates):.1f} to {max(rates):.1f}")
    if a.json:
        json.dump(out, open(a.json, "w"), indent=2)


if __name__ == "__main__":
    main()
