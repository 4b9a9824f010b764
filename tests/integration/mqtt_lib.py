"""Shared pieces of the MQTT bridge tests: Debian's mosquitto on a loopback
port chosen here, `lec serve` on its built-in twin, and a paho-mqtt (MQTT 5)
client that records every message. Every wait is on an event with a deadline.

Run by Debian's /usr/bin/python3 (python3-paho-mqtt)."""

import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request

import paho.mqtt.client as mqtt
from paho.mqtt.packettypes import PacketTypes
from paho.mqtt.properties import Properties

LEC = os.environ.get("LEC", "build/lec")
MOSQUITTO = "/usr/sbin/mosquitto"


class Timeout(Exception):
    pass


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_until(pred, timeout, what):
    """Polls `pred` (a state we cannot be told about, e.g. over HTTP) until
    it is true or the deadline passes."""
    deadline = time.monotonic() + timeout
    while True:
        value = pred()
        if value:
            return value
        if time.monotonic() > deadline:
            raise Timeout(what)
        time.sleep(0.02)


class Checks:
    def __init__(self):
        self.passed = 0
        self.failed = 0

    def check(self, cond, what, detail=""):
        if cond:
            self.passed += 1
        else:
            self.failed += 1
            print(f"FAIL: {what} {detail}", flush=True)
        return cond

    def finish(self):
        print(f"{self.passed} passed, {self.failed} failed", flush=True)
        return 0 if self.failed == 0 and self.passed > 0 else 1


class Broker:
    """mosquitto with a generated config, on 127.0.0.1:<port>."""

    def __init__(self, tmp, port=None, extra="", name="broker"):
        self.tmp = tmp
        self.port = port or free_port()
        self.extra = extra
        self.name = name
        self.proc = None
        self.conf = os.path.join(tmp, f"{name}.conf")
        with open(self.conf, "w") as f:
            f.write(self.config())

    def config(self):
        # Started as root, mosquitto would switch to the user `mosquitto`, who
        # cannot read the password file and certificates in our private temp
        # directory: stay the user who started it.
        user = "user root\n" if os.geteuid() == 0 else ""
        # Without it the broker's small packets wait on Nagle's algorithm and the
        # peer's delayed ACK (~40 ms per command round trip).
        user += "set_tcp_nodelay true\n"
        if self.extra:
            return f"{user}listener {self.port} 127.0.0.1\n{self.extra}\npersistence false\n"
        return f"{user}listener {self.port} 127.0.0.1\nallow_anonymous true\npersistence false\n"

    def start(self):
        log = open(os.path.join(self.tmp, f"{self.name}.log"), "ab")
        self.proc = subprocess.Popen([MOSQUITTO, "-c", self.conf], stdout=log, stderr=log)

        def listening():
            if self.proc.poll() is not None:
                raise RuntimeError(f"mosquitto exited {self.proc.returncode}: {self.log()}")
            try:
                socket.create_connection(("127.0.0.1", self.port), timeout=0.2).close()
                return True
            except OSError:
                return False

        wait_until(listening, 10, "mosquitto listening")
        return self

    def kill(self):
        self.proc.kill()
        self.proc.wait()

    def stop(self):
        if self.proc and self.proc.poll() is None:
            self.proc.terminate()
            self.proc.wait(10)

    def log(self):
        with open(os.path.join(self.tmp, f"{self.name}.log"), errors="replace") as f:
            return f.read()


def serve_yaml(mqtt_cfg, http_port, lines=1, ids=(1, 2), axis_hz=20, probe_ms=200):
    out = ["lines:"]
    for n in range(1, lines + 1):
        axes = ", ".join(
            f"{{id: {i}, name: l{n}a{i}, telemetry_hz: {axis_hz}}}" if lines > 1 else
            f"{{id: {i}, name: axis{i}, telemetry_hz: {axis_hz}}}" for i in ids)
        out += [f"  - name: line{n}", "    port: sim", "    sim: {timing: fast}",
                f"    probe_interval_ms: {probe_ms}", f"    axes: [{axes}]"]
    out.append(f'http: {{listen: "127.0.0.1:{http_port}"}}')
    if mqtt_cfg is not None:  # None: no bridge (benchmark baseline)
        out.append("mqtt:")
        for k, v in mqtt_cfg.items():
            out.append(f"  {k}: {json.dumps(v)}")
    return "\n".join(out) + "\n"


