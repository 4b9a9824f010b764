// Attacks on the promises of lec serve's Sparkplug B edge node
// (docs/sparkplug.md) in the plant's worst states, by an independent host
// (npm mqtt + Eclipse Tahu's sparkplug-payload) against Debian's mosquitto.
//
//   LEC=build/lec node tests/sparkplug_host/attack.mjs [scenario ...]
//
// Scenarios: settings-race, flood-stop, stop-result-hidden, bdseq-no-history, broker-restart,
// sigterm-after-offline, settings-refused-in-order, settings-same-value, big-dcmd-stop
// (all when none is named). Each check is named; prints
// "N passed, M failed" and exits non-zero on any failure.

import { spawn } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { Checks, Host, freePort, http, serveYaml, sleep, sp, startBroker, startServe, tmpdir } from './lib.mjs';

const GROUP = 'plant';
const ck = new Checks();
// The margin a stop behind a burst may take over a lone one: 100 ms, three
// times that in the sanitizer tree (every DCMD's look for a stop on the MQTT
// thread is ~3x slower there: 130 ms behind 2000 DCMDs, 5-8 ms optimised).
const MARGIN_MS = process.env.LEC6_SANITIZED === '1' ? 300 : 100;
// The two comparisons above are wall-clock samples, and this test runs beside the
// others (a -j2 ctest: the burst's run was once starved past the margin, CI stop 39):
// each gets up to three (lone, behind) pairs, and passes on the first pair within the
// margin. A stop that really waits behind the burst (the 2000 DCMDs handled first:
// seconds; the 2 MB DCMD decoded first: 9.8 s) misses every pair.
const WALL_TRIES = 3;
const dir = tmpdir();
process.env.XDG_STATE_HOME = `${dir}/xdg`;
delete process.env.STATE_DIRECTORY;
const procs = [];

const is = (verb, device, node) => (m) => m.verb === verb && (device === undefined || m.device === device) &&
  (node === undefined || m.topic.split('/')[3] === node);
const metric = (m, name) => (m.p.metrics ?? []).find((x) => x.name === name);

// The node's view as a host keeps it: aliases from the births, values since.
class NodeView {
  constructor(host, node) {
    this.host = host;
    this.node = node;
    this.devices = {};
    this.applied = 0;
  }
  sync() {
    while (this.applied < this.host.messages.length) this.apply(this.host.messages[this.applied++]);
  }
  apply(m) {
    if (m.topic.split('/')[3] !== this.node) return;
    if (m.verb === 'NBIRTH' || m.verb === 'DBIRTH') {
      const d = { byName: {}, byAlias: {}, values: {} };
      for (const x of m.p.metrics) {
        if (x.alias !== undefined) {
          d.byName[x.name] = x.alias;
          d.byAlias[x.alias] = x;
        }
        d.values[x.name] = x.value;
      }
      this.devices[m.device ?? ''] = d;
      return;
    }
    if (m.verb !== 'DDATA' && m.verb !== 'NDATA') return;
    const d = this.devices[m.device ?? ''];
    if (!d) return;
    for (const x of m.p.metrics) {
      const def = d.byAlias[x.alias];
      if (def) d.values[def.name] = x.value;
    }
  }
  value(device, name) {
    this.sync();
    return this.devices[device]?.values[name];
  }
  alias(device, name) {
    this.sync();
    return this.devices[device]?.byName[name];
  }
  async until(device, name, pred, ms, what) {
    const deadline = Date.now() + ms;
    for (;;) {
      const v = this.value(device, name);
      if (pred(v)) return v;
      if (Date.now() > deadline) throw new Error(`timed out: ${what} (${device} ${name} = ${v})`);
      await sleep(5);
    }
  }
  writes(device, values) {
    return Object.entries(values).map(([name, [type, value]]) => ({ alias: this.alias(device, name), type, value }));
  }
}

