"""A stop always reaches the controller: `lec serve` on its built-in twin in
real timing, a slow move under way, and a stop posted through HTTP, MQTT and
Modbus TCP while the line struggles: replies lost, corrupted or preceded by
noise, a configured ID that never answers, twenty SCADA clients flooding
uncached reads, the controller backed off as not answering. In each case the
axis must end not moving, short of its target, where the stop caught it.

Prints, for each case and channel, the time from the stop posted to its frame
on the wire (the line's own figure: the scheduler's wait of that RESET) and
from post to answer.

Every wait is on an event or a polled state with a deadline; nothing sleeps
to synchronise (the short sleeps below let the axis travel, and are part of
the scenario, not of its synchronisation). Run by Debian's /usr/bin/python3.
"""

import json
import os
import socket
import struct
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mqtt_lib import Broker, Checks, Client, Serve, free_port, wait_until  # noqa: E402

SPEED = 20  # mm/s: a slow move, so where the stop caught it is measurable
RESET = 0x1B


def config(http_port, tcp_port, mqtt_port):
    return f"""lines:
  - name: line1
    port: sim
    sim: {{timing: real, absent_ids: [9]}}
    probe_interval_ms: 500
    axes: [{{id: 1, name: axis1, telemetry_hz: 10}}, {{id: 9, name: ghost, telemetry_hz: 0}}]
    modbus_tcp: {{listen: "127.0.0.1:{tcp_port}"}}
http: {{listen: "127.0.0.1:{http_port}"}}
mqtt: {{broker: "mqtt://127.0.0.1:{mqtt_port}", prefix: lec6}}
"""


class Mbap:
    """A Modbus TCP master over one socket, one request at a time."""

    def __init__(self, port):
        self.s = socket.create_connection(("127.0.0.1", port), timeout=10)
        self.s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.t = 0

    def request(self, unit, pdu):
        self.t = (self.t + 1) & 0xFFFF
        self.s.sendall(struct.pack(">HHHB", self.t, 0, len(pdu) + 1, unit) + pdu)
        return self.reply()

    def reply(self):
        head = self.recv(7)
        _, _, length, _ = struct.unpack(">HHHB", head)
        return self.recv(length - 1)

    def recv(self, n):
        out = b""
        while len(out) < n:
            chunk = self.s.recv(n - len(out))
            if not chunk:
                raise ConnectionError("closed")
            out += chunk
        return out

    def write_coil(self, unit, coil, on):
        return self.request(unit, struct.pack(">BHH", 5, coil, 0xFF00 if on else 0))

    def close(self):
        self.s.close()


class Flood:
    """Twenty SCADA clients, each keeping 8 reads of step data in flight
    (D0400×16: not a telemetry block, so every one reaches the line)."""

    def __init__(self, port, clients=20, in_flight=8):
        self.stop = threading.Event()
        self.replies = 0
        self.threads = [threading.Thread(target=self.client, args=(port, in_flight), daemon=True)
                        for _ in range(clients)]
        for t in self.threads:
            t.start()

    def client(self, port, in_flight):
        try:
            s = socket.create_connection(("127.0.0.1", port), timeout=30)
            s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            pdu = struct.pack(">BHH", 3, 0x0400, 16)
            frame = lambda t: struct.pack(">HHHB", t, 0, len(pdu) + 1, 1) + pdu  # noqa: E731
            t = 0
            for _ in range(in_flight):
                t += 1
                s.sendall(frame(t))
            buf = b""
            while not self.stop.is_set():
                chunk = s.recv(4096)
                if not chunk:
                    return
                buf += chunk
                while len(buf) >= 6:
                    length = struct.unpack(">H", buf[4:6])[0]
                    if len(buf) < 6 + length:
                        break
                    buf = buf[6 + length:]
                    self.replies += 1
                    t = (t + 1) & 0xFFFF
                    s.sendall(frame(t))
            s.close()
        except OSError:
            pass

    def end(self):
        self.stop.set()
        for t in self.threads:
            t.join(10)


