#!/usr/bin/python3
"""How long a stop waits for the wire (BENCHMARKS.md, "A stop reaches the wire").

`lec serve` on its built-in twin in real timing at 38400 baud. A stop is posted
through HTTP (POST /api/axes/axis1/stop), MQTT (PREFIX/line1/axis1/cmd
{"op": "stop"}) and Modbus TCP (a PLC's FC05 RESET pulse), N times each, under
each of three loads:

- idle: one axis with telemetry at 10 Hz, nothing else;
- mixed: the same axis, twenty Modbus TCP clients each keeping 8 uncached
  reads in flight (D0400×16, as a busy SCADA does), a move started before each
  stop, telemetry;
- plant (issue 31, through real sockets): a plant's worst state. The line has
  IDs 1, 2 and 3, telemetry at 10 Hz each, and the twin has only 1 and 2: ID 3
  is a dead neighbour that never answers (backed off, probed every 500 ms). A
  PLC writes its output image every 100 ms over Modbus TCP to every configured
  controller, the dead one too: one FC0F of Y10–Y1F with SVON = 1 and HOLD,
  DRIVE, RESET, SETUP, JOG, IN0–IN5 = 0 (an idle image, no stop), one write per
  controller in flight, as a PLC's client block; the dead one's writes are
  answered 0B and counted. Beside it the mixed load's SCADA flood and a move
  under way on axis1 at each stop: each stop waits until the daemon sees the
  move's start carried out (its commands take turns with the flood's
  connections: about 2 s; 8-15 s when the queue was first in first out across
  clients, bench/results/2026-11-29T0250Z-plant.md), and the stops that found
  the axis moving are counted.

The figure is the line's own: the scheduler's wait of each stop's RESET from
its submit to its frame on the wire (`priorities.emergency.recent_waits_ms` of
GET /api/lines), so it measures the daemon's queueing, not the client's
network stack. The plant load also prints the daemon's view of the dead ID
(GET /api/axes/axis3, the line's device counters) and what the PLC's writes
got back.

Goals, at p99: idle and mixed, one transaction time + Ts, whatever the queue
holds; plant, one transaction + one lost exchange (the dead neighbour's reply
window) + Ts.

Usage: /usr/bin/python3 bench/stop_bench.py [--lec build/lec] [--stops 40]
           [--loads idle,mixed,plant] [--json OUT]
(--loads: a comma-separated subset, default all three; e.g. --loads plant)
"""

import argparse
import collections
import json
import os
import random
import select
import struct
import sys
import tempfile
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests", "integration"))

# A read of D0400×16 at 38400 baud, 8N1 (10 bits a character, digest §1): 8 B query,
# 37 B reply, Ts 0.911 ms, T0 4 ms, Td 5 ms: 21.6 ms; the goal adds Ts: 22.5 ms.
CHAR_MS = 10 * 1000 / 38400
TS_MS = 3.5 * CHAR_MS
TRANSACTION_MS = 8 * CHAR_MS + TS_MS + 4 + 5 + 37 * CHAR_MS

# One lost exchange: the dead neighbour's reply window as lec serve's line times
# it. Once backed off (docs/serve.md, "A dead controller never clogs the others")
# the dead ID is only probed, with one short read of its flags
# (src/serve/line/scheduler_next.cpp: X40×16 by FC02, 8 B query, 7 B reply). The
# line's RtuMaster (src/client/rtu_master.cpp, exchange) sends the query (the
# twin's link holds it for its wire time, src/twin/sim_link.cpp) and then waits
# until Transaction::deadline (src/client/transaction.cpp): Tx of the reply +
# the line's timeout_margin_ms (50 ms, the default of docs/serve.md and
# src/serve/config/config.cpp), where Tx = Ts + T0 4 ms × 1.5 + Td 5 ms + the
# reply's wire time (include/lec6/modbus/timing.hpp, response_time). A stop to
# another ID then waits only Ts of silence, not the quiet after a failure
# (rtu_master.cpp, wait_for_silence): that Ts is the goal's. At 38400 baud:
# 2.08 + 0.91 + 6 + 5 + 1.82 + 50 = 65.8 ms.
TIMEOUT_MARGIN_MS = 50
LOST_EXCHANGE_MS = 8 * CHAR_MS + (TS_MS + 4 * 1.5 + 5 + 7 * CHAR_MS) + TIMEOUT_MARGIN_MS

