// Shared by the browser tests: `lec serve` on the twin (ports chosen by the
// OS, read from its ready line), Debian's chromium through playwright-core,
// the `lec` CLI through the daemon, and screenshots under build/.
import { spawn, execFile } from "node:child_process";
import { mkdirSync, mkdtempSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join, resolve } from "node:path";
import { promisify } from "node:util";
import { chromium } from "playwright-core";

const here = new URL(".", import.meta.url).pathname;
export const LEC = process.env.LEC6_BIN ?? resolve(here, "../../build/lec");
export const ARTIFACTS = process.env.LEC6_ARTIFACTS ?? resolve(here, "../../build/web-screenshots");
const CHROMIUM = process.env.LEC6_CHROMIUM ?? "/usr/bin/chromium";

export const DESKTOP = { width: 1600, height: 1000 };
export const PANEL = { width: 1024, height: 768 };

// Starts `lec serve --port sim`; resolves once it prints where it listens.
export async function startDaemon({ ids = "1-4", args = [], config } = {}) {
  const argv = config
    ? ["serve", "--config", writeTemp("lec6.yaml", config)]
    : ["serve", "--port", "sim", "--ids", ids, "--http", "127.0.0.1:0", "--modbus-tcp", "127.0.0.1:0", ...args];
  const proc = spawn(LEC, argv, { stdio: ["ignore", "pipe", "pipe"] });
  let log = "";
  proc.stderr.on("data", (d) => (log += d));
  const ready = await new Promise((ok, fail) => {
    let out = "";
    const timer = setTimeout(() => fail(new Error(`lec serve did not get ready in 20 s:\n${out}${log}`)), 20000);
    proc.stdout.on("data", (d) => {
      out += d;
      const m = out.match(/lec serve: ready on (.*)\n/);
      if (m) {
        clearTimeout(timer);
        ok(m[1]);
      }
    });
    proc.on("exit", (code) => fail(new Error(`lec serve exited (${code}) before ready:\n${out}${log}`)));
  });
  const http = ready.match(/http:\/\/[\d.]+:\d+/)?.[0];
  const tcp = ready.match(/tcp:\/\/[\d.]+:\d+/)?.[0];
  if (!http) throw new Error(`no HTTP listener in the ready line: ${ready}`);
  const exited = new Promise((ok) => proc.on("exit", (code, signal) => ok({ code, signal })));
  return {
    http,
    tcp,
    log: () => log,
    // SIGTERM, and the daemon must exit cleanly (0): a crash or a sanitizer report fails the test.
    async stop() {
      proc.kill("SIGTERM");
      const r = await Promise.race([exited, sleep(10000).then(() => null)]);
      if (!r) {
        proc.kill("SIGKILL");
        throw new Error(`lec serve did not stop within 10 s of SIGTERM\n${log}`);
      }
      if (r.code !== 0) throw new Error(`lec serve exited with ${r.code ?? r.signal}\n${log}`);
    },
  };
}

export async function launch() {
  return chromium.launch({
    executablePath: CHROMIUM,
    headless: true,
    args: [
      "--no-sandbox",
      "--disable-gpu",
      "--disable-quic",
      "--no-first-run",
      "--disable-background-networking",
      "--disable-component-update",
      "--disable-sync",
    ],
  });
}

// A page on the dashboard, failing the test on any error the page logs.
export async function open(browser, daemon, hash = "#/overview", viewport = DESKTOP) {
  const context = await browser.newContext({ viewport, acceptDownloads: true });
  const page = await context.newPage();
  const errors = [];
  page.on("pageerror", (e) => errors.push(String(e)));
  page.on("console", (m) => m.type() === "error" && errors.push(m.text()));
  page.errors = errors;
  await page.goto(`${daemon.http}/${hash}`);
  await page.waitForSelector("#link:text('live')");
  return page;
}

export async function shot(page, name) {
  mkdirSync(ARTIFACTS, { recursive: true });
  await page.screenshot({ path: join(ARTIFACTS, `${name}.png`), fullPage: false });
}

export async function api(daemon, path, init = {}) {
  const res = await fetch(`${daemon.http}${path}`, {
    ...init,
    body: init.body && typeof init.body !== "string" ? JSON.stringify(init.body) : init.body,
  });
  const text = await res.text();
  let body;
  try {
    body = JSON.parse(text);
  } catch {
    body = text;
  }
  return { status: res.status, body };
}

// The `lec` CLI through the daemon's Modbus TCP listener.
export async function lec(daemon, ...args) {
  const { stdout } = await promisify(execFile)(LEC, ["--port", daemon.tcp, ...args], { timeout: 30000 });
  return stdout;
}

export async function lecJson(daemon, ...args) {
  return JSON.parse(await lec(daemon, "--json", ...args));
}

// Serial mode, servo on, homed: through the API, for tests about something else.
export async function ready(daemon, axis = "axis1") {
  for (const [op, body] of [["serial", { on: true }], ["servo", { on: true }], ["home", {}]]) {
    const r = await api(daemon, `/api/axes/${axis}/${op}`, { method: "POST", body });
    if (r.status !== 200) throw new Error(`${op}: ${JSON.stringify(r.body)}`);
  }
}

// Polls a condition until it holds, or fails after `ms` with `what`.
export async function until(what, fn, ms = 15000) {
  const deadline = Date.now() + ms;
  let last;
  while (Date.now() < deadline) {
    last = await fn();
    if (last) return last;
    await sleep(50);
  }
  throw new Error(`timed out after ${ms} ms waiting for ${what} (last: ${JSON.stringify(last)})`);
}

export function sleep(ms) {
  return new Promise((ok) => setTimeout(ok, ms));
}

export function writeTemp(name, text) {
  const dir = mkdtempSync(join(tmpdir(), "lec6-web-"));
  const path = join(dir, name);
  writeFileSync(path, text);
  return path;
}
