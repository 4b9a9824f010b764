// What the Sparkplug host's scenarios share: a mosquitto on a free loopback
// port, `lec serve` on the built-in twin with a sparkplug: section, and a
// host application (npm mqtt + sparkplug-payload, Eclipse Tahu's JS codec)
// that records every message of the node, decoded.

import { spawn } from 'node:child_process';
import fs from 'node:fs';
import net from 'node:net';
import os from 'node:os';
import path from 'node:path';
import mqtt from 'mqtt';
import sparkplug from 'sparkplug-payload';

export const sp = sparkplug.get('spBv1.0');
export const LEC = process.env.LEC ?? path.resolve('build/lec');
const MOSQUITTO = fs.existsSync('/usr/sbin/mosquitto') ? '/usr/sbin/mosquitto' : 'mosquitto';

export function sleep(ms) {
  return new Promise((r) => setTimeout(r, ms));
}

export async function freePort() {
  return new Promise((resolve, reject) => {
    const s = net.createServer();
    s.listen(0, '127.0.0.1', () => {
      const { port } = s.address();
      s.close(() => resolve(port));
    });
    s.on('error', reject);
  });
}

export function tmpdir() {
  return fs.mkdtempSync(path.join(os.tmpdir(), 'lec6-sparkplug-'));
}

// The assertions, each under the specification's id (or a name of ours).
export class Checks {
  constructor() {
    this.passed = 0;
    this.failed = 0;
    this.ids = new Set();
  }
  check(id, cond, what, detail = '') {
    this.ids.add(id);
    if (cond) {
      this.passed++;
      console.log(`ok   ${id}: ${what}`);
    } else {
      this.failed++;
      console.log(`FAIL ${id}: ${what} ${typeof detail === 'string' ? detail : JSON.stringify(detail)}`);
    }
    return cond;
  }
}

export async function startBroker(dir) {
  const port = await freePort();
  const conf = path.join(dir, 'mosquitto.conf');
  const user = process.getuid && process.getuid() === 0 ? 'user root\n' : '';
  fs.writeFileSync(conf, `${user}set_tcp_nodelay true\nlistener ${port} 127.0.0.1\nallow_anonymous true\npersistence false\n`);
  const log = fs.openSync(path.join(dir, 'mosquitto.log'), 'a');
  const proc = spawn(MOSQUITTO, ['-c', conf], { stdio: ['ignore', log, log] });
  for (let i = 0; i < 100; i++) {
    const up = await new Promise((r) => {
      const s = net.connect(port, '127.0.0.1', () => { s.end(); r(true); });
      s.on('error', () => r(false));
    });
    if (up) return { port, proc, url: `mqtt://127.0.0.1:${port}` };
    await sleep(100);
  }
  throw new Error('mosquitto did not listen');
}

export function serveYaml({ broker, httpPort, axes = 2, axisHz = 20, sparkplug = {}, extra = '' }) {
  const ids = Array.from({ length: axes }, (_, i) => `{id: ${i + 1}, name: axis${i + 1}, telemetry_hz: ${axisHz}}`);
  const lines = [
    'lines:',
    '  - name: line1',
    '    port: sim',
    '    baud: 115200',
    '    sim: {timing: fast}',
    '    probe_interval_ms: 200',
    '    offline_after: 2',
    `    axes: [${ids.join(', ')}]`,
    `http: {listen: "127.0.0.1:${httpPort}"}`,
    'sparkplug:',
    `  broker: "${broker}"`,
  ];
  for (const [k, v] of Object.entries(sparkplug)) lines.push(`  ${k}: ${JSON.stringify(v)}`);
  return lines.join('\n') + '\n' + extra;
}

// `lec serve --config` in the background; resolves on its ready line.
export async function startServe(dir, yaml, name = 'serve') {
  const config = path.join(dir, `${name}.yaml`);
  fs.writeFileSync(config, yaml);
  const err = fs.openSync(path.join(dir, `${name}.err`), 'a');
  const proc = spawn(LEC, ['serve', '--config', config], { stdio: ['ignore', 'pipe', err] });
  const errText = () => {
    try {
      return fs.readFileSync(path.join(dir, `${name}.err`), 'utf8');
    } catch {
      return '';
    }
  };
  await new Promise((resolve, reject) => {
    let out = '';
    const t = setTimeout(() => reject(new Error(`lec serve not ready: ${errText()}`)), 20000);
    proc.stdout.on('data', (d) => {
      out += d;
      if (out.includes('ready')) {
        clearTimeout(t);
        resolve();
      }
    });
    proc.on('exit', (code) => reject(new Error(`lec serve exited ${code}: ${errText()}`)));
  });
  return proc;
}