LOADS = ("idle", "mixed", "plant")
GOALS_MS = {"idle": TRANSACTION_MS + TS_MS, "mixed": TRANSACTION_MS + TS_MS,
            "plant": TRANSACTION_MS + LOST_EXCHANGE_MS + TS_MS}

# The plant: the twin answers IDs 1 and 2; the line also has ID 3, which it never answers.
PLANT_IDS = (1, 2, 3)
DEAD_ID = 3
PLANT_PROBE_MS = 500  # as stop_matrix's rig; the default 2 s: fewer stops meet a probe
PLC_PERIOD_S = 0.1
MOVE_START_DEADLINE_S = 40  # a move's start behind the flood's reads (measured: 8-15 s)
# The PLC's output image: Y10–Y1F, one FC0F of 16 coils, LSB first (bit 0 = Y10).
# Coil addresses: include/lec6/lec/flags.hpp (HOLD Y18, SVON Y19, DRIVE Y1A,
# RESET Y1B, SETUP Y1C, JOG- Y1D, JOG+ Y1E). SVON = 1, everything else 0: an idle
# image, not a stop (client::stops_or_releases: SVON ← 1 and HOLD ← 0 start,
# so the image's RESET ← 0 and DRIVE ← 0 are no release).
Y10 = 0x10
SVON = 0x19
IMAGE_BITS = 1 << (SVON - Y10)
IMAGE_PDU = struct.pack(">BHHB", 0x0F, Y10, 16, 2) + struct.pack("<H", IMAGE_BITS)


def plant_config(http_port, tcp_port, mqtt_port):
    axes = ", ".join(f"{{id: {i}, name: axis{i}, telemetry_hz: 10}}" for i in PLANT_IDS)
    return f"""lines:
  - name: line1
    port: sim
    sim: {{timing: real, absent_ids: [{DEAD_ID}]}}
    probe_interval_ms: {PLANT_PROBE_MS}
    axes: [{axes}]
    modbus_tcp: {{listen: "127.0.0.1:{tcp_port}"}}
http: {{listen: "127.0.0.1:{http_port}"}}
mqtt: {{broker: "mqtt://127.0.0.1:{mqtt_port}", prefix: lec6}}
"""


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
        waits.extend(stop_wait(rig, channel))
    return waits


def stop_wait(rig, channel):
    """Sends one stop by `channel`; the line's wait for its first frame
    (RESET <- 1), as a list of one (none when the line's record missed it)."""
    count0, _ = rig.emergency()
    rig.stop_via(channel)
    count1, recent = rig.emergency()
    new = count1 - count0
    return [recent[-new]] if 0 < new <= len(recent) else []


def moving(axis):
    return bool((axis.get("flags") or {}).get("busy")) or (axis.get("speed_mm_s") or 0) != 0


def measure_moving(rig, channel, stops):
    """As measure(), but each stop waits until the move it is meant to stop is
    seen under way (BUSY or a speed in the daemon's telemetry): behind the SCADA
    flood a move's start is a client command that takes its turns with the
    flood's twenty connections (about 2 s; 8-15 s when the queue was first in
    first out across clients); a stop posted 50-250 ms after the POST, as
    measure() does, finds it still queued and supersedes it (the axis at rest). Returns the waits, the stops that
    found the axis moving, and how long each start took to be seen (s)."""
    waits, moved, starts = [], 0, []
    rng = random.Random(1)
    for _ in range(stops):
        # At rest first (a PLC's RESET pulse is answered before the axis has
        # decelerated), so that the motion seen next is the new move's.
        t0 = time.monotonic()
        while moving(a := rig.axis()) and time.monotonic() - t0 < 10:
            time.sleep(0.05)
        t0 = time.monotonic()
        target = 390 if (a.get("position_mm") or 0) < 200 else 10  # the far end: ~2 s of travel
        rig.http("POST", "/api/axes/axis1/move?wait=false",
                 {"position_mm": target, "speed_mm_s": 200})
        while time.monotonic() - t0 < MOVE_START_DEADLINE_S:
            a = rig.axis()
            if moving(a) or a.get("operation") is None:  # under way, or ended without being seen
                break
            time.sleep(0.05)
        starts.append(time.monotonic() - t0)
        # At a random instant of the telemetry cycle, the move under way.
        time.sleep(rng.uniform(0.05, 0.25))
        moved += moving(rig.axis())
        waits.extend(stop_wait(rig, channel))
    return waits, moved, starts


