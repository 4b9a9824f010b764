#!/usr/bin/python3
"""How long a stop waits for the wire (BENCHMARKS.md, "A stop reaches the wire").

`lec serve` on its built-in twin in real timing at 38400 baud, one axis with
telemetry at 10 Hz. A stop is posted through HTTP (POST /api/axes/axis1/stop),
MQTT (PREFIX/line1/axis1/cmd {"op": "stop"}) and Modbus TCP (a PLC's FC05
RESET pulse), N times each, on an idle line and under mixed load: twenty
Modbus TCP clients each keeping 8 uncached reads in flight (D0400×16, as a
busy SCADA does), a move started before each stop, telemetry. The figure is the line's own:
the scheduler's wait of each stop's RESET from its submit to its frame on the
wire (`priorities.emergency.recent_waits_ms` of GET /api/lines), so it
measures the daemon's queueing, not the client's network stack.

Goal: p99 <= one transaction time + Ts, whatever the queue holds.

Usage: /usr/bin/python3 bench/stop_bench.py [--lec build/lec] [--stops 40] [--json OUT]
"""

import argparse
import json
import os
import random
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests", "integration"))

# A read of D0400×16 at 38400 baud, 8N1 (10 bits a character, digest §1): 8 B query,
# 37 B reply, Ts 0.911 ms, T0 4 ms, Td 5 ms: 21.6 ms; the goal adds Ts: 22.5 ms.
CHAR_MS = 10 * 1000 / 38400
TS_MS = 3.5 * CHAR_MS
TRANSACTION_MS = 8 * CHAR_MS + TS_MS + 4 + 5 + 37 * CHAR_MS


def percentile(v, p):
    v = sorted(v)
    return v[min(len(v) - 1, int(p * (len(v) - 1) + 0.5))] if v else float("nan")


def measure(rig, channel, stops, moving):
    waits = []
    rng = random.Random(1)
    for i in range(stops):
        # At a random instant of the telemetry cycle: right after the previous
        # stop, the telemetry that waited for it would always be on the wire.
        time.sleep(rng.uniform(0.05, 0.25))
        if moving:  # a move under way at each stop: the last stop ended the previous one
            rig.http("POST", "/api/axes/axis1/move?wait=false",
                     {"position_mm": 390 if i % 2 == 0 else 10, "speed_mm_s": 200})
        count0, _ = rig.emergency()
        rig.stop_via(channel)
        count1, recent = rig.emergency()
        new = count1 - count0
        if 0 < new <= len(recent):
            waits.append(recent[-new])  # the stop's first frame: RESET <- 1
    return waits


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--lec", default="build/lec")
    ap.add_argument("--stops", type=int, default=40)
    ap.add_argument("--json")
    args = ap.parse_args()
    os.environ["LEC"] = os.path.abspath(args.lec)
    import stop_matrix  # after LEC is set: mqtt_lib reads it at import

    results = {}
    with tempfile.TemporaryDirectory(prefix="lec6-stop-bench-") as tmp:
        rig = stop_matrix.Rig(tmp)
        try:
            rig.prepare()
            for load in ("idle", "mixed"):
                flood = None
                if load == "mixed":
                    flood = stop_matrix.Flood(rig.tcp_port)
                    deadline = time.monotonic() + 10
                    while flood.replies < 50 and time.monotonic() < deadline:
                        time.sleep(0.05)
                for channel in ("http", "mqtt", "modbus"):
                    w = measure(rig, channel, args.stops, load == "mixed")
                    results[f"{load}/{channel}"] = {
                        "stops": len(w), "p50_ms": percentile(w, 0.5),
                        "p99_ms": percentile(w, 0.99), "max_ms": max(w) if w else None}
                if flood:
                    flood.end()
        finally:
            rig.serve.kill()
            rig.broker.stop()
    goal = TRANSACTION_MS + TS_MS
    print(f"one transaction (D0400x16 at 38400) {TRANSACTION_MS:.1f} ms + Ts {TS_MS:.2f} ms "
          f"= goal {goal:.1f} ms at p99")
    print(f"{'load/channel':<14} {'stops':>5} {'p50 ms':>8} {'p99 ms':>8} {'max ms':>8}  goal met")
    for k, r in results.items():
        print(f"{k:<14} {r['stops']:>5} {r['p50_ms']:>8.2f} {r['p99_ms']:>8.2f} "
              f"{r['max_ms']:>8.2f}  {'yes' if r['p99_ms'] <= goal else 'NO'}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"goal_ms": goal, "results": results}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