export async function http(port, method, p, body) {
  const r = await fetch(`http://127.0.0.1:${port}${p}`, {
    method,
    body: body === undefined ? undefined : JSON.stringify(body),
    headers: body === undefined ? {} : { 'content-type': 'application/json' },
  });
  return [r.status, await r.json().catch(() => null)];
}

// Numbers as numbers (Tahu's codec gives Int64 as a Long).
export function num(v) {
  return v && typeof v === 'object' && typeof v.toNumber === 'function' ? v.toNumber() : v;
}

// The host application: connects, subscribes to the group and records the
// node's messages, decoded by Tahu's codec (a message it cannot decode is a failure).
export class Host {
  constructor(brokerUrl, group, hostId) {
    this.group = group;
    this.hostId = hostId;
    this.url = brokerUrl;
    this.messages = [];
    this.undecodable = [];
    this.waiters = [];
  }

  stateTopic() {
    return `spBv1.0/STATE/${this.hostId}`;
  }

  async connect() {
    this.client = mqtt.connect(this.url, {
      clientId: `host-${this.hostId}-${process.pid}`,
      clean: true,
      protocolVersion: 5,
      reconnectPeriod: 0,
      will: { topic: this.stateTopic(), payload: Buffer.from(JSON.stringify({ online: false, timestamp: Date.now() })), qos: 1, retain: true },
    });
    await new Promise((r, j) => { this.client.once('connect', r); this.client.once('error', j); });
    this.client.on('message', (topic, payload, packet) => this.onMessage(topic, payload, packet));
    // Retain as published: a node that retained a message is seen doing it
    // (a live message is otherwise always delivered with retain = 0).
    await this.client.subscribeAsync([`spBv1.0/${this.group}/#`], { qos: 1, rap: true });
  }

  onMessage(topic, payload, packet) {
    const m = { topic, raw: payload, qos: packet.qos, retain: packet.retain, t: Date.now() };
    const verb = topic.split('/')[2];
    m.verb = verb;
    m.device = topic.split('/')[4];
    try {
      m.p = sp.decodePayload(payload);
      if (m.p.seq !== undefined && m.p.seq !== null) m.p.seq = num(m.p.seq);
      for (const x of m.p.metrics ?? []) {
        x.value = num(x.value);
        if (x.alias !== undefined) x.alias = num(x.alias);
      }
    } catch (e) {
      this.undecodable.push({ topic, error: String(e) });
      m.p = { metrics: [] };
    }
    this.messages.push(m);
    for (const w of [...this.waiters]) {
      if (w.pred(m)) {
        this.waiters.splice(this.waiters.indexOf(w), 1);
        clearTimeout(w.timer);
        w.resolve(m);
      }
    }
  }

  mark() {
    return this.messages.length;
  }

  since(mark, pred = () => true) {
    return this.messages.slice(mark).filter(pred);
  }

  // The first message from `mark` on that satisfies `pred`.
  waitFor(pred, ms, what, mark = 0) {
    const found = this.messages.slice(mark).find(pred);
    if (found) return Promise.resolve(found);
    return new Promise((resolve, reject) => {
      const w = { pred, resolve };
      w.timer = setTimeout(() => {
        this.waiters.splice(this.waiters.indexOf(w), 1);
        reject(new Error(`timed out after ${ms} ms waiting for ${what}`));
      }, ms);
      this.waiters.push(w);
    });
  }

  async state(online, timestamp = Date.now()) {
    await this.client.publishAsync(this.stateTopic(), JSON.stringify({ online, timestamp }), { qos: 1, retain: true });
  }

  async command(verb, node, device, metrics) {
    const topic = `spBv1.0/${this.group}/${verb}/${node}${device ? '/' + device : ''}`;
    await this.client.publishAsync(topic, sp.encodePayload({ timestamp: Date.now(), metrics }), { qos: 0 });
  }

  async close() {
    if (this.client) await this.client.endAsync(true);
  }
}