def start_flood(stop_matrix, port):
    flood = stop_matrix.Flood(port)
    deadline = time.monotonic() + 10
    while flood.replies < 50 and time.monotonic() < deadline:
        time.sleep(0.05)
    return flood


class Plc:
    """A PLC writing its output image (IMAGE_PDU) to each of `units` every
    PLC_PERIOD_S over one Modbus TCP connection, pipelined: at most one write
    per controller in flight (a PLC's client block is busy until its reply;
    a scan that finds it busy skips that controller). Paced by its scan clock,
    never a tight loop; survives exception replies (counted by code) and a
    broken connection (counted, reconnects at the next scan)."""

    def __init__(self, stop_matrix, port, units, period=PLC_PERIOD_S):
        self.mbap = stop_matrix.Mbap
        self.port = port
        self.units = tuple(units)
        self.period = period
        self.halt = threading.Event()
        self.conn = None
        self.buf = b""
        self.in_flight = {}  # transaction id -> (unit, sent at)
        self.scans = 0
        self.late_scans = 0  # scan ticks missed (the host held the thread past them)
        self.sent = collections.Counter()
        self.ok = collections.Counter()
        self.exceptions = {u: collections.Counter() for u in self.units}
        self.busy = collections.Counter()  # scans that found the unit's write still in flight
        self.reply_ms = {u: [] for u in self.units}
        self.errors = collections.Counter()
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def run(self):
        next_scan = time.monotonic()
        while not self.halt.is_set():
            try:
                if self.conn is None:
                    self.conn = self.mbap(self.port)
                    self.buf = b""
                now = time.monotonic()
                if now >= next_scan:
                    self.scan()
                    next_scan += self.period
                    now = time.monotonic()
                    if next_scan <= now:  # behind: skip the ticks missed, keep the phase
                        missed = int((now - next_scan) / self.period) + 1
                        self.late_scans += missed
                        next_scan += missed * self.period
                ready, _, _ = select.select([self.conn.s], [], [],
                                            max(0.0, min(next_scan - time.monotonic(), 0.2)))
                if ready:
                    self.read()
            except (OSError, ValueError, struct.error) as e:
                self.errors[type(e).__name__] += 1
                self.drop()
                self.halt.wait(self.period)
                next_scan = time.monotonic()
        self.drop()

    def scan(self):
        self.scans += 1
        busy = {u for u, _ in self.in_flight.values()}
        for unit in self.units:
            if unit in busy:
                self.busy[unit] += 1
                continue
            c = self.conn
            c.t = (c.t + 1) & 0xFFFF
            self.in_flight[c.t] = (unit, time.monotonic())
            c.s.sendall(struct.pack(">HHHB", c.t, 0, len(IMAGE_PDU) + 1, unit) + IMAGE_PDU)
            self.sent[unit] += 1

    def read(self):
        chunk = self.conn.s.recv(4096)
        if not chunk:
            raise ConnectionError("lec serve closed the PLC's connection")
        self.buf += chunk
        while len(self.buf) >= 7:
            tid, _, length = struct.unpack(">HHH", self.buf[:6])
            if len(self.buf) < 6 + length:
                break
            pdu = self.buf[7:6 + length]
            self.buf = self.buf[6 + length:]
            unit, at = self.in_flight.pop(tid, (None, None))
            if unit is None:
                self.errors["unmatched reply"] += 1
                continue
            self.reply_ms[unit].append((time.monotonic() - at) * 1000)
            if pdu and pdu[0] & 0x80:
                self.exceptions[unit][pdu[1] if len(pdu) > 1 else -1] += 1
            else:
                self.ok[unit] += 1

    def drop(self):
        if self.conn is not None:
            self.in_flight.clear()  # their replies are lost with the connection
            try:
                self.conn.close()
            except OSError:
                pass
            self.conn = None

    def end(self):
        self.halt.set()
        self.thread.join(10)

    def report(self):
        out = {"period_ms": self.period * 1000, "scans": self.scans, "late_scans": self.late_scans,
               "errors": dict(self.errors), "units": {}}
        for u in self.units:
            r = self.reply_ms[u]
            out["units"][u] = {
                "writes": self.sent[u], "ok": self.ok[u],
                "exceptions": {f"{code:02X}": n for code, n in sorted(self.exceptions[u].items())},
                "busy_skips": self.busy[u],
                "reply_p50_ms": percentile(r, 0.5) if r else None,
                "reply_max_ms": max(r) if r else None}
        return out