// One node (no primary host unless given) on the twin, its host connected and the births seen.
async function bringUp(broker, node, { axes = 2, sparkplug = {}, extra = '', name = node, host } = {}) {
  host = host ?? new Host(broker.url, GROUP, 'scada');
  if (!host.client) await host.connect();
  const httpPort = await freePort();
  const mark = host.mark();
  const yaml = serveYaml({ broker: broker.url, httpPort, axes, sparkplug: { group_id: GROUP, edge_node_id: node, telemetry_hz: 50, keepalive_s: 5, ...sparkplug }, extra });
  const serve = await startServe(dir, yaml, name);
  procs.push(serve);
  const view = new NodeView(host, node);
  if (!sparkplug.primary_host_id) {
    await host.waitFor(is('DBIRTH', `axis${axes}`, node), 10000, `DBIRTH axis${axes} of ${node}`, mark);
  }
  return { host, view, serve, httpPort, yaml };
}

async function dcmd(host, view, node, device, values) {
  await host.command('DCMD', node, device, view.writes(device, values));
}

// Sends a DCMD and waits until its Command/Count is seen and its outcome is final.
async function run(host, view, node, device, values, what) {
  const before = view.value(device, 'Command/Count');
  await dcmd(host, view, node, device, values);
  await view.until(device, 'Command/Count', (v) => v > before, 5000, `${what}: counted`);
  return view.until(device, 'Command/Outcome', (v) => ['done', 'failed', 'refused', 'set'].includes(v), 20000, what);
}

async function moving(host, view, node, device, position = 390, speed = 20) {
  for (const [n, w] of [['Command/Serial', 'serial'], ['Command/Servo', 'servo'], ['Command/Home', 'home']]) {
    const got = await run(host, view, node, device, { [n]: ['Boolean', true] }, `${device} ${w}`);
    if (got !== 'done') throw new Error(`${device} ${w}: ${got} ${view.value(device, 'Command/Message')}`);
  }
  await view.until(device, 'Flags/BUSY', (v) => v === false, 5000, `${device} at rest after home`);
  await dcmd(host, view, node, device, {
    'Command/Move/Position mm': ['Double', position], 'Command/Move/Speed mm/s': ['Int32', speed], 'Command/Move/Execute': ['Boolean', true],
  });
  await view.until(device, 'Flags/BUSY', (v) => v === true, 5000, `${device} moving`);
}

// ---- a refused move's settings, with a settings DCMD right behind it ----------------
// docs/sparkplug.md: "A move DCMD the axis refuses before the wire keeps none of its
// settings". The axis refuses the move (servo off, 409) on the operation's thread; a
// settings-only DCMD handled before that refusal comes back takes over
// CommandState::settings_from, so finished() no longer gives the refused move's
// settings back.
async function settingsRace(broker) {
  const node = 'race';
  const { host, view, serve } = await bringUp(broker, node, { axes: 1 });
  const got = await run(host, view, node, 'axis1', { 'Command/Serial': ['Boolean', true] }, 'serial on');
  if (got !== 'done') throw new Error(`serial on: ${got}`);
  let kept = 0;
  const tries = 5;
  const seen = [];
  for (let i = 0; i < tries; i++) {
    const before = view.value('axis1', 'Command/Count');
    // The servo is off: the axis refuses this move before the wire.
    await dcmd(host, view, node, 'axis1', {
      'Command/Move/Position mm': ['Double', 100 + i], 'Command/Move/Speed mm/s': ['Int32', 30 + i], 'Command/Move/Execute': ['Boolean', true],
    });
    // At once, a DCMD that only sets the acceleration.
    await dcmd(host, view, node, 'axis1', { 'Command/Move/Accel mm/s2': ['Int32', 200 + i] });
    await view.until('axis1', 'Command/Count', (v) => v >= before + 2, 5000, 'both DCMDs counted');
    await sleep(500);  // the move's refusal has come back
    const pos = view.value('axis1', 'Command/Move/Position mm');
    const speed = view.value('axis1', 'Command/Move/Speed mm/s');
    const accel = view.value('axis1', 'Command/Move/Accel mm/s2');
    seen.push(`${pos}/${speed}/${accel}`);
    if (i === 0) console.log(`# the move's result (Operation/Last Result): ${view.value('axis1', 'Operation/Last Result')}`);
    if (pos === 100 + i || speed === 30 + i) kept++;
    // Back to no position: a move that is refused by the session (no axis involved) cannot clear it,
    // so a fresh node would be needed; the next try uses other values and checks only its own.
  }
  ck.check('lec6-never-half-applied-by-the-axis (race)', kept === 0,
    `a move refused by the axis (servo off) keeps none of its settings when a settings DCMD follows at once: kept in ${kept} of ${tries} tries (position/speed/accel seen: ${seen.join(', ')})`);
  serve.kill('SIGTERM');
  await new Promise((r) => serve.once('exit', r));
}

