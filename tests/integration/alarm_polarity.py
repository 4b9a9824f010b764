#!/usr/bin/python3
"""ALARM polarity in lec serve (issue 33): a twin whose controller reports X4F
inverted (profile key alarm_polarity: active-low) behind a `port: sim` line.

    alarm_polarity.py SCENARIO...    (inverted unset)

inverted: the line says `alarm_polarity: active-low`. No alarm is reported
while there is none (HTTP, SSE, retained MQTT state), motions work (the
operations read X4F with it), and an alarm, when one comes, is reported
everywhere: the move's result, HTTP status and alarms, SSE, MQTT state and
alarm event, the move history's record and the odometer's alarm count.
unset: the same twin without the key shows an alarm at rest (what the
setting fixes: the test can fail), and a bad value is a config error."""

import json
import os
import subprocess
import sys
import threading
import urllib.request

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mqtt_lib import LEC, Broker, Client, Serve, run_scenarios, wait_until  # noqa: E402

PREFIX = "t"


def config_text(tmp, broker_port, http_port, polarity_line):
    profile = os.path.join(tmp, "active-low.yaml")
    with open(profile, "w") as f:
        f.write("name: active-low\nactuator:\n  alarm_polarity: active-low\n")
    return "\n".join([
        "lines:",
        "  - name: line1",
        "    port: sim",
        f"    sim: {{timing: fast, profile: {json.dumps(profile)}}}",
        *([f"    {polarity_line}"] if polarity_line else []),
        "    axes: [{id: 1, name: axis1, telemetry_hz: 20}]",
        f'http: {{listen: "127.0.0.1:{http_port}"}}',
        "mqtt:",
        f'  broker: "mqtt://127.0.0.1:{broker_port}"',
        f"  prefix: {PREFIX}",
        "  bridge: box1",
        "  telemetry_hz: 10",
        "history:",
        f"  state_dir: {json.dumps(os.path.join(tmp, 'state'))}",
    ]) + "\n"


def start(tmp, procs, polarity_line):
    broker = Broker(tmp).start()
    procs.append(broker)
    serve = Serve(tmp, {})
    with open(serve.config, "w") as f:
        f.write(config_text(tmp, broker.port, serve.http_port, polarity_line))
    serve.start()
    procs.append(serve)
    client = Client(broker.port, [f"{PREFIX}/#"])
    procs.append(client)
    client.wait_for(lambda m: m.topic == f"{PREFIX}/box1/status" and m.payload == "online", 15,
                    "bridge online")
    return serve, client


class Events:
    """GET /api/events read on a thread: the telemetry events of axis1."""

    def __init__(self, serve):
        self.telemetry = []
        self.lock = threading.Lock()
        self.resp = urllib.request.urlopen(f"http://127.0.0.1:{serve.http_port}/api/events",
                                           timeout=60)
        threading.Thread(target=self.read, daemon=True).start()

    def read(self):
        event = None
        try:
            for raw in self.resp:
                line = raw.decode().rstrip("\n")
                if line.startswith("event: "):
                    event = line[7:]
                elif line.startswith("data: ") and event == "telemetry":
                    d = json.loads(line[6:])
                    if d.get("name") == "axis1" and "flags" in d:
                        with self.lock:
                            self.telemetry.append(d)
        except Exception:  # noqa: BLE001 - the stream ends with the daemon
            pass

    def seen(self, pred):
        with self.lock:
            return next((d for d in self.telemetry if pred(d)), None)


def with_flags(serve):
    return wait_until(lambda: (lambda a: a if "flags" in a and a.get("alarm_history") is not None
                               else None)(serve.axis("axis1")), 15, "axis1 read")


