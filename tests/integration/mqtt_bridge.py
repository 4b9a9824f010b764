#!/usr/bin/python3
"""lec serve's MQTT bridge against a real mosquitto (docs/mqtt.md).

    mqtt_bridge.py SCENARIO...    (telemetry commands dedup refusals alarms
                                   flags home_assistant will outage tls)

Each scenario starts its own broker on a free loopback port and `lec serve`
on the built-in twin, and checks what a real MQTT 5 client sees."""

import os
import signal
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import mqtt_lib  # noqa: E402
from mqtt_lib import (Axis, Broker, Client, Serve, free_port, publish_props,  # noqa: E402
                      run_scenarios, wait_until)

PREFIX = "t"


def bridge(tmp, procs, broker_proc, **mqtt):
    """lec serve bridged to broker_proc; **mqtt overrides its mqtt: section."""
    cfg = {"broker": f"mqtt://127.0.0.1:{broker_proc.port}", "client_id": "lec6-test", "bridge": "box1",
           "prefix": PREFIX, "telemetry_hz": 10}
    cfg.update(mqtt)
    serve = Serve(tmp, cfg).start()
    procs.append(serve)
    return serve


def setup(tmp, procs, **mqtt):
    broker = Broker(tmp).start()
    procs.append(broker)
    serve = bridge(tmp, procs, broker, **mqtt)
    client = Client(broker.port, [f"{PREFIX}/#"])
    procs.append(client)
    client.wait_for(lambda m: m.topic == f"{PREFIX}/box1/status" and m.payload == "online", 15,
                    "bridge online")
    return broker, serve, client


def ready_axis(ck, ax):
    for op, args in [("serial", {"on": True}), ("servo", {"on": True}), ("home", {})]:
        r = ax.run(op, **args)
        ck.check(r["ok"] and r["status"] == 200, f"{op} through the broker", r)


def idle_at(serve, name):
    a = wait_until(lambda: (lambda a: a if a["operation"] is None and not a["flags"]["busy"]
                            else None)(serve.axis(name)), 20, f"{name} idle")
    return a["position_mm"]


# ---- scenarios -----------------------------------------------------------------------

def telemetry(ck, tmp, procs):
    broker, serve, cl = setup(tmp, procs)
    ck.check(f"mqtt://127.0.0.1:{broker.port}" in serve.ready_line, "ready line names the broker",
             serve.ready_line)
    state = f"{PREFIX}/line1/axis1/state"
    first = cl.wait_for(lambda m: m.topic == state, 5, "a state message")
    last = cl.wait_for(lambda m: m.topic == state and m.t >= first.t + 3.0, 10, "3 s of telemetry")
    n = sum(1 for m in cl.since(0, state) if first.t < m.t <= first.t + 3.0)
    ck.check(7 <= n / 3.0 <= 13, "state at the configured 10 Hz", f"{n / 3.0:.1f}/s")
    s = last.json()
    for key in ("position_mm", "speed_mm_s", "thrust_pct", "flags", "alarms", "online", "at"):
        ck.check(key in s, f"state has {key}", s)
    ck.check("alarm" in s.get("flags", {}) and "busy" in s.get("flags", {}), "flags", s)
    # Retained: a client arriving later is told at once.
    late = Client(broker.port, [f"{PREFIX}/box1/status", state,
                                f"{PREFIX}/line1/axis2/availability"])
    procs.append(late)
    m = late.wait_for(lambda m: m.topic.endswith("/status"), 5, "retained status")
    ck.check(m.retain and m.payload == "online", "status retained online", m.payload)
    m = late.wait_for(lambda m: m.topic == state, 5, "retained state")
    ck.check(m.retain and m.json()["name"] == "axis1", "state retained")
    m = late.wait_for(lambda m: m.topic.endswith("/availability"), 5, "retained availability")
    ck.check(m.retain and m.payload == "online", "axis availability retained online", m.payload)
    # A clean stop says offline for the bridge and each axis; exit 0.
    start = cl.mark()
    ck.check(serve.stop() == 0, "lec serve exits 0 on SIGTERM")
    cl.wait_for(lambda m: m.topic == f"{PREFIX}/box1/status" and m.payload == "offline", 10,
                "offline on stop", start)
    cl.wait_for(lambda m: m.topic == f"{PREFIX}/line1/axis2/availability" and
                m.payload == "offline", 10, "axis offline on stop", start)
    ck.check(True, "offline published on stop")