// ---- a stop behind a flood of other DCMDs ------------------------------------------
// The one stop rule: a stop never waits for anything. The MQTT thread handles each
// DCMD in order (lock, plan, sample, encode, publish, log), so a stop queued behind a
// burst of other DCMDs waits for all of them.
async function floodStop(broker, n) {
  const node = 'flood';
  const { host, view, serve } = await bringUp(broker, node, { axes: 2 });
  const measure = async (flood) => {
    await moving(host, view, node, 'axis1');
    await sleep(200);
    const bad = [{ name: 'Command/Fly', type: 'Boolean', value: true }];
    const t0 = Date.now();
    for (let i = 0; i < flood; i++) host.command('DCMD', node, 'axis2', bad);  // not awaited: a burst
    const sent = Date.now();
    const mk = host.mark();
    await dcmd(host, view, node, 'axis1', { 'Command/Stop': ['Boolean', true] });
    // The host is subscribed to the group: the broker hands it the stop as it hands it to the node.
    const echo = await host.waitFor(is('DCMD', 'axis1', node), 30000, 'the stop through the broker', mk);
    await view.until('axis1', 'Flags/BUSY', (v) => v === false, 30000, 'axis1 stopped');
    const ms = Date.now() - echo.t;
    console.log(`#   ${flood} DCMDs before: the broker handed the stop on ${echo.t - sent} ms after it was sent; BUSY = 0 on the broker ${ms} ms after that`);
    await view.until('axis1', 'Command/Outcome', (v) => v === 'done' || v === 'failed', 5000, 'stop finished');
    return { ms, burstMs: sent - t0, outcome: view.value('axis1', 'Command/Outcome') };
  };
  // A pair (lone, behind the burst) per try, up to WALL_TRIES: see WALL_TRIES.
  const seen = [];
  let base, flooded;
  for (let i = 0; i < WALL_TRIES; i++) {
    base = await measure(0);
    flooded = await measure(n);
    seen.push(`lone ${base.ms} ms, behind the burst ${flooded.ms} ms, outcome ${flooded.outcome}`);
    if (flooded.ms < base.ms + MARGIN_MS && flooded.outcome === 'done') break;
  }
  await sleep(1000);
  const refused = view.value('axis2', 'Command/Count');
  console.log(`# stop alone: BUSY = 0 on the broker ${base.ms} ms after the broker handed the DCMD on; behind ${n} refused DCMDs (burst sent in ${flooded.burstMs} ms): ${flooded.ms} ms; axis2 Command/Count ${refused}`);
  ck.check('lec6-one-stop-rule: a stop behind a burst of DCMDs', flooded.ms < base.ms + MARGIN_MS && flooded.outcome === 'done',
    `a stop sent right after ${n} other DCMDs reaches the line within ${MARGIN_MS} ms of a lone stop's time, in one of ${WALL_TRIES} tries (${seen.join('; ')})`);
  serve.kill('SIGTERM');
  await new Promise((r) => serve.once('exit', r));
}