class Rig:
    def __init__(self, tmp):
        self.broker = Broker(tmp).start()
        self.tcp_port = free_port()
        self.serve = Serve(tmp, None)
        with open(self.serve.config, "w") as f:
            f.write(config(self.serve.http_port, self.tcp_port, self.broker.port))
        self.serve.start()
        self.mqtt = Client(self.broker.port, subscribe=["lec6/line1/axis1/result"])
        self.n = 0

    def http(self, method, path, body=None):
        return self.serve.http(method, path, body)

    def axis(self):
        return self.serve.axis("axis1")

    def twin(self, **faults):
        status, _ = self.http("POST", "/api/lines/line1/twin", faults)
        assert status == 200, status

    def emergency(self):
        p = self.http("GET", "/api/lines")[1][0]["stats"]["priorities"]["emergency"]
        return p.get("wait_count", 0), p.get("recent_waits_ms", [])

    def prepare(self):
        for op, body in (("serial", {"on": True}), ("servo", {"on": True}), ("home", {})):
            status, r = self.http("POST", f"/api/axes/axis1/{op}", body)
            assert status == 200, (op, status, r)

    def fresh(self):
        """The axis as read after now: flags and state newer than 300 ms."""
        def ok():
            a = self.axis()
            ages = a.get("ages_ms") or {}
            if not a.get("online") or ages.get("flags") is None or ages.get("state") is None:
                return None
            return a if max(ages["flags"], ages["state"]) < 300 else None
        return wait_until(ok, 15, "a fresh read of axis1")

    def start_move(self):
        a = self.fresh()
        target = 390.0 if a["position_mm"] < 200 else 10.0
        status, r = self.http("POST", "/api/axes/axis1/move?wait=false",
                              {"position_mm": target, "speed_mm_s": SPEED})
        assert status == 202, (status, r)
        wait_until(lambda: abs(self.axis().get("speed_mm_s") or 0) > 0, 10, "the axis moving")
        return target

    def stop_via(self, channel):
        """Posts a stop; returns (post → answer seconds, status)."""
        t0 = time.monotonic()
        if channel == "http":
            status, body = self.http("POST", "/api/axes/axis1/stop", {})
            if os.environ.get("STOP_MATRIX_BODY"):  # debugging: the stop's answer
                print(body, flush=True)
        elif channel == "mqtt":
            self.n += 1
            rid = f"stop{self.n}"
            start = len(self.mqtt.msgs)
            self.mqtt.c.publish("lec6/line1/axis1/cmd", json.dumps({"id": rid, "op": "stop"}), qos=1)
            m = self.mqtt.wait_for(lambda m: m.json().get("id") == rid, 30, "the stop's result",
                                   start=start)
            status = m.json()["status"]
        else:  # a PLC's stop: the RESET pulse as two coil writes
            plc = Mbap(self.tcp_port)
            on = plc.write_coil(1, RESET, True)
            plc.write_coil(1, RESET, False)
            plc.close()
            status = 200 if on[0] == 5 else 500 + on[-1]
        return time.monotonic() - t0, status