def commands(ck, tmp, procs):
    broker, serve, cl = setup(tmp, procs)
    ax = Axis(cl, PREFIX, "line1", "axis1")
    ready_axis(ck, ax)
    r = ax.run("move", position_mm=150, speed_mm_s=500)
    ck.check(r["ok"] and r["status"] == 200 and r["outcome"] == "reached", "move reached", r)
    ck.check(abs(r["position_mm"] - 150) < 0.6 and r["op"] == "move", "move result position", r)
    ck.check(abs(idle_at(serve, "axis1") - 150) < 0.6, "the axis is at 150 mm")
    # MQTT 5 request/response: the result also goes to the response topic,
    # with the correlation data.
    rep = Client(broker.port, ["replies/#"])
    procs.append(rep)
    id = ax.send("step-read", step=0, props=publish_props("replies/me", b"\x00corr-1"))
    m = rep.wait_for(lambda m: m.topic == "replies/me", 10, "reply on the response topic")
    ck.check(m.json()["id"] == id and m.json()["ok"], "response topic result", m.payload)
    ck.check(getattr(m.props, "CorrelationData", None) == b"\x00corr-1", "correlation data echoed")
    ck.check(ax.result(id)["step"]["step"] == 0, "and on .../result")
    # Another motion while one runs is refused (one motion per axis).
    start = cl.mark()
    long_id = ax.send("move", position_mm=10, speed_mm_s=20)
    busy = ax.run("move", position_mm=20)
    ck.check(busy["status"] == 409 and "busy" in busy["error"] and "mqtt id" in busy["error"],
             "a second motion is refused 409", busy)
    ck.check(ax.run("stop")["ok"], "stop goes at once")
    ended = ax.result(long_id, start=start)
    ck.check(ended["outcome"] == "stopped" and not ended["ok"], "the move ends stopped", ended)


def dedup(ck, tmp, procs):
    broker, serve, cl = setup(tmp, procs)
    ax = Axis(cl, PREFIX, "line1", "axis1")
    ready_axis(ck, ax)
    p0 = idle_at(serve, "axis1")
    cmd = {"id": "inc-1", "op": "move", "position_mm": 10, "relative": True, "speed_mm_s": 200}
    start = cl.mark()
    cl.publish(f"{ax.base}/cmd", cmd)  # the same command twice, as a QoS 1 redelivery would
    cl.publish(f"{ax.base}/cmd", cmd)
    first = ax.result("inc-1", start=start)
    ck.check(first["ok"] and abs(first["position_mm"] - (p0 + 10)) < 0.6, "INC move done", first)
    ax.run("step-read", step=0)  # a barrier: the bridge has handled both copies
    results = [m for m in cl.since(start, f"{ax.base}/result") if m.json().get("id") == "inc-1"]
    ck.check(len(results) == 1, "one result for the id sent twice", len(results))
    ck.check(abs(idle_at(serve, "axis1") - (p0 + 10)) < 0.6, "moved once: +10 mm, not +20")
    # Sent again after it finished: the earlier result, and nothing on the line.
    before = serve.client_requests()
    start = cl.mark()
    cl.publish(f"{ax.base}/cmd", cmd)
    again = cl.wait_for(lambda m: m.topic == f"{ax.base}/result" and m.json()["id"] == "inc-1", 10,
                        "republished result", start)
    ck.check(again.payload == results[0].payload, "the earlier result, republished as it was")
    ck.check(serve.client_requests() == before, "a repeat reaches nothing on the line")
    ck.check(abs(idle_at(serve, "axis1") - (p0 + 10)) < 0.6, "still +10 mm")