class Serve:
    """`lec serve --config` with HTTP on a free port; waits for its ready line."""

    def __init__(self, tmp, mqtt_cfg, name="serve", **yaml_args):
        self.tmp = tmp
        self.name = name
        self.http_port = free_port()
        self.config = os.path.join(tmp, f"{name}.yaml")
        with open(self.config, "w") as f:
            f.write(serve_yaml(mqtt_cfg, self.http_port, **yaml_args))
        self.err_path = os.path.join(tmp, f"{name}.err")
        self.proc = None

    def start(self):
        err = open(self.err_path, "ab")
        self.proc = subprocess.Popen([LEC, "serve", "--config", self.config],
                                     stdout=subprocess.PIPE, stderr=err, text=True)
        ready = threading.Event()
        self.ready_line = None

        def read():
            for line in self.proc.stdout:
                if "ready" in line and not ready.is_set():
                    self.ready_line = line.strip()
                    ready.set()

        threading.Thread(target=read, daemon=True).start()
        if not ready.wait(30):
            raise Timeout(f"lec serve ready line; stderr: {self.stderr()}")
        return self

    def stderr(self):
        with open(self.err_path, errors="replace") as f:
            return f.read()

    def http(self, method, path, body=None):
        data = None if body is None else json.dumps(body).encode()
        req = urllib.request.Request(f"http://127.0.0.1:{self.http_port}{path}", data=data,
                                     method=method)
        try:
            with urllib.request.urlopen(req, timeout=30) as r:
                return r.status, json.loads(r.read() or b"null")
        except urllib.error.HTTPError as e:
            return e.code, json.loads(e.read() or b"null")

    def axis(self, name):
        return self.http("GET", f"/api/axes/{name}")[1]

    def client_requests(self, line=0):
        """Requests that reached the line from clients (all but telemetry and
        background reads)."""
        prio = self.http("GET", "/api/lines")[1][line]["stats"]["priorities"]
        return sum(prio[p]["count"] for p in ("emergency", "command", "completion"))

    def transactions(self, line=0):
        return self.http("GET", "/api/lines")[1][line]["stats"]["transactions"]

    def signal(self, sig):
        self.proc.send_signal(sig)

    def stop(self, timeout=20):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
        return self.proc.wait(timeout)

    def kill(self):
        if self.proc and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()


class Msg:
    def __init__(self, m):
        self.t = time.monotonic()
        self.topic = m.topic
        self.payload = m.payload.decode(errors="replace")
        self.retain = bool(m.retain)
        self.props = m.properties

    def json(self):
        return json.loads(self.payload)


