#!/usr/bin/python3
"""A stop through HTTP while the history answers long queries (BENCHMARKS.md,
"Move history", issue 32: "a stop posted meanwhile is not delayed").

`lec serve` on its built-in twin in real timing at 38400 baud, one axis (x)
with telemetry at 10 Hz, its history a file of N records (4 axes over 100
days, filled by lec6_history_queries). A stop is posted through HTTP (POST
/api/axes/x/stop) N times on an idle daemon, then while two clients keep
asking GET /api/axes/x/history?limit=10000 back to back (each a long query
over a quarter of the records). Two figures per stop: the HTTP round trip as
the client sees it (the request's handling on the daemon's I/O thread, the
RESET pulse, the judgement of the axis at rest), and the scheduler's wait of
its RESET from submit to the wire (GET /api/lines). If a query held the I/O
thread, the round trip would grow by the query's time.

Usage: /usr/bin/python3 bench/history_stop_bench.py [--lec build/lec]
         [--fill build/lec6_history_queries] [--records 1000000] [--stops 60] [--json OUT]
"""

import argparse
import json
import os
import random
import subprocess
import sys
import tempfile
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests", "integration"))


def percentile(v, p):
    v = sorted(v)
    return v[min(len(v) - 1, int(p * (len(v) - 1) + 0.5))] if v else float("nan")


def config(http_port, state_dir):
    return f"""lines:
  - name: line1
    port: sim
    sim: {{timing: real}}
    axes: [{{id: 1, name: x, telemetry_hz: 10}}]
http: {{listen: "127.0.0.1:{http_port}"}}
history: {{state_dir: "{state_dir}", max_size_mb: 100000, max_age_days: 36500}}
"""


class Queries:
    """Clients asking the history's longest page back to back."""

    def __init__(self, serve, clients=2):
        self.serve, self.ms, self.errors, self.done = serve, [], 0, False
        self.threads = [threading.Thread(target=self.run, daemon=True) for _ in range(clients)]
        for t in self.threads:
            t.start()

    def run(self):
        while not self.done:
            t0 = time.monotonic()
            status, body = self.serve.http("GET", "/api/axes/x/history?limit=10000")
            if status == 200 and body:
                self.ms.append((time.monotonic() - t0) * 1000)
            else:
                self.errors += 1

    def end(self):
        self.done = True
        for t in self.threads:
            t.join(60)


def emergency(serve):
    p = serve.http("GET", "/api/lines")[1][0]["stats"]["priorities"]["emergency"]
    return p.get("wait_count", 0), p.get("recent_waits_ms", [])


def measure(serve, stops):
    rtt, waits = [], []
    rng = random.Random(1)
    for _ in range(stops):
        time.sleep(rng.uniform(0.05, 0.25))
        count0, _ = emergency(serve)
        t0 = time.monotonic()
        status, body = serve.http("POST", "/api/axes/x/stop", {})
        rtt.append((time.monotonic() - t0) * 1000)
        assert status == 200, (status, body)
        count1, recent = emergency(serve)
        new = count1 - count0
        if 0 < new <= len(recent):
            waits.append(recent[-new])
    return rtt, waits


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--lec", default="build/lec")
    ap.add_argument("--fill", default="build/lec6_history_queries")
    ap.add_argument("--records", type=int, default=1_000_000)
    ap.add_argument("--stops", type=int, default=60)
    ap.add_argument("--json")
    args = ap.parse_args()
    os.environ["LEC"] = os.path.abspath(args.lec)
    import mqtt_lib  # after LEC is set: it reads it at import

    results = {}
    with tempfile.TemporaryDirectory(prefix="lec6-history-stop-") as tmp:
        state = os.path.join(tmp, "state")
        t = time.monotonic()
        subprocess.run([args.fill, "--records", str(args.records), "--runs", "10", "--dir", state,
                        "--keep"], check=True, stdout=subprocess.DEVNULL)
        print(f"history of {args.records} records filled in {time.monotonic() - t:.0f} s",
              flush=True)
        serve = mqtt_lib.Serve(tmp, None)
        with open(serve.config, "w") as f:
            f.write(config(serve.http_port, state))
        serve.start()
        try:
            for op, body in (("serial", {"on": True}), ("servo", {"on": True}), ("home", {})):
                status, r = serve.http("POST", f"/api/axes/x/{op}", body)
                assert status == 200, (op, status, r)
            for load in ("idle", "history"):
                q = Queries(serve) if load == "history" else None
                if q:
                    time.sleep(1)  # the queries under way
                rtt, waits = measure(serve, args.stops)
                r = {"stops": len(rtt), "rtt_p50_ms": percentile(rtt, 0.5),
                     "rtt_p99_ms": percentile(rtt, 0.99), "rtt_max_ms": max(rtt),
                     "wire_wait_p50_ms": percentile(waits, 0.5),
                     "wire_wait_p99_ms": percentile(waits, 0.99)}
                if q:
                    q.end()
                    r.update({"queries": len(q.ms), "query_errors": q.errors,
                              "query_p50_ms": percentile(q.ms, 0.5),
                              "query_p99_ms": percentile(q.ms, 0.99)})
                results[load] = r
        finally:
            serve.stop()
    print(f"{'load':<8} {'stops':>5} {'HTTP stop p50':>13} {'p99':>7} {'max':>7}  "
          f"{'wire wait p50':>13} {'p99':>6}  queries (p50 / p99 ms)")
    for k, r in results.items():
        qs = (f"{r['queries']} ({r['query_p50_ms']:.0f} / {r['query_p99_ms']:.0f}), "
              f"{r['query_errors']} failed" if "queries" in r else "-")
        print(f"{k:<8} {r['stops']:>5} {r['rtt_p50_ms']:>13.1f} {r['rtt_p99_ms']:>7.1f} "
              f"{r['rtt_max_ms']:>7.1f}  {r['wire_wait_p50_ms']:>13.2f} {r['wire_wait_p99_ms']:>6.2f}  {qs}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"records": args.records, "results": results}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