def refusals(ck, tmp, procs):
    broker, serve, cl = setup(tmp, procs)
    ax = Axis(cl, PREFIX, "line1", "axis1")
    ready_axis(ck, ax)
    p0 = idle_at(serve, "axis1")
    before = serve.client_requests()
    # Stale: issued a minute ago; an expiry longer than valid_for.
    r = ax.run("move", position_mm=100, issued_at=time.time() - 60)
    ck.check(not r["ok"] and r["status"] == 408 and r["field"] == "issued_at", "stale refused", r)
    r = ax.run("move", position_mm=100, props=publish_props(expiry=3600))
    ck.check(r["status"] == 408 and r["field"] == "message_expiry", "long expiry refused", r)
    # Bad payloads: an error naming the field.
    cases = [
        ("not json", None, ""),
        ('{"op": "stop"}', None, "id"),
        ('{"id": "b1", "op": "fly"}', "b1", "op"),
        ('{"id": "b2", "op": "move", "position_mm": 150, "speed_mm_s": 70000}', "b2", "speed_mm_s"),
        ('{"id": "b3", "op": "move", "position_mm": 150, "colour": 1}', "b3", "colour"),
        ('{"id": "b4", "op": "servo"}', "b4", "on"),
        ('{"id": "b5", "op": "jog", "direction": "up", "lease_ms": 500}', "b5", "direction"),
        ('{"id": "b6", "op": "stop", "valid_for": -1}', "b6", "valid_for"),
    ]
    for payload, id, field in cases:
        start = cl.mark()
        cl.publish(f"{ax.base}/cmd", payload)
        m = cl.wait_for(lambda m: m.topic == f"{ax.base}/result" and m.json()["id"] == id, 10,
                        f"error result for {payload}", start)
        r = m.json()
        ck.check(r["ok"] is False and r["status"] == 400 and r.get("field", "") == field and
                 r["error"], f"bad payload {payload} names '{field}'", r)
    # Retained: refused, and deleted from the broker.
    start = cl.mark()
    cl.publish(f"{ax.base}/cmd", {"id": "r1", "op": "stop"}, retain=True)
    r = ax.result("r1", start=start)
    ck.check(r["status"] == 400 and r["field"] == "retain", "retained command refused", r)
    probe = Client(broker.port, [f"{ax.base}/cmd", "probe/marker"])
    procs.append(probe)
    probe.publish("probe/marker", "x")  # after the subscription: a retained cmd would come first
    probe.wait_for(lambda m: m.topic == "probe/marker", 5, "marker")
    ck.check(not [m for m in probe.since(0, f"{ax.base}/cmd") if m.payload],
             "the retained command was deleted from the broker")
    ck.check(serve.client_requests() == before, "the line saw none of them",
             f"{before} -> {serve.client_requests()}")
    ck.check(abs(idle_at(serve, "axis1") - p0) < 0.6, "the axis did not move")
    # Fresh ones go: issued_at now, an expiry within valid_for.
    r = ax.run("step-read", step=1, issued_at=time.time(), valid_for=5)
    ck.check(r["ok"], "issued_at now runs", r)
    r = ax.run("step-read", step=1, props=publish_props(expiry=4))
    ck.check(r["ok"], "an expiry within valid_for runs", r)


