// Alarms, bus and twin pages, and the access rules (read-only, token) as a
// page shows them; a screenshot of each at desktop and 1024×768 sizes.
import { test, after, before } from "node:test";
import assert from "node:assert/strict";
import { api, launch, open, shot, startDaemon, until, PANEL } from "./harness.mjs";

let daemon, browser;
before(async () => {
  daemon = await startDaemon({ ids: "1-4", args: ["--telemetry-hz", "20"] });
  browser = await launch();
});
after(async () => {
  await browser?.close();
  await daemon?.stop();
});

async function both(page, name) {
  await shot(page, `${name}-desktop`);
  await page.setViewportSize(PANEL);
  await shot(page, `${name}-1024x768`);
}

test("alarms: an active alarm with its meaning, the history, and a reset", async () => {
  // A direct move to 500 mm on a 400 mm stroke: the controller refuses it
  // with alarm 62 (resettable by RESET).
  for (const [op, body] of [["serial", { on: true }], ["servo", { on: true }], ["home", {}]]) {
    const r = await api(daemon, `/api/axes/axis1/${op}`, { method: "POST", body });
    assert.equal(r.status, 200, JSON.stringify(r.body));
  }
  await api(daemon, "/api/axes/axis1/move", { method: "POST", body: { position_mm: 500 } });
  await until("ALARM on axis1", async () => (await api(daemon, "/api/axes/axis1")).body.flags.alarm);
  const page = await open(browser, daemon, "#/alarms");
  const section = page.locator('section[data-axis="axis1"]');
  await section.locator(".active-alarms li.bad").waitFor();
  const active = await section.locator(".active-alarms").textContent();
  const expected = (await api(daemon, "/api/axes/axis1/alarms")).body;
  assert.equal(expected.alarms[0].code, 62);
  assert.ok(active.includes(`62: ${expected.alarms[0].meaning}`), active);
  await section.locator("table.history td", { hasText: "62:" }).first().waitFor();
  await both(page, "alarms");
  await page.setViewportSize({ width: 1600, height: 1000 });
  await section.locator('button:text("RESET")').click();
  await section.locator(".active-alarms li", { hasText: "no alarm active" }).waitFor();
  assert.equal((await api(daemon, "/api/axes/axis1")).body.flags.alarm, false);
  assert.deepEqual(page.errors, []);
});

test("bus: transactions/s, utilisation, latency, queues and errors per ID", async () => {
  const page = await open(browser, daemon, "#/bus");
  const section = page.locator('section[data-line="line1"]');
  // The stats event arrives once a second; the figures are the daemon's.
  await until("a transaction rate", async () => Number((await section.locator(".readout .big").first().textContent()) || 0) > 0);
  assert.equal(await section.locator("table.stats").nth(1).locator("tbody tr").count(), 4);
  assert.deepEqual(
    await section.locator("table.stats").nth(1).locator("tbody tr td:first-child").allTextContents(),
    ["1", "2", "3", "4"],
  );
  assert.ok(await section.locator("table.stats").first().locator("tbody tr", { hasText: "telemetry" }).count());
  assert.equal(await section.locator(".charts canvas").count(), 2);
  await page.waitForTimeout(2500); // a few points on the trend for the screenshot
  await both(page, "bus");
  assert.deepEqual(page.errors, []);
});

test("twin: fault-injection rates applied from the page", async () => {
  const page = await open(browser, daemon, "#/twin");
  const section = page.locator('section[data-line="line1"]');
  await until("the twin's settings", async () => (await section.locator('input[name="drop_rate"]').inputValue()) !== "");
  await section.locator('input[name="drop_rate"]').fill("5");
  await section.locator('button:text("Apply")').click();
  await section.locator(".status", { hasText: "applied" }).waitFor();
  assert.equal((await api(daemon, "/api/lines/line1/twin")).body.drop_rate, 0.05);
  await both(page, "twin");
  await page.setViewportSize({ width: 1600, height: 1000 });
  await section.locator('input[name="drop_rate"]').fill("0");
  await section.locator('button:text("Apply")').click();
  await until("drop rate back to 0", async () => (await api(daemon, "/api/lines/line1/twin")).body.drop_rate === 0);
  assert.deepEqual(page.errors, []);
});

test("twin: the workpiece position", async () => {
  const twin = (await api(daemon, "/api/lines/line1/twin")).body;
  assert.ok("workpiece_mm" in twin, JSON.stringify(twin));
  const page = await open(browser, daemon, "#/twin");
  const section = page.locator('section[data-line="line1"]');
  await section.locator('input[name="workpiece_mm"]').fill("300");
  await section.locator('button:text("Apply")').click();
  await section.locator(".status", { hasText: "applied" }).waitFor();
  assert.equal((await api(daemon, "/api/lines/line1/twin")).body.workpiece_mm, 300);
});

test("a read-only listener shows a read-only page", async () => {
  const ro = await startDaemon({
    config: `lines:
  - name: line1
    port: sim
    axes: [{id: 1, name: axis1}]
    modbus_tcp: {listen: "127.0.0.1:0"}
http: {listen: "127.0.0.1:0", read_only: true}
`,
  });
  try {
    const page = await open(browser, ro, "#/axis/axis1");
    assert.equal(await page.locator("#access .badge").textContent(), "read-only");
    const buttons = page.locator(".controls button");
    const n = await buttons.count();
    assert.ok(n >= 10);
    for (let i = 0; i < n; i++) {
      assert.equal(await buttons.nth(i).isDisabled(), true);
      assert.match(await buttons.nth(i).getAttribute("title"), /read-only listener/);
    }
    await shot(page, "axis-read-only");
    await page.goto(`${ro.http}/#/steps/axis1`);
    await page.waitForSelector('.grid [data-step="0"][data-field="speed_mm_s"]');
    assert.equal(await page.locator('.grid [data-step="0"][data-field="speed_mm_s"]').isDisabled(), true);
    assert.deepEqual(page.errors, []);
  } finally {
    await ro.stop();
  }
});

test("a listener with a token: controls wait for it, then work", async () => {
  const tok = await startDaemon({ ids: "1", args: ["--token", "s3cret"] });
  try {
    const page = await open(browser, tok, "#/axis/axis1");
    const serialOn = page.locator('.controls .row:has(> label:text-is("Serial mode")) button:text-is("On")');
    assert.equal(await serialOn.isDisabled(), true);
    assert.match(await serialOn.getAttribute("title"), /enter the token/);
    await page.fill("#access input", "wrong");
    await page.press("#access input", "Enter");
    await page.locator('.controls .row:has(> label:text-is("Serial mode")) button:text-is("On")').click();
    await page.locator(".results li.bad", { hasText: "token" }).waitFor();
    await page.fill("#access input", "s3cret");
    await page.press("#access input", "Enter");
    await page.locator('.controls .row:has(> label:text-is("Serial mode")) button:text-is("On")').click();
    await until("serial mode", async () => (await api(tok, "/api/axes/axis1")).body.inputs?.serial_mode);
    assert.deepEqual(page.errors.filter((e) => !/401/.test(e)), []);
  } finally {
    await tok.stop();
  }
});