// ---- a stop's result, with another DCMD right behind it ---------------------------
// docs/sparkplug.md: "Command/Count changes with every DCMD, so each gets its DDATA:
// the result is that event." finished() publishes a result only while no later DCMD
// has taken the device's command state, so a stop followed at once by any other DCMD
// (a refused one, one from another host) never has its result published; and a stop is
// not a motion, so Operation/Last Result does not carry it either. A stop the axis did
// not obey (502) would be said nowhere on the broker.
async function stopResultHidden(broker) {
  const node = 'hidden';
  const { host, view, serve } = await bringUp(broker, node, { axes: 1 });
  await moving(host, view, node, 'axis1');
  await sleep(200);
  const mark = host.mark();
  const before = view.value('axis1', 'Command/Count');
  await dcmd(host, view, node, 'axis1', { 'Command/Stop': ['Boolean', true] });
  await host.command('DCMD', node, 'axis1', [{ name: 'Command/Fly', type: 'Boolean', value: true }]);
  await view.until('axis1', 'Flags/BUSY', (v) => v === false, 5000, 'axis1 stopped');
  await sleep(1500);
  // Every (count, outcome) pair the host saw since the stop.
  const pairs = [];
  const countAlias = view.alias('axis1', 'Command/Count');
  const outcomeAlias = view.alias('axis1', 'Command/Outcome');
  const messageAlias = view.alias('axis1', 'Command/Message');
  let count = before;
  for (const m of host.since(mark, is('DDATA', 'axis1', node))) {
    const c = m.p.metrics.find((x) => x.alias === countAlias);
    if (c) count = c.value;
    const o = m.p.metrics.find((x) => x.alias === outcomeAlias);
    const msg = m.p.metrics.find((x) => x.alias === messageAlias);
    if (o || c) pairs.push(`${count}:${o?.value ?? '-'}${msg ? ` (${msg.value})` : ''}`);
  }
  // A stop has metrics of its own: Command/Stop Outcome says the last stop's result
  // whatever DCMD came after it (Command/Outcome is the latest DCMD's).
  view.sync();
  const stopOutcome = view.value('axis1', 'Command/Stop Outcome');
  ck.check('lec6-dcmd-result-event: a stop followed by another DCMD', stopOutcome === 'done' || stopOutcome === 'failed',
    `the stop's result is published (Command/Stop Outcome = ${stopOutcome}: ${view.value('axis1', 'Command/Stop Message')}); the later DCMD's outcome: ${pairs.join(', ')}`);
  serve.kill('SIGTERM');
  await new Promise((r) => serve.once('exit', r));
}

// ---- bdSeq across kill -9 with the history off ------------------------------------
// docs/sparkplug.md: "bdSeq ... is kept in bdseq_file, so a restart — after kill -9 too
// — births with the next one." The default bdseq_file lives in the history's state_dir:
// with the history off there is none, and nothing says so.
async function bdseqNoHistory(broker) {
  const node = 'nohist';
  const host = new Host(broker.url, GROUP, 'scada');
  await host.connect();
  let mark = host.mark();
  const first = await bringUp(broker, node, { axes: 1, extra: 'history: false\n', host });
  const nb1 = await host.waitFor(is('NBIRTH', undefined, node), 5000, 'first NBIRTH', mark);
  mark = host.mark();
  first.serve.kill('SIGKILL');
  await host.waitFor(is('NDEATH', undefined, node), 10000, 'the will on kill -9', mark);
  mark = host.mark();
  const second = await startServe(dir, first.yaml, `${node}2`);
  procs.push(second);
  const nb2 = await host.waitFor(is('NBIRTH', undefined, node), 10000, 'NBIRTH after the restart', mark);
  const a = metric(nb1, 'bdSeq')?.value;
  const b = metric(nb2, 'bdSeq')?.value;
  ck.check('tck-id-topics-nbirth-bdseq-increment (history off)', b === (a + 1) % 256,
    `history: false, kill -9, restart: the NBIRTH's bdSeq goes from ${a} to ${b} (expected ${(a + 1) % 256})`);
  const err = fs.readFileSync(path.join(dir, `${node}2.err`), 'utf8');
  console.log(`# the restarted node's log on bdSeq: ${err.split('\n').filter((l) => /bdseq|bdSeq/.test(l)).join(' | ') || '(nothing)'}`);
  second.kill('SIGTERM');
  await new Promise((r) => second.once('exit', r));
}