def alarms(ck, tmp, procs):
    broker, serve, cl = setup(tmp, procs)
    ax = Axis(cl, PREFIX, "line1", "axis1")
    ready_axis(ck, ax)
    start = cl.mark()
    r = ax.run("move", position_mm=450)  # beyond the twin's 400 mm stroke
    ck.check(not r["ok"], "a move beyond the stroke fails", r)
    ev = cl.wait_for(lambda m: m.topic == f"{ax.base}/alarm" and m.json()["event"] == "raised", 10,
                     "alarm event", start).json()
    ck.check(ev["code"] > 0 and "stroke" in ev["meaning"] and ev["axis"] == "axis1",
             "alarm event with code and meaning", ev)
    st = cl.wait_for(lambda m: m.topic == f"{ax.base}/state" and m.json()["alarms"], 10,
                     "state with the alarm", start).json()
    ck.check(st["flags"]["alarm"] and st["alarms"][0]["code"] == ev["code"], "state shows it", st)
    ck.check(ax.run("reset")["ok"], "reset")
    ev = cl.wait_for(lambda m: m.topic == f"{ax.base}/alarm" and m.json()["event"] == "cleared", 10,
                     "cleared event", start).json()
    ck.check(ev["code"] == st["alarms"][0]["code"], "alarm cleared event", ev)
    # A controller that stops answering: its availability goes offline, then back.
    av = f"{PREFIX}/line1/axis2/availability"
    start = cl.mark()
    serve.http("POST", "/api/lines/line1/twin", {"drop_rate": 1.0})
    cl.wait_for(lambda m: m.topic == av and m.payload == "offline", 20, "axis offline", start)
    ck.check(True, "axis availability offline when it stops answering")
    serve.http("POST", "/api/lines/line1/twin", {"drop_rate": 0.0})
    cl.wait_for(lambda m: m.topic == av and m.payload == "online", 20, "axis online", start)
    ck.check(True, "and online again")


def flags(ck, tmp, procs):
    # A state every 5 s; a flag change must not wait for it.
    broker, serve, cl = setup(tmp, procs, telemetry_hz=0.2)
    ax = Axis(cl, PREFIX, "line1", "axis1")
    ax.run("serial", on=True)
    state = f"{ax.base}/state"
    for on in (True, False, True):
        start = cl.mark()
        r = ax.run("servo", on=on)
        m = cl.wait_for(lambda m: m.topic == state and m.json()["flags"]["svre"] == on, 10,
                        f"state with svre={on}", start)
        lag = m.t - cl.since(start, f"{ax.base}/result")[0].t
        ck.check(r["ok"] and lag < 1.0, f"SVRE={int(on)} published at once", f"{lag:.2f} s")


def home_assistant(ck, tmp, procs):
    broker, serve, cl = setup(tmp, procs, home_assistant=True)
    ha = Client(broker.port, ["homeassistant/#"])
    procs.append(ha)
    node = "homeassistant/{}/t_line1_axis1/{}/config"
    want = [node.format("sensor", k) for k in ("position_mm", "speed_mm_s", "thrust_pct")] + \
        [node.format("binary_sensor", k) for k in ("busy", "inp", "svre", "seton", "alarm", "estop")] + \
        [node.format("button", k) for k in ("home", "stop")]
    for topic in want:
        ha.wait_for(lambda m: m.topic == topic, 10, topic)
    # Published at connect, possibly while `ha` subscribed (then live, retain
    # flag 0): a subscriber that comes now must get every one from the broker.
    later = Client(broker.port, ["homeassistant/#"])
    procs.append(later)
    for topic in want:
        m = later.wait_for(lambda m: m.topic == topic, 10, topic)
        ck.check(m.retain and m.json()["device"]["identifiers"] == ["t_line1_axis1"],
                 f"discovery {topic}")
    home = ha.wait_for(lambda m: m.topic == node.format("button", "home"), 1, "home").json()
    ax = Axis(cl, PREFIX, "line1", "axis1")
    ax.run("serial", on=True)
    ax.run("servo", on=True)
    # What Home Assistant sends on a press: the template with now() rendered.
    payload = home["command_template"].replace("{{ now().timestamp() }}", str(time.time()))
    start = cl.mark()
    cl.publish(home["command_topic"], payload)
    r = cl.wait_for(lambda m: m.topic == f"{ax.base}/result", 30, "home result", start).json()
    ck.check(r["ok"] and r["op"] == "home", "the Home button homes", r)