class Client:
    """A paho-mqtt MQTT 5 client recording every message it receives."""

    def __init__(self, port, subscribe=(), tls=None, auth=None, name="checker"):
        self.msgs = []
        self.cv = threading.Condition()
        self.connected = threading.Event()
        # Set when the broker acknowledged every subscription (SUBACK): a
        # message published before that is not delivered to this client (CI:
        # a reply on a response topic missed by a checker made a moment before).
        self.subscribed = threading.Event()
        self.unacked = set()
        self.subscriptions = list(subscribe)
        self.c = mqtt.Client(client_id=f"{name}-{os.getpid()}-{time.monotonic_ns()}",
                             protocol=mqtt.MQTTv5)
        if tls:
            self.c.tls_set(ca_certs=tls)
        if auth:
            self.c.username_pw_set(*auth)
        self.c.on_connect = self._on_connect
        self.c.on_message = self._on_message
        self.c.on_subscribe = self._on_subscribe
        self.c.connect("127.0.0.1", port)
        # paho leaves Nagle's algorithm on: a command published right after a
        # PUBACK would wait for the broker's delayed ACK (~40 ms). A plant's
        # client should do the same.
        self.c.socket().setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.c.loop_start()
        if not self.connected.wait(10):
            raise Timeout("test client connected")
        if not self.subscribed.wait(10):
            raise Timeout(f"test client's subscriptions acknowledged: {self.subscriptions}")

    def _on_connect(self, c, userdata, flags, rc, props=None):
        self.unacked = set()
        for t in self.subscriptions:
            _, mid = c.subscribe(t, qos=1)
            self.unacked.add(mid)
        if not self.unacked:
            self.subscribed.set()
        self.connected.set()

    def _on_subscribe(self, c, userdata, mid, *granted):
        self.unacked.discard(mid)
        if not self.unacked:
            self.subscribed.set()

    def _on_message(self, c, userdata, m):
        with self.cv:
            self.msgs.append(Msg(m))
            self.cv.notify_all()

    def wait_for(self, pred, timeout, what, start=0):
        """The first message from index `start` on for which pred(msg) holds."""
        deadline = time.monotonic() + timeout
        i = start
        with self.cv:
            while True:
                while i < len(self.msgs):
                    m = self.msgs[i]
                    i += 1
                    try:
                        if pred(m):
                            return m
                    except (ValueError, KeyError, TypeError):
                        pass
                left = deadline - time.monotonic()
                if left <= 0:
                    raise Timeout(what)
                self.cv.wait(left)

    def mark(self):
        with self.cv:
            return len(self.msgs)

    def since(self, start, topic=None):
        with self.cv:
            return [m for m in self.msgs[start:] if topic is None or m.topic == topic]

    def publish(self, topic, payload, qos=1, retain=False, props=None):
        if isinstance(payload, (dict, list)):
            payload = json.dumps(payload)
        info = self.c.publish(topic, payload, qos=qos, retain=retain, properties=props)
        info.wait_for_publish(10)

    def close(self):
        self.c.loop_stop()
        self.c.disconnect()


def publish_props(response_topic=None, correlation=None, expiry=None):
    p = Properties(PacketTypes.PUBLISH)
    if response_topic:
        p.ResponseTopic = response_topic
    if correlation is not None:
        p.CorrelationData = correlation
    if expiry is not None:
        p.MessageExpiryInterval = expiry
    return p


class Axis:
    """Commands to one axis through the broker, results matched by id."""

    def __init__(self, client, prefix, line, axis):
        self.client = client
        self.base = f"{prefix}/{line}/{axis}"
        self.n = 0

    def send(self, op, id=None, props=None, retain=False, **args):
        self.n += 1
        id = id or f"{op}-{self.n}-{time.monotonic_ns()}"
        self.client.publish(f"{self.base}/cmd", {"id": id, "op": op, **args}, props=props,
                            retain=retain)
        return id

    def result(self, id, timeout=30, start=0):
        return self.client.wait_for(
            lambda m: m.topic == f"{self.base}/result" and m.json().get("id") == id,
            timeout, f"result of {id} on {self.base}/result", start).json()

    def run(self, op, timeout=30, **args):
        start = self.client.mark()
        id = self.send(op, **args)
        return self.result(id, timeout, start)


def run_scenarios(scenarios, names):
    """Runs the named scenarios, each with its own temp dir; a timeout or
    crash fails that scenario and the next one runs."""
    import tempfile
    import traceback
    checks = Checks()
    for name in names:
        print(f"== {name}", flush=True)
        with tempfile.TemporaryDirectory() as tmp:
            procs = []
            try:
                scenarios[name](checks, tmp, procs)
            except Exception as e:  # noqa: BLE001 - every failure is reported
                checks.check(False, f"{name}: {type(e).__name__}: {e}")
                traceback.print_exc()
                for p in procs:
                    if isinstance(p, Serve):
                        print(f"--- {p.name} stderr:\n{p.stderr()}", flush=True)
            finally:
                for p in reversed(procs):
                    try:
                        if isinstance(p, Serve):
                            p.kill()
                        elif isinstance(p, Broker):
                            p.stop()
                        elif isinstance(p, Client):
                            p.close()
                    except Exception:  # noqa: BLE001
                        pass
    sys.exit(checks.finish())