// ---- mosquitto restarted under the node, data flowing --------------------------------
// One NBIRTH per connection (no second one owed to the lost connection), the next bdSeq,
// seq continuous from it, no NDEATH said twice.
async function brokerRestart() {
  const bdir = path.join(dir, 'restart');
  fs.mkdirSync(bdir);
  let broker = await startBroker(bdir);
  const port = broker.port;
  const node = 'restart';
  const host = new Host(broker.url, GROUP, 'scada');
  await host.connect();
  const { view, serve } = await bringUp(broker, node, { axes: 2, host, sparkplug: { telemetry_hz: 200, reconnect_max_s: 1 } });
  await moving(host, view, node, 'axis1', 390, 20);
  await moving(host, view, node, 'axis2', 390, 20);
  const rounds = 4;
  const results = [];
  for (let i = 0; i < rounds; i++) {
    broker.proc.kill(i % 2 ? 'SIGKILL' : 'SIGTERM');
    await new Promise((r) => broker.proc.once('exit', r));
    await sleep(300);
    // The same port again (the node reconnects to it).
    const conf = path.join(bdir, 'mosquitto.conf');
    const log = fs.openSync(path.join(bdir, 'mosquitto.log'), 'a');
    const proc = spawn(fs.existsSync('/usr/sbin/mosquitto') ? '/usr/sbin/mosquitto' : 'mosquitto', ['-c', conf], { stdio: ['ignore', log, log] });
    procs.push(proc);
    broker = { ...broker, proc, port };
    await sleep(300);
    const h = new Host(broker.url, GROUP, 'scada');
    for (let k = 0; k < 50; k++) {
      try {
        await h.connect();
        break;
      } catch {
        await sleep(100);
      }
    }
    const nb = await h.waitFor(is('NBIRTH', undefined, node), 10000, `NBIRTH after broker restart ${i + 1}`);
    await sleep(2500);
    const nbirths = h.since(0, is('NBIRTH', undefined, node));
    const deaths = h.since(0, is('NDEATH', undefined, node));
    // seq from the first NBIRTH on
    let prev = null;
    const breaks = [];
    for (const m of h.messages.slice(h.messages.indexOf(nb))) {
      if (m.topic.split('/')[3] !== node || m.verb === 'NDEATH') continue;
      if (m.verb === 'NBIRTH') prev = 0;
      else if (prev !== null && m.p.seq !== (prev + 1) % 256) breaks.push(`${m.verb} ${m.p.seq} after ${prev}`), prev = m.p.seq;
      else prev = m.p.seq;
    }
    results.push({ bdSeq: metric(nb, 'bdSeq')?.value, nbirths: nbirths.length, deaths: deaths.length, breaks: breaks.length });
    await h.close();
  }
  console.log(`# after each broker restart: ${JSON.stringify(results)}`);
  ck.check('lec6-broker-restart: one NBIRTH per connection', results.every((r) => r.nbirths === 1),
    `exactly one NBIRTH in the 2.5 s after each of ${rounds} broker restarts (${results.map((r) => r.nbirths).join(', ')})`);
  ck.check('tck-id-topics-nbirth-bdseq-increment (broker restart)', results.every((r, i) => i === 0 || r.bdSeq === (results[i - 1].bdSeq + 1) % 256),
    `bdSeq one up per reconnect (${results.map((r) => r.bdSeq).join(', ')})`);
  ck.check('tck-id-payloads-sequence-num-incrementing (broker restart)', results.every((r) => r.breaks === 0),
    `seq continuous after each reconnect (breaks: ${results.map((r) => r.breaks).join(', ')})`);
  serve.kill('SIGKILL');
  broker.proc.kill('SIGKILL');
}

