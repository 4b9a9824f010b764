// A speed out of range: the field says so, nothing can be written, and the
// controller, read back, is unchanged.
import { test, after, before } from "node:test";
import assert from "node:assert/strict";
import { api, launch, lec, open, shot, startDaemon } from "./harness.mjs";

let daemon, browser;
before(async () => {
  daemon = await startDaemon({ ids: "1" });
  browser = await launch();
  const r = await api(daemon, "/api/axes/axis1/steps/3", { method: "PUT", body: { position_mm: 80, speed_mm_s: 300, pushing_force_pct: 50, trigger_level_pct: 40 } });
  assert.equal(r.status, 200, JSON.stringify(r.body));
});
after(async () => {
  await browser?.close();
  await daemon?.stop();
});

const cell = (step, field) => `.grid [data-step="${step}"][data-field="${field}"]`;

test("a speed out of range shows a field error and writes nothing", async () => {
  const before = await lec(daemon, "step", "get", "3");
  const page = await open(browser, daemon, "#/steps/axis1");
  await page.waitForSelector(cell(3, "speed_mm_s"));
  await page.fill(cell(3, "speed_mm_s"), "70000");
  assert.match(await page.getAttribute(cell(3, "speed_mm_s"), "class"), /\bbad\b/);
  assert.match(await page.getAttribute(cell(3, "speed_mm_s"), "title"), /speed 70000 mm\/s is out of range: allowed 1 to 65535 mm\/s/);
  assert.match(await page.locator(".field-errors").first().textContent(), /step 3: speed 70000 mm\/s is out of range/);
  const write = page.locator(".toolbar button.primary");
  assert.equal(await write.isDisabled(), true);
  assert.match(await write.getAttribute("title"), /fix the field errors first/);
  // The rule between fields, as typed: trigger level above the pushing force.
  await page.fill(cell(3, "trigger_level_pct"), "60");
  assert.match(await page.getAttribute(cell(3, "trigger_level_pct"), "title"), /trigger level exceeds pushing force \(60 > 50\)/);
  // A length takes at most two decimals (the controller's 0.01 mm).
  await page.fill(cell(3, "position_mm"), "80.125");
  assert.match(await page.getAttribute(cell(3, "position_mm"), "title"), /at most 2 decimals/);
  await shot(page, "steps-field-errors");
  // Clicking anyway does nothing: no dialog, no request.
  await write.click({ force: true });
  assert.equal(await page.locator("dialog.modal").count(), 0);
  assert.equal(await lec(daemon, "step", "get", "3"), before);
  // And the daemon refuses the same value on its own.
  const r = await api(daemon, "/api/axes/axis1/steps/3", { method: "PUT", body: { speed_mm_s: 70000 } });
  assert.equal(r.status, 400);
  assert.equal(await lec(daemon, "step", "get", "3"), before);
  assert.deepEqual(page.errors, []);
});