def plant_rig(stop_matrix, tmp):
    """stop_matrix's Rig (its HTTP, MQTT and Modbus TCP stops, its emergency
    figure, its prepare of axis1) on the plant's line: IDs 1-3, the twin
    without DEAD_ID. Only the config differs from the Rig's own."""

    class PlantRig(stop_matrix.Rig):
        def __init__(self, tmp):  # the Rig's __init__ but for the config
            self.broker = stop_matrix.Broker(tmp).start()
            self.serve = None
            try:
                self.tcp_port = stop_matrix.free_port()
                self.serve = stop_matrix.Serve(tmp, None)
                with open(self.serve.config, "w") as f:
                    f.write(plant_config(self.serve.http_port, self.tcp_port, self.broker.port))
                self.serve.start()
                self.mqtt = stop_matrix.Client(self.broker.port,
                                               subscribe=["lec6/line1/axis1/result"])
            except BaseException:
                if self.serve is not None:
                    self.serve.kill()
                self.broker.stop()
                raise
            self.n = 0

    return PlantRig(tmp)


def dead_view(rig):
    """The daemon's view of the dead ID: its axis and the line's counters for it."""
    a = rig.http("GET", f"/api/axes/axis{DEAD_ID}")[1]
    devices = rig.http("GET", "/api/lines")[1][0]["stats"].get("devices", [])
    dev = next((d for d in devices if d.get("id") == DEAD_ID), {})
    return {"online": a.get("online"), "offline_reason": a.get("offline_reason"),
            "error_rate": a.get("error_rate"),
            "device": {k: dev.get(k) for k in ("transactions", "answers", "timeouts",
                                               "exceptions", "superseded")},
            "superseded": {d.get("id"): d.get("superseded") for d in devices}}


def run_plant(stop_matrix, tmp, stops, results):
    """The plant load; returns what the dead ID and the PLC showed."""
    rig = plant_rig(stop_matrix, tmp)
    plc = flood = None
    moves = {}
    try:
        rig.prepare()  # axis1: serial mode, servo on, homed
        # axis2 in serial mode: the PLC's image writes Y10–Y1F, which needs Y30 = 1.
        status, r = rig.http("POST", "/api/axes/axis2/serial", {"on": True})
        assert status == 200, ("axis2 serial", status, r)
        stop_matrix.wait_until(lambda: rig.http("GET", f"/api/axes/axis{DEAD_ID}")[1]
                               .get("online") is False, 15, f"ID {DEAD_ID} backed off")
        plc = Plc(stop_matrix, rig.tcp_port, PLANT_IDS)
        stop_matrix.wait_until(
            lambda: all(plc.ok[u] for u in PLANT_IDS if u != DEAD_ID)
            and plc.exceptions[DEAD_ID][0x0B] > 0, 15, "the PLC's first writes answered")
        flood = start_flood(stop_matrix, rig.tcp_port)
        for channel in ("http", "mqtt", "modbus"):
            w, moved, starts = measure_moving(rig, channel, stops)
            results[f"plant/{channel}"] = {
                "stops": len(w), "p50_ms": percentile(w, 0.5),
                "p99_ms": percentile(w, 0.99), "max_ms": max(w) if w else None}
            moves[channel] = {"stops_on_a_moving_axis": moved, "stops": stops,
                              "start_seen_p50_s": percentile(starts, 0.5),
                              "start_seen_max_s": max(starts) if starts else None}
        plant = {"dead": dead_view(rig), "moves": moves}
    finally:
        if flood:
            flood.end()
        if plc:
            plc.end()
        rig.mqtt.close()
        rig.serve.kill()
        rig.broker.stop()
    plant["plc"] = plc.report()
    plant["flood_replies"] = flood.replies
    return plant


def parse_loads(values):
    loads = [x for v in values for x in v.split(",") if x]
    bad = [x for x in loads if x not in LOADS]
    if bad or not loads:
        raise argparse.ArgumentTypeError(f"--loads: one or more of {', '.join(LOADS)}")
    return [x for x in LOADS if x in loads]