// ---- SIGTERM right after the primary host went offline -----------------------------
// The node's own NDEATH (host offline) and the clean stop's NDEATH must not both go
// out for one bdSeq.
async function sigtermAfterOffline(broker) {
  const node = 'offterm';
  const tries = Number(process.env.TRIES ?? 6);
  const twice = [];
  for (let i = 0; i < tries; i++) {
    const host = new Host(broker.url, GROUP, `scada${i}`);
    host.hostId = `scada${i}`;
    await host.connect();
    await host.state(true);
    const mark = host.mark();
    const { serve } = await bringUp(broker, node, { axes: 1, host, name: `${node}${i}`, sparkplug: { primary_host_id: `scada${i}` } });
    await host.waitFor(is('DBIRTH', 'axis1', node), 10000, 'DBIRTH', mark);
    const m2 = host.mark();
    host.state(false);
    await sleep(i % 6);  // 0..5 ms
    serve.kill('SIGTERM');
    await new Promise((r) => serve.once('exit', r));
    await sleep(300);
    const per = new Map();
    for (const m of host.since(m2, is('NDEATH', undefined, node))) {
      const k = metric(m, 'bdSeq')?.value;
      per.set(k, (per.get(k) ?? 0) + 1);
    }
    if ([...per.values()].some((n) => n > 1)) twice.push(`try ${i}: ${JSON.stringify([...per.entries()])}`);
    await host.close();
  }
  ck.check('lec6-one-ndeath-per-bdseq (SIGTERM after host offline)', twice.length === 0,
    `one NDEATH per bdSeq when SIGTERM follows the host's offline STATE (${tries} tries) ${twice.join('; ')}`);
}

// ---- review 2: the fixes attacked ------------------------------------------------

// Two DCMDs with an action, both refused by the axis before the wire, results in order
// (the controller in parallel mode: a move, then a servo-on with a speed). docs/sparkplug.md:
// a refused move "gives back the settings its DCMD set"; the second DCMD gives back "the value
// before it", which is the first refused DCMD's (dcmd.cpp settle_settings).
async function settingsRefusedInOrder(broker) {
  const node = 'inorder';
  const { host, view, serve } = await bringUp(broker, node, { axes: 1 });
  const tries = Number(process.env.TRIES ?? 8);
  const kept = [];
  for (let i = 0; i < tries; i++) {
    const before = view.value('axis1', 'Command/Count');
    const move = { 'Command/Move/Position mm': ['Double', 100 + i], 'Command/Move/Speed mm/s': ['Int32', 10 + i], 'Command/Move/Execute': ['Boolean', true] };
    const servo = { 'Command/Servo': ['Boolean', true], 'Command/Move/Speed mm/s': ['Int32', 40 + i] };
    // Which of the two the axis answers first is the operations' threads' race: both orders.
    for (const values of i % 2 ? [servo, move] : [move, servo]) await dcmd(host, view, node, 'axis1', values);
    await view.until('axis1', 'Command/Count', (v) => v >= before + 2, 5000, 'both DCMDs counted');
    await view.until('axis1', 'Command/Outcome', (v) => v === 'failed' || v === 'done', 5000, 'the second one finished');
    await sleep(300);
    const pos = view.value('axis1', 'Command/Move/Position mm');
    const speed = view.value('axis1', 'Command/Move/Speed mm/s');
    if (pos != null || speed != null) kept.push(`try ${i}: position ${pos}, speed ${speed}`);
    if (kept.length) break;  // the state is no longer clean
  }
  ck.check('lec6-never-half-applied-by-the-axis (two refused DCMDs)', kept.length === 0,
    `a move and a servo-on with a speed, both refused by the axis (parallel mode, 409), in ${tries} tries, either order: no setting stays (${kept.join('; ') || 'none stayed'}); last: ${view.value('axis1', 'Command/Message')}`);
  serve.kill('SIGTERM');
  await new Promise((r) => serve.once('exit', r));
}

// A settings DCMD that writes the value a move in flight wrote: "move settings kept"; the
// move is refused by the axis (servo off) and takes the value away (record_settings marks
// only the fields whose value changed).
async function settingsSameValue(broker) {
  const node = 'samevalue';
  const { host, view, serve } = await bringUp(broker, node, { axes: 1 });
  const got = await run(host, view, node, 'axis1', { 'Command/Serial': ['Boolean', true] }, 'serial on');
  if (got !== 'done') throw new Error(`serial on: ${got}`);
  const before = view.value('axis1', 'Command/Count');
  await dcmd(host, view, node, 'axis1', {
    'Command/Move/Position mm': ['Double', 100], 'Command/Move/Speed mm/s': ['Int32', 30], 'Command/Move/Execute': ['Boolean', true],
  });
  await dcmd(host, view, node, 'axis1', { 'Command/Move/Speed mm/s': ['Int32', 30] });
  await view.until('axis1', 'Command/Count', (v) => v >= before + 2, 5000, 'both DCMDs counted');
  const outcome = await view.until('axis1', 'Command/Outcome', (v) => v === 'set', 5000, 'the settings DCMD kept');
  await sleep(500);  // the move's refusal has come back
  const speed = view.value('axis1', 'Command/Move/Speed mm/s');
  const pos = view.value('axis1', 'Command/Move/Position mm');
  ck.check('lec6-never-half-applied-by-the-axis (a later DCMD wrote the same value)', speed === 30 && pos == null,
    `a settings DCMD writing speed 30 ("${outcome}", ${view.value('axis1', 'Command/Message')}) behind a move with speed 30 the axis refused (servo off): speed ${speed} (expected 30), position ${pos} (expected none)`);
  serve.kill('SIGTERM');
  await new Promise((r) => serve.once('exit', r));
}