def will(ck, tmp, procs):
    broker, serve, cl = setup(tmp, procs, keepalive_s=5)
    status = f"{PREFIX}/box1/status"
    # A box that hangs (SIGSTOP): the broker gives up after 1.5 × keepalive
    # and publishes the will; when it resumes it reconnects and is online again.
    start = cl.mark()
    serve.signal(signal.SIGSTOP)
    cl.wait_for(lambda m: m.topic == status and m.payload == "offline", 20, "will on a hang",
                start)
    ck.check(True, "the last will says offline when the box hangs")
    start = cl.mark()
    serve.signal(signal.SIGCONT)
    cl.wait_for(lambda m: m.topic == status and m.payload == "online", 30, "online again", start)
    ax = Axis(cl, PREFIX, "line1", "axis1")
    ck.check(ax.run("step-read", step=0)["ok"], "commands work after the reconnect")
    # A box that dies (kill -9): the will again.
    start = cl.mark()
    serve.kill()
    m = cl.wait_for(lambda m: m.topic == status, 20, "will on kill -9", start)
    ck.check(m.payload == "offline", "the last will says offline when lec serve dies", m.payload)


def outage(ck, tmp, procs):
    broker, serve, cl = setup(tmp, procs)
    ax = Axis(cl, PREFIX, "line1", "axis1")
    ready_axis(ck, ax)
    cl.close()
    broker.kill()
    # The broker is gone: the line keeps polling, HTTP answers at once.
    wait_until(lambda: "lost the broker" in serve.stderr(), 10, "the bridge notices")
    t0 = serve.transactions()
    wait_until(lambda: serve.transactions() > t0 + 50, 10, "polling goes on without the broker")
    t = time.monotonic()
    ck.check(serve.axis("axis1")["online"], "the axis is online over HTTP")
    ck.check(time.monotonic() - t < 1.0, "HTTP answers at once meanwhile")
    ck.check(serve.http("POST", "/api/axes/axis1/step-read", {"step": 0})[0] == 200,
             "commands over HTTP work meanwhile")
    # Back: the bridge reconnects (back-off), republishes its retained state,
    # telemetry and commands resume.
    broker.start()
    late = Client(broker.port, [f"{PREFIX}/#"])
    procs.append(late)
    late.wait_for(lambda m: m.topic == f"{PREFIX}/box1/status" and m.payload == "online", 40,
                  "online after the broker restarts")
    # A subscriber that was there before the bridge came back gets live
    # messages (retain flag 0); one that subscribes now gets what the broker
    # retained: the bridge's republished state.
    later = Client(broker.port, [f"{PREFIX}/line1/axis1/state"])
    procs.append(later)
    m = later.wait_for(lambda m: m.topic == f"{PREFIX}/line1/axis1/state" and m.retain, 10,
                       "retained state republished")
    ck.check(m.json()["name"] == "axis1", "retained state is back after the restart")
    first = late.wait_for(lambda m: m.topic == f"{PREFIX}/line1/axis2/state", 5, "telemetry")
    late.wait_for(lambda m: m.topic == f"{PREFIX}/line1/axis2/state" and m.t > first.t + 1, 5,
                  "a second of telemetry")
    n = sum(1 for m in late.since(0, f"{PREFIX}/line1/axis2/state")
            if first.t < m.t <= first.t + 1)
    ck.check(5 <= n <= 15, "telemetry resumed at rate", n)
    ax = Axis(late, PREFIX, "line1", "axis1")
    r = ax.run("move", position_mm=20, relative=True)
    ck.check(r["ok"] and r["outcome"] == "reached", "a move after the outage", r)


