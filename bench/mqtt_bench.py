#!/usr/bin/python3
"""The MQTT bridge's cost and latency (BENCHMARKS.md, "MQTT bridge").

Starts Debian's mosquitto on a free loopback port and `lec serve` with
LINES sim lines (fast twin) of IDS axes each, the line's telemetry at
--axis-hz per axis, then:

  1. CPU of `lec serve` over --seconds without the bridge (baseline), then
     with mqtt.telemetry_hz = --mqtt-hz: the bridge's own cost is the
     difference. Messages/s and bytes/s as a subscriber to PREFIX/# counts
     them, and the broker's CPU.
  2. Command round trip on one axis, N times each, interleaved in rounds:
     MQTT (publish to .../cmd, wait for .../result with the id) against
     HTTP (POST /api/axes/NAME/step-read on a kept-alive connection), both
     `step-read {"step": 0}` (one FC03 read at client priority).

    bench/mqtt_bench.py [--lec build/lec] [--lines 4] [--ids 16] [--axis-hz 20]
                        [--mqtt-hz 20] [--seconds 10] [--rtt 300] [--json FILE]
"""

import argparse
import http.client
import json
import os
import statistics
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests", "integration"))
import mqtt_lib  # noqa: E402
from mqtt_lib import Axis, Broker, Client, Serve  # noqa: E402

TICK = os.sysconf("SC_CLK_TCK")


def cpu_s(pid):
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICK  # utime + stime


def measure_cpu(pids, seconds):
    before = [cpu_s(p) for p in pids]
    t0 = time.monotonic()
    time.sleep(seconds)  # a measurement window, not a synchronisation
    dt = time.monotonic() - t0
    return [(cpu_s(p) - b) / dt for p, b in zip(pids, before)], dt


def percentiles(v):
    v = sorted(v)
    q = lambda p: v[min(len(v) - 1, int(p * (len(v) - 1) + 0.5))]  # noqa: E731
    return {"n": len(v), "mean_ms": statistics.fmean(v), "p50_ms": q(0.5), "p90_ms": q(0.9),
            "p99_ms": q(0.99), "max_ms": v[-1]}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--lec", default=os.path.join(HERE, "..", "build", "lec"))
    ap.add_argument("--lines", type=int, default=4)
    ap.add_argument("--ids", type=int, default=16)
    ap.add_argument("--axis-hz", type=float, default=20)
    ap.add_argument("--mqtt-hz", type=float, default=20)
    ap.add_argument("--seconds", type=float, default=10)
    ap.add_argument("--rtt", type=int, default=300)
    ap.add_argument("--json")
    a = ap.parse_args()
    mqtt_lib.LEC = a.lec
    ids = tuple(range(1, a.ids + 1))
    shape = dict(lines=a.lines, ids=ids, axis_hz=a.axis_hz)
    out = {"lines": a.lines, "axes": a.lines * a.ids, "axis_hz": a.axis_hz, "mqtt_hz": a.mqtt_hz}
    with tempfile.TemporaryDirectory() as tmp:
        base = Serve(tmp, None, name="base", **shape).start()
        time.sleep(2)  # settle: every axis polled at least once
        (cpu,), dt = measure_cpu([base.proc.pid], a.seconds)
        out["baseline"] = {"serve_cpu": cpu, "tx_per_s": sum(
            l["stats"]["transactions_per_s"] for l in base.http("GET", "/api/lines")[1])}
        base.stop()
        print(f"baseline: lec serve {100 * cpu:.1f} % CPU over {dt:.1f} s, "
              f"{out['baseline']['tx_per_s']:.0f} tx/s on the lines", flush=True)

        broker = Broker(tmp).start()
        serve = Serve(tmp, {"broker": f"mqtt://127.0.0.1:{broker.port}", "client_id": "bench",
                            "prefix": "b", "telemetry_hz": a.mqtt_hz}, **shape).start()
        try:
            sub = Client(broker.port, ["b/#"])
            sub.wait_for(lambda m: m.topic == "b/bench/status" and m.payload == "online", 10,
                         "online")
            time.sleep(2)
            start = sub.mark()
            t0 = time.monotonic()
            (cpu, bcpu), dt = measure_cpu([serve.proc.pid, broker.proc.pid], a.seconds)
            msgs = [m for m in sub.since(start) if t0 <= m.t]
            states = [m for m in msgs if m.topic.endswith("/state")]
            out["bridge"] = {
                "serve_cpu": cpu, "broker_cpu": bcpu,
                "messages_per_s": len(msgs) / dt, "state_per_s": len(states) / dt,
                "bytes_per_s": sum(len(m.payload) for m in msgs) / dt,
                "state_bytes_mean": statistics.fmean(len(m.payload) for m in states),
                "tx_per_s": sum(l["stats"]["transactions_per_s"]
                                for l in serve.http("GET", "/api/lines")[1])}
            b = out["bridge"]
            print(f"bridge: lec serve {100 * cpu:.1f} % CPU (+{100 * (cpu - out['baseline']['serve_cpu']):.1f}),"
                  f" mosquitto {100 * bcpu:.1f} %; {b['messages_per_s']:.0f} messages/s "
                  f"({b['state_per_s']:.0f} state/s, expected {a.lines * a.ids * a.mqtt_hz:.0f}), "
                  f"{b['bytes_per_s'] / 1e3:.0f} kB/s, state {b['state_bytes_mean']:.0f} B",
                  flush=True)

            name = "l1a1" if a.lines > 1 else "axis1"
            ax = Axis(sub, "b", "line1", name)
            conn = http.client.HTTPConnection("127.0.0.1", serve.http_port)
            body = json.dumps({"step": 0})
            mq, ht = [], []
            for i in range(a.rtt):
                t = time.perf_counter()
                r = ax.run("step-read", step=0)
                mq.append(1e3 * (time.perf_counter() - t))
                assert r["ok"], r
                t = time.perf_counter()
                conn.request("POST", f"/api/axes/{name}/step-read", body)
                resp = conn.getresponse()
                resp.read()
                ht.append(1e3 * (time.perf_counter() - t))
                assert resp.status == 200
            out["rtt"] = {"mqtt": percentiles(mq), "http": percentiles(ht)}
            for k in ("mqtt", "http"):
                p = out["rtt"][k]
                print(f"round trip {k:4}: p50 {p['p50_ms']:.2f} ms, p90 {p['p90_ms']:.2f}, "
                      f"p99 {p['p99_ms']:.2f}, mean {p['mean_ms']:.2f} (n={p['n']})", flush=True)
            sub.close()
        finally:
            serve.stop()
            broker.stop()
    if a.json:
        with open(a.json, "w") as f:
            json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