def run_case(rig, checks, case, channel, retried=False):
    flood = None
    target = rig.start_move()
    time.sleep(0.3)  # travel
    before = rig.fresh() if case != "offline" else rig.axis()
    start_pos = before["position_mm"]
    direction = 1 if target > start_pos else -1
    if case == "drops":
        rig.twin(drop_rate=0.5)
    elif case == "corruption":
        rig.twin(corrupt_rate=0.5)
    elif case == "noise":
        rig.twin(garbage_rate=0.5)
    elif case == "flood":
        flood = Flood(rig.tcp_port)
        wait_until(lambda: flood.replies > 20, 10, "the flood under way")
    elif case == "dead-id":
        # ID 9 is configured and never answers: clients keep asking for it.
        flood = Flood(rig.tcp_port, clients=4, in_flight=1)
        ghost = Mbap(rig.tcp_port)
        ghost.request(9, struct.pack(">BHH", 3, 0x9000, 7))  # 0B: no answer
        ghost.close()
    elif case == "offline":
        loss_at = time.monotonic()
        rig.twin(drop_rate=1.0)
        wait_until(lambda: rig.axis().get("online") is False, 10, "axis1 backed off")
    count0, _ = rig.emergency()
    t_posted = time.monotonic()
    back = None
    if case == "offline" and channel != "modbus":
        # The replies come back 3 s after they were lost, while the stop is
        # being judged (its deadline is 10 s): the judgement must see the axis
        # once it answers again, and say it stopped.
        back = threading.Timer(max(0.0, 3.0 - (time.monotonic() - loss_at)),
                               lambda: rig.twin(drop_rate=0))
        back.start()
    took, status = rig.stop_via(channel)
    if back:
        back.join()
    elif case == "offline":
        # A PLC's RESET writes are answered at once (exception 0B: the axis is
        # backed off); the replies come back 3 s after they were lost.
        time.sleep(max(0.0, 3.0 - (time.monotonic() - loss_at)))
    if flood:
        flood.end()
    rig.twin(drop_rate=0, corrupt_rate=0, garbage_rate=0)
    after = rig.fresh()
    # Stopped: BUSY = 0 and no speed (the twin drops BUSY at the stop and
    # then decelerates, as its ledger says).
    wait_until(lambda: (lambda a: not a["flags"]["busy"] and a["speed_mm_s"] == 0)(rig.fresh()),
               10, "BUSY = 0 and speed 0")
    p1 = rig.fresh()["position_mm"]
    time.sleep(0.5)  # would an axis still moving at 20 mm/s have gone on 10 mm?
    p2 = rig.fresh()["position_mm"]
    count1, waits = rig.emergency()
    new = count1 - count0
    wire_ms = waits[-new] if 0 < new <= len(waits) else None
    label = f"{case:<10} via {channel:<4}"
    print(f"{label}: stop on the wire {wire_ms if wire_ms is None else round(wire_ms, 1)} ms "
          f"after it was posted; answered {status} in {took * 1000:.0f} ms; stood at "
          f"{p2:.2f} mm (target {target:.0f})", flush=True)
    checks.check(abs(p2 - p1) < 0.05, f"{label}: the axis is not moving", f"{p1} → {p2}")
    checks.check(abs(p2 - target) > 5, f"{label}: stopped short of the target", f"at {p2}")
    checks.check(wire_ms is not None, f"{label}: the stop reached the wire",
                 f"{new} emergency jobs")
    if back:
        checks.check(status == 200 and took < 8,
                     f"{label}: judged stopped once the controller answered again",
                     f"{status} after {took:.1f} s")
    if case == "offline":
        # Where the stop caught it: at most the travel since the loss began
        # until the stop was posted, and the short deceleration.
        most = SPEED * (t_posted - loss_at + 0.5) + 1.0
        travelled = (p2 - start_pos) * direction
        checks.check(travelled <= most, f"{label}: stood where the stop caught it",
                     f"travelled {travelled:.1f} mm in the loss, at most {most:.1f}")
    if case == "flood" and channel == "modbus":
        # Within two transaction times (a D0400×16 read at 38400 baud, 8N1: 21.6 ms).
        # One wall-clock sample: a host busy with make test's other tests can
        # hold the daemon's thread past it (a clean run: 66 ms once); in one
        # of two tries, as the other wall-clock bounds here. A real regression
        # (a stop queued behind the flood) fails both.
        within = wire_ms is not None and wire_ms <= 2 * 21.6
        if not within and not retried:
            print(f"{label}: {wire_ms} ms, over the bound once: a loaded host? once more", flush=True)
            return run_case(rig, checks, case, channel, retried=True)
        checks.check(within, f"{label}: the RESET on the wire within 2 transaction times",
                     f"{wire_ms} ms")
    return after


def main():
    cases = sys.argv[1:] or ["idle", "drops", "corruption", "noise", "dead-id", "flood",
                             "offline"]
    checks = Checks()
    with tempfile.TemporaryDirectory(prefix="lec6-stop-") as tmp:
        rig = Rig(tmp)
        try:
            rig.prepare()
            for case in cases:
                for channel in ("http", "mqtt", "modbus"):
                    run_case(rig, checks, case, channel)
        finally:
            rig.serve.kill()
            rig.broker.stop()
    return checks.finish()


if __name__ == "__main__":
    sys.exit(main())
