// Benchmark of lec serve's Sparkplug edge node (docs/sparkplug.md, BENCHMARKS.md):
// 8 axes on one twin line, each moving back and forth; DDATA per second on the
// broker, the edge node's CPU per message (its MQTT thread, and its own count of
// sampling and encoding), and the latency from a flag change on the
//
//   LEC=build/lec node tests/sparkplug_host/bench.mjs [SECONDS]

import fs from 'node:fs';
import { Host, freePort, http, serveYaml, sleep, startBroker, startServe, tmpdir } from './lib.mjs';

const SECONDS = Number(process.argv[2] ?? 10);
const AXES = 8;
const dir = tmpdir();
// Every lec serve started here keeps its default state (history, bdSeq) in this run's directory.
process.env.XDG_STATE_HOME = `${dir}/xdg`;
delete process.env.STATE_DIRECTORY;
const procs = [];

function cpuSeconds(pid) {
  const f = fs.readFileSync(`/proc/${pid}/stat`, 'utf8').split(') ')[1].split(' ');
  return (Number(f[11]) + Number(f[12])) / 100;  // utime + stime, clock ticks of 10 ms
}

// CPU seconds of the process' threads named `name` (the edge node's MQTT thread: lec-sparkplug).
function threadCpuSeconds(pid, name) {
  let total = 0;
  for (const tid of fs.readdirSync(`/proc/${pid}/task`)) {
    if (fs.readFileSync(`/proc/${pid}/task/${tid}/comm`, 'utf8').trim() !== name) continue;
    const f = fs.readFileSync(`/proc/${pid}/task/${tid}/stat`, 'utf8').split(') ')[1].split(' ');
    total += (Number(f[11]) + Number(f[12])) / 100;
  }
  return total;
}

function pct(sorted, p) {
  return sorted[Math.min(sorted.length - 1, Math.floor(p * sorted.length))];
}

// One lec serve with 8 axes on a twin line, ready to move (with or without the edge node).
async function start(broker, host, sparkplug) {
  const httpPort = await freePort();
  let yaml = serveYaml({ broker: broker.url, httpPort, axes: AXES, axisHz: 10,
    sparkplug: { group_id: 'bench', edge_node_id: 'box', telemetry_hz: 10 } }).replace('baud: 115200', 'baud: 230400');
  if (!sparkplug) yaml = yaml.slice(0, yaml.indexOf('sparkplug:'));
  const serve = await startServe(dir, yaml, sparkplug ? 'with' : 'without');
  procs.push(serve);
  if (sparkplug) await host.waitFor((m) => m.verb === 'DBIRTH' && m.device === `axis${AXES}`, 10000, 'the last DBIRTH');
  for (let i = 1; i <= AXES; i++) {
    for (const [op, body] of [['serial', { on: true }], ['servo', { on: true }], ['home', {}]]) {
      const [status, r] = await http(httpPort, 'POST', `/api/axes/axis${i}/${op}`, body);
      if (status !== 200) throw new Error(`axis${i} ${op}: ${JSON.stringify(r)}`);
    }
  }
  return { serve, httpPort };
}

async function main() {
  const broker = await startBroker(dir);
  procs.push(broker.proc);
  const host = new Host(broker.url, 'bench', 'none');
  await host.connect();
  // Both at once, the same moves: the machine's other load weighs on both alike.
  const without = await start(broker, host, false);
  const run = await start(broker, host, true);
  let running = true;
  const mover = async (port, i) => {
    let far = true;
    while (running) {
      await http(port, 'POST', `/api/axes/axis${i + 1}/move`, { position_mm: far ? 300 + i : 50 + i, speed_mm_s: 200 });
      far = !far;
    }
  };
  const movers = [];
  for (let i = 0; i < AXES; i++) movers.push(mover(run.httpPort, i), mover(without.httpPort, i));
  await sleep(1000);
  const c0 = [cpuSeconds(run.serve.pid), cpuSeconds(without.serve.pid)];
  const net0 = threadCpuSeconds(run.serve.pid, 'lec-sparkplug');
  const all0 = host.mark();
  const m0 = host.mark();
  const t0 = Date.now();
  await sleep(SECONDS * 1000);
  const s = (Date.now() - t0) / 1000;
  const cpu = (cpuSeconds(run.serve.pid) - c0[0]) / s;
  const cpuWithout = (cpuSeconds(without.serve.pid) - c0[1]) / s;
  const netCpu = threadCpuSeconds(run.serve.pid, 'lec-sparkplug') - net0;
  const sent = host.since(all0).length;
  const ddata = host.since(m0, (m) => m.verb === 'DDATA');
  const perS = ddata.length / s;
  const metrics = ddata.reduce((n, m) => n + m.p.metrics.length, 0) / Math.max(1, ddata.length);
  running = false;
  await Promise.all(movers);
  without.serve.kill('SIGTERM');
  // Flag change on the twin -> DDATA on the broker.
  const lat = [];
  let on = false;
  const svre = host.messages.find((b) => b.verb === 'DBIRTH' && b.device === 'axis1').p.metrics.find((d) => d.name === 'Flags/SVRE').alias;
  for (let i = 0; i < 20; i++) {
    const mk = host.mark();
    const sent = Date.now();
    await http(run.httpPort, 'POST', '/api/axes/axis1/servo', { on });
    const m = await host.waitFor((x) => x.verb === 'DDATA' && x.device === 'axis1' &&
      x.p.metrics.some((v) => v.alias === svre && v.value === on), 5000, `SVRE=${on} in a DDATA`, mk);
    lat.push(m.t - sent);
    on = !on;
    await sleep(100);
  }
  lat.sort((a, b) => a - b);
  // The node's own work (sampling, encoding, queueing) as it counts it, in its stop line.
  run.serve.kill('SIGTERM');
  await new Promise((r) => run.serve.once('exit', r));
  const own = /sparkplug: NDEATH published.*?(\d+) messages published.*?took ([\d.]+) ms of CPU \((\d+) us per message\)/
    .exec(fs.readFileSync(`${dir}/with.err`, 'utf8'));
  console.log(`${AXES} axes moving (HTTP moves back and forth), axis telemetry 10 Hz, sparkplug telemetry_hz 10, ${s.toFixed(1)} s`);
  console.log(`DDATA: ${perS.toFixed(1)}/s on the broker (${metrics.toFixed(1)} metrics each)`);
  console.log(`lec serve CPU: ${(cpu * 100).toFixed(1)} % with the edge node, ${(cpuWithout * 100).toFixed(1)} % without (same moves, same time)`);
  console.log(`the edge node's MQTT thread (lec-sparkplug): ${(netCpu * 1e6 / sent).toFixed(0)} µs of CPU per message (${sent} messages, ${(netCpu * 1000).toFixed(0)} ms; 10 ms ticks)`);
  console.log(own ? `the node's sampling and encoding (its own count over the whole run): ${own[3]} µs of CPU per message (${own[1]} messages, ${own[2]} ms)`
    : 'the node did not log its CPU at stop');
  console.log(`servo command sent over HTTP -> DDATA with the new SVRE on the broker: median ${pct(lat, 0.5)} ms, p95 ${pct(lat, 0.95)} ms, max ${lat.at(-1)} ms (n=${lat.length})`);
  await host.close();
}

try {
  await main();
} catch (e) {
  console.log(`bench failed: ${e.stack ?? e}`);
  process.exitCode = 1;
} finally {
  for (const p of procs) if (p.exitCode === null) p.kill('SIGKILL');
  fs.rmSync(dir, { recursive: true, force: true });
}