def main():
    ap = argparse.ArgumentParser(description="How long a stop waits for the wire.")
    ap.add_argument("--lec", default="build/lec")
    ap.add_argument("--stops", type=int, default=40)
    ap.add_argument("--loads", nargs="+", default=[",".join(LOADS)],
                    help="comma-separated: idle, mixed, plant (default: all three)")
    ap.add_argument("--json")
    args = ap.parse_args()
    try:
        loads = parse_loads(args.loads)
    except argparse.ArgumentTypeError as e:
        ap.error(str(e))
    os.environ["LEC"] = os.path.abspath(args.lec)
    import stop_matrix  # after LEC is set: mqtt_lib reads it at import

    results = {}
    plant = None
    with tempfile.TemporaryDirectory(prefix="lec6-stop-bench-") as tmp:
        # The daemons' move history in the scratch directory, not the user's.
        os.environ["XDG_STATE_HOME"] = os.path.join(tmp, "state")
        if "idle" in loads or "mixed" in loads:
            rig = stop_matrix.Rig(tmp)
            try:
                rig.prepare()
                for load in ("idle", "mixed"):
                    if load not in loads:
                        continue
                    flood = None
                    if load == "mixed":
                        flood = start_flood(stop_matrix, rig.tcp_port)
                    for channel in ("http", "mqtt", "modbus"):
                        w = measure(rig, channel, args.stops, load == "mixed")
                        results[f"{load}/{channel}"] = {
                            "stops": len(w), "p50_ms": percentile(w, 0.5),
                            "p99_ms": percentile(w, 0.99), "max_ms": max(w) if w else None}
                    if flood:
                        flood.end()
            finally:
                rig.mqtt.close()
                rig.serve.kill()
                rig.broker.stop()
        if "plant" in loads:
            os.mkdir(os.path.join(tmp, "plant"))
            plant = run_plant(stop_matrix, os.path.join(tmp, "plant"), args.stops, results)

    if "idle" in loads or "mixed" in loads:
        print(f"idle, mixed: one transaction (D0400x16 at 38400) {TRANSACTION_MS:.1f} ms "
              f"+ Ts {TS_MS:.2f} ms = goal {GOALS_MS['idle']:.1f} ms at p99")
    if plant is not None:
        print(f"plant: one transaction {TRANSACTION_MS:.1f} ms + one lost exchange (the dead "
              f"ID's probe, its reply window) {LOST_EXCHANGE_MS:.1f} ms + Ts {TS_MS:.2f} ms "
              f"= goal {GOALS_MS['plant']:.1f} ms at p99")
    print(f"{'load/channel':<14} {'stops':>5} {'p50 ms':>8} {'p99 ms':>8} {'max ms':>8}  goal met")
    for k, r in results.items():
        goal = GOALS_MS[k.split("/")[0]]
        if not r["stops"]:
            print(f"{k:<14} {0:>5} {'-':>8} {'-':>8} {'-':>8}  NO (no stop measured)")
            continue
        print(f"{k:<14} {r['stops']:>5} {r['p50_ms']:>8.2f} {r['p99_ms']:>8.2f} "
              f"{r['max_ms']:>8.2f}  {'yes' if r['p99_ms'] <= goal else 'NO'}")
    if plant is not None:
        d = plant["dead"]
        print(f"plant: ID {DEAD_ID} as lec serve sees it: online {d['online']}, "
              f"{d['device']['timeouts']} timeouts, {d['device']['answers']} answers in "
              f"{d['device']['transactions']} exchanges; {d['offline_reason']}")
        p = plant["plc"]
        print(f"plant: the PLC, {p['scans']} scans every {p['period_ms']:.0f} ms "
              f"({p['late_scans']} ticks missed), errors {p['errors'] or 'none'}:")
        for u, s in p["units"].items():
            rep = ("" if s["reply_p50_ms"] is None else
                   f", reply p50 {s['reply_p50_ms']:.0f} ms max {s['reply_max_ms']:.0f} ms")
            print(f"  ID {u}: {s['writes']} writes, {s['ok']} ok, exceptions "
                  f"{s['exceptions'] or 'none'}, {s['busy_skips']} scans found it in flight{rep}")
        for ch, m in plant["moves"].items():
            print(f"plant/{ch}: {m['stops_on_a_moving_axis']} of {m['stops']} stops found axis1 "
                  f"moving; its start seen under way {m['start_seen_p50_s']:.1f} s (p50), "
                  f"{m['start_seen_max_s']:.1f} s (max) after the move was posted")
        print(f"plant: superseded writes per ID {d['superseded']}; "
              f"SCADA flood {plant['flood_replies']} replies")
    if args.json:
        out = {"goals_ms": {k: GOALS_MS[k] for k in loads}, "results": results}
        if "idle" in loads or "mixed" in loads:
            out["goal_ms"] = GOALS_MS["idle"]  # as before the plant load: idle's and mixed's
        if plant is not None:
            out["plant"] = plant
        with open(args.json, "w") as f:
            json.dump(out, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