def tls(ck, tmp, procs):
    ca_key, ca, key, csr, crt = (os.path.join(tmp, f) for f in
                                 ("ca.key", "ca.crt", "srv.key", "srv.csr", "srv.crt"))
    ext = os.path.join(tmp, "san.ext")
    with open(ext, "w") as f:
        f.write("subjectAltName=IP:127.0.0.1,DNS:localhost\n")
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "check": True}
    subprocess.run(["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "2",
                    "-subj", "/CN=lec6 test CA", "-keyout", ca_key, "-out", ca], **quiet)
    subprocess.run(["openssl", "req", "-newkey", "rsa:2048", "-nodes", "-subj", "/CN=127.0.0.1",
                    "-keyout", key, "-out", csr], **quiet)
    subprocess.run(["openssl", "x509", "-req", "-in", csr, "-CA", ca, "-CAkey", ca_key,
                    "-CAcreateserial", "-days", "2", "-extfile", ext, "-out", crt], **quiet)
    passwords = os.path.join(tmp, "passwd")
    subprocess.run(["mosquitto_passwd", "-c", "-b", passwords, "cell7", "s3cret"], **quiet)
    port = free_port()
    broker = Broker(tmp, port=port, extra=f"certfile {crt}\nkeyfile {key}\n"
                    f"allow_anonymous false\npassword_file {passwords}").start()
    procs.append(broker)
    serve = bridge(tmp, procs, broker, broker=f"mqtts://127.0.0.1:{port}", ca_file=ca,
                   username="cell7", password="s3cret")
    cl = Client(port, [f"{PREFIX}/#"], tls=ca, auth=("cell7", "s3cret"))
    procs.append(cl)
    cl.wait_for(lambda m: m.topic == f"{PREFIX}/box1/status" and m.payload == "online", 15,
                "online over TLS")
    ck.check(True, "the bridge connects over TLS with a password")
    ax = Axis(cl, PREFIX, "line1", "axis1")
    ck.check(ax.run("step-read", step=0)["ok"], "a command over TLS")
    serve.stop()
    # A wrong password: refused, said so, and retried (never a crash).
    bad = Serve(tmp, {"broker": f"mqtts://127.0.0.1:{port}", "ca_file": ca, "username": "cell7",
                      "password": "wrong", "client_id": "lec6-bad", "prefix": PREFIX},
                name="bad").start()
    procs.append(bad)
    wait_until(lambda: "refused the connection" in bad.stderr(), 15, "refusal logged")
    ck.check("Not authorized" in bad.stderr() or "not authorised" in bad.stderr().lower(),
             "the refusal names the reason", bad.stderr())
    ck.check(bad.http("GET", "/api/axes/axis1")[0] == 200, "and the daemon serves on")


def command_line(ck, tmp, procs):
    """`lec serve --port sim --ids 1-2 --mqtt URL`: the bridge without a config file."""
    bad = subprocess.run([mqtt_lib.LEC, "--port", "sim", "serve", "--mqtt", "ftp://x", "--check"],
                         capture_output=True, text=True, timeout=30)
    ck.check(bad.returncode == 2 and "--mqtt:" in bad.stderr, "a bad --mqtt URL is a usage error",
             bad.stderr)
    bad = subprocess.run([mqtt_lib.LEC, "--port", "sim", "serve", "--mqtt", "mqtt://127.0.0.1",
                          "--mqtt-prefix", "a/#", "--check"], capture_output=True, text=True, timeout=30)
    ck.check(bad.returncode == 2 and "--mqtt-prefix:" in bad.stderr, "a bad prefix is refused",
             bad.stderr)
    broker = Broker(tmp).start()
    procs.append(broker)
    cl = Client(broker.port, ["flagsbox/#"])
    procs.append(cl)
    p = subprocess.Popen([mqtt_lib.LEC, "--port", "sim", "serve", "--ids", "1-2", "--http", "",
                          "--modbus-tcp", "", "--mqtt", f"mqtt://127.0.0.1:{broker.port}",
                          "--mqtt-prefix", "flagsbox"],
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        m = cl.wait_for(lambda m: m.topic == "flagsbox/line1/axis2/state", 15, "state of axis2")
        ck.check(m.json()["id"] == 2, "telemetry from a bridge set up by flags", m.payload)
        ax = Axis(cl, "flagsbox", "line1", "axis1")
        r = ax.run("serial", on=True)
        ck.check(r["ok"], "and it takes commands", r)
    finally:
        p.terminate()
        p.wait(20)


SCENARIOS = {f.__name__: f for f in (telemetry, commands, dedup, refusals, alarms, flags,
                                     home_assistant, will, outage, tls, command_line)}

if __name__ == "__main__":
    run_scenarios(SCENARIOS, sys.argv[1:] or list(SCENARIOS))