def inverted(ck, tmp, procs):
    serve, cl = start(tmp, procs, "alarm_polarity: active-low")
    events = Events(serve)
    a = with_flags(serve)
    ck.check(a["alarm_polarity"] == "active-low", "the status names the polarity", a)
    ck.check(not a["flags"]["alarm"] and a["alarms"] == [], "HTTP: no alarm at rest", a)
    state = f"{PREFIX}/line1/axis1/state"
    m = cl.wait_for(lambda m: m.topic == state, 10, "a state message")
    ck.check(not m.json()["flags"]["alarm"] and m.json()["alarms"] == [], "MQTT: no alarm at rest",
             m.payload)
    wait_until(lambda: events.seen(lambda d: True), 10, "an SSE telemetry event")
    ck.check(events.seen(lambda d: d["flags"]["alarm"]) is None, "SSE: no alarm at rest")
    for op, body in [("serial", {"on": True}), ("servo", {"on": True}), ("home", {})]:
        status, r = serve.http("POST", f"/api/axes/axis1/{op}", body)
        ck.check(status == 200, f"{op} works (its wait reads X4F with the polarity)", r)
    status, r = serve.http("POST", "/api/axes/axis1/move", {"position_mm": 150, "speed_mm_s": 500})
    ck.check(status == 200 and r.get("outcome") == "reached", "a move reaches its target", r)

    mark = cl.mark()
    status, r = serve.http("POST", "/api/axes/axis1/move", {"position_mm": 450})  # beyond 400 mm
    ck.check(status >= 400 and r.get("outcome") == "alarm" and r.get("alarms"),
             "a move beyond the stroke ends in an alarm", r)
    code = r["alarms"][0]["code"] if r.get("alarms") else -1
    a = wait_until(lambda: (lambda a: a if a["alarms"] else None)(serve.axis("axis1")), 10,
                   "HTTP alarms")
    ck.check(a["flags"]["alarm"] and a["alarms"][0]["code"] == code, "HTTP: the alarm", a)
    ev = cl.wait_for(lambda m: m.topic == f"{PREFIX}/line1/axis1/alarm" and
                     m.json()["event"] == "raised", 10, "MQTT alarm event", mark).json()
    ck.check(ev["code"] == code, "MQTT: the alarm event", ev)
    st = cl.wait_for(lambda m: m.topic == state and m.json()["alarms"], 10, "MQTT state", mark)
    ck.check(st.json()["flags"]["alarm"], "MQTT: the state's ALARM", st.payload)
    sse = wait_until(lambda: events.seen(lambda d: d["flags"]["alarm"]), 10, "SSE alarm")
    ck.check(sse is not None, "SSE: the telemetry's ALARM", sse)
    hist = wait_until(lambda: (lambda h: h if h.get("records") else None)(
        serve.http("GET", "/api/axes/axis1/history")[1]), 10, "history records")
    outcomes = [rec["outcome"] for rec in hist["records"]]
    ck.check(outcomes[0] == "alarm" and hist["records"][0]["alarms"] == [code],
             "history: the last move ended in the alarm", outcomes)
    ck.check(all(o != "alarm" for o in outcomes[1:]), "history: no other record has one", outcomes)
    health = wait_until(lambda: (lambda h: h if h.get("odometer", {}).get("alarms") else None)(
        serve.http("GET", "/api/axes/axis1/health")[1]), 10, "odometer alarms")
    ck.check(health["odometer"]["alarms"] == 1, "odometer: one alarm", health["odometer"])

    status, r = serve.http("POST", "/api/axes/axis1/reset", {})
    ck.check(status == 200, "RESET clears it", r)
    a = wait_until(lambda: (lambda a: a if not a["flags"]["alarm"] else None)(serve.axis("axis1")),
                   10, "HTTP alarm gone")
    ck.check(a["alarms"] == [], "HTTP: no alarm after RESET", a)


def unset(ck, tmp, procs):
    serve, _ = start(tmp, procs, None)
    a = with_flags(serve)
    ck.check(a["alarm_polarity"] == "active-high", "the default polarity is the manual's", a)
    ck.check(a["flags"]["alarm"], "without the setting the inverted twin reads as an alarm", a)
    serve.stop()
    bad = os.path.join(tmp, "bad.yaml")
    with open(bad, "w") as f:
        f.write("lines:\n  - port: sim\n    axes: [{id: 1, alarm_polarity: inverted}]\n")
    p = subprocess.run([LEC, "serve", "--config", bad, "--check"], capture_output=True, text=True,
                       timeout=20)
    ck.check(p.returncode == 2 and "lines[0].axes[0].alarm_polarity: 'inverted' is not an alarm "
             "polarity" in p.stderr and "bad.yaml:3" in p.stderr, "a bad value is a config error",
             p.stderr)


if __name__ == "__main__":
    run_scenarios({"inverted": inverted, "unset": unset}, sys.argv[1:] or ["inverted", "unset"])