// One big DCMD (empty metrics, no stop) in front of a stop: the MQTT thread decoded every
// metric of it into a vector before it read the stop (9.8 s behind 2 MB); now a command over
// 16 KiB is refused unread. docs/sparkplug.md: "a stop behind 2000 other DCMDs is on the line as fast as a lone one".
async function bigDcmdStop(broker, mb) {
  const node = 'bigdcmd';
  const { host, view, serve } = await bringUp(broker, node, { axes: 2 });
  const measure = async (bytes) => {
    await moving(host, view, node, 'axis1');
    await sleep(200);
    const mk = host.mark();
    if (bytes) {
      const big = Buffer.alloc(bytes);
      for (let i = 0; i + 1 < bytes; i += 2) big[i] = 0x12;
      host.client.publish(`spBv1.0/${GROUP}/DCMD/${node}/axis2`, big, { qos: 0 });
    }
    await dcmd(host, view, node, 'axis1', { 'Command/Stop': ['Boolean', true] });
    const echo = await host.waitFor(is('DCMD', 'axis1', node), 60000, 'the stop through the broker', mk);
    await view.until('axis1', 'Flags/BUSY', (v) => v === false, 60000, 'axis1 stopped');
    return Date.now() - echo.t;
  };
  // A pair (lone, behind the big DCMD) per try, up to WALL_TRIES: see WALL_TRIES.
  const seen = [];
  let lone, behind;
  for (let i = 0; i < WALL_TRIES; i++) {
    lone = await measure(0);
    behind = await measure(mb << 20);
    seen.push(`lone ${lone} ms, behind it ${behind} ms`);
    if (behind < lone + MARGIN_MS) break;
  }
  console.log(`# stop alone: BUSY = 0 ${lone} ms after the broker handed it on; behind one ${mb} MB DCMD: ${behind} ms`);
  ck.check('lec6-one-stop-rule: a stop behind one big DCMD', behind < lone + MARGIN_MS,
    `a stop right after one ${mb} MB DCMD of empty metrics reaches the line within ${MARGIN_MS} ms of a lone stop's time, in one of ${WALL_TRIES} tries (${seen.join('; ')})`);
  serve.kill('SIGTERM');
  await new Promise((r) => serve.once('exit', r));
}

// A move DCMD and a stop right behind it, the gap swept: the node checks "a stop came
// after this DCMD" (Core::command, overtaken()) before it numbers, records and hands the
// move to Operations; a stop in that gap goes to the line first, and the move then starts
// on a fresh slot (Operations marks only a motion already there): the axis moves after a
// stop that was sent after the move. Not found in the tries: the move runs after the stop.
async function stopOvertakeRace(broker) {
  const node = 'overtake';
  const { host, view, serve } = await bringUp(broker, node, { axes: 1 });
  await moving(host, view, node, 'axis1', 10, 50);  // serial, servo, home, then a short move
  await view.until('axis1', 'Flags/BUSY', (v) => v === false, 10000, 'at rest');
  const tries = Number(process.env.TRIES_OVERTAKE ?? 150);
  const topic = `spBv1.0/${GROUP}/DCMD/${node}/axis1`;
  const move = sp.encodePayload({ timestamp: Date.now(), metrics: view.writes('axis1', {
    'Command/Move/Position mm': ['Double', 390], 'Command/Move/Speed mm/s': ['Int32', 20], 'Command/Move/Execute': ['Boolean', true] }) });
  const stop = sp.encodePayload({ timestamp: Date.now(), metrics: view.writes('axis1', { 'Command/Stop': ['Boolean', true] }) });
  const after = [];
  const outcomes = {};
  for (let i = 0; i < tries && after.length === 0; i++) {
    const before = view.value('axis1', 'Command/Count');
    host.client.publish(topic, move, { qos: 0 });
    const gapUs = (i % 50) * 40;
    const t = process.hrtime.bigint();
    while (Number(process.hrtime.bigint() - t) / 1000 < gapUs) { /* spin */ }
    host.client.publish(topic, stop, { qos: 0 });
    await view.until('axis1', 'Command/Count', (v) => v >= before + 2, 5000, 'both counted');
    await view.until('axis1', 'Command/Stop Outcome', (v) => v === 'done' || v === 'failed', 5000, 'stop finished');
    await sleep(150);
    const busy = view.value('axis1', 'Flags/BUSY');
    const running = view.value('axis1', 'Operation/Running');
    const o = view.value('axis1', 'Command/Outcome');
    outcomes[o] = (outcomes[o] ?? 0) + 1;
    if (busy === true || (running && running !== 'none' && running !== '')) {
      after.push(`try ${i} (gap ${gapUs} us): BUSY ${busy}, running ${running}, outcome ${o}: ${view.value('axis1', 'Command/Message')}`);
      await dcmd(host, view, node, 'axis1', { 'Command/Stop': ['Boolean', true] });
      await view.until('axis1', 'Flags/BUSY', (v) => v === false, 10000, 'stopped again');
    }
  }
  console.log(`# last Command/Outcome after each try: ${JSON.stringify(outcomes)}`);
  ck.check('lec6-no-dcmd-after-a-later-stop (swept gap)', after.length === 0,
    `a move DCMD followed by a stop 0-2 ms later never leaves the axis moving after the stop's result (${tries} tries) ${after.join('; ')}`);
  serve.kill('SIGTERM');
  await new Promise((r) => serve.once('exit', r));
}

async function main() {
  const all = ['settings-race', 'flood-stop', 'stop-result-hidden', 'bdseq-no-history', 'broker-restart', 'sigterm-after-offline',
    'settings-refused-in-order', 'settings-same-value', 'big-dcmd-stop', 'stop-overtake-race'];
  const want = process.argv.slice(2).length ? process.argv.slice(2) : all;
  const broker = await startBroker(dir);
  procs.push(broker.proc);
  for (const s of want) {
    console.log(`# ---- ${s}`);
    try {
      if (s === 'settings-race') await settingsRace(broker);
      else if (s === 'flood-stop') await floodStop(broker, Number(process.env.FLOOD ?? 2000));
      else if (s === 'stop-result-hidden') await stopResultHidden(broker);
      else if (s === 'bdseq-no-history') await bdseqNoHistory(broker);
      else if (s === 'broker-restart') await brokerRestart();
      else if (s === 'sigterm-after-offline') await sigtermAfterOffline(broker);
      else if (s === 'settings-refused-in-order') await settingsRefusedInOrder(broker);
      else if (s === 'settings-same-value') await settingsSameValue(broker);
      else if (s === 'big-dcmd-stop') await bigDcmdStop(broker, Number(process.env.BIG_MB ?? 2));
      else if (s === 'stop-overtake-race') await stopOvertakeRace(broker);
      else throw new Error(`no scenario ${s}`);
    } catch (e) {
      ck.check(s, false, 'scenario ran', String(e.stack ?? e));
    }
  }
}

let code = 1;
try {
  await main();
  code = ck.failed === 0 && ck.passed > 0 ? 0 : 1;
} finally {
  for (const p of procs) if (p.exitCode === null) p.kill('SIGKILL');
  console.log(`${ck.passed} passed, ${ck.failed} failed (logs in ${dir})`);
  if (code === 0) fs.rmSync(dir, { recursive: true, force: true });
  process.exit(code);
}
