// The step grid: edit step 3's speed, see the diff, write it; the CLI through
// the daemon reads the new value back from the controller.
import { test, after, before } from "node:test";
import assert from "node:assert/strict";
import { api, launch, lec, open, shot, startDaemon, PANEL } from "./harness.mjs";

let daemon, browser;
before(async () => {
  daemon = await startDaemon({ ids: "1-2" });
  browser = await launch();
  // Step 3 registered, as a commissioned machine would have it.
  const r = await api(daemon, "/api/axes/axis1/steps/3", { method: "PUT", body: { position_mm: 120.5, speed_mm_s: 300 } });
  assert.equal(r.status, 200, JSON.stringify(r.body));
});
after(async () => {
  await browser?.close();
  await daemon?.stop();
});

const cell = (step, field) => `.grid [data-step="${step}"][data-field="${field}"]`;

test("edit step 3's speed in the grid and write it", async () => {
  const page = await open(browser, daemon, "#/steps/axis1");
  await page.waitForSelector(`${cell(3, "speed_mm_s")}`);
  assert.equal(await page.inputValue(cell(3, "speed_mm_s")), "300");
  assert.equal(await page.inputValue(cell(3, "position_mm")), "120.50");
  await page.fill(cell(3, "speed_mm_s"), "450");
  assert.match(await page.getAttribute(cell(3, "speed_mm_s"), "class"), /changed/);
  await page.click('button:text("Write 1 step")');
  // The preview: only step 3's speed, controller 300 → 450.
  const dialog = page.locator("dialog.modal");
  await dialog.waitFor();
  const rows = await dialog.locator("table.diff tbody tr").allTextContents();
  assert.deepEqual(rows, ["3Speed300450"]);
  await shot(page, "steps-write-preview");
  await dialog.locator('button:text("Write 1 step")').click();
  await page.waitForSelector('.status:text("1 step written and read back")', { timeout: 20000 });
  assert.equal(await page.inputValue(cell(3, "speed_mm_s")), "450");

  const out = await lec(daemon, "step", "get", "3");
  assert.match(out, /speed\D+450\b/i, out);
  assert.match(out, /120\.50/, out);

  // A blank step starts from the defaults when edited, so a position is enough.
  await page.fill(cell(5, "position_mm"), "42.00");
  assert.equal(await page.inputValue(cell(5, "mode")), "abs");
  assert.equal(await page.locator(".field-errors li").count(), 0);
  await shot(page, "steps-desktop");
  await page.setViewportSize(PANEL);
  await shot(page, "steps-1024x768");
  assert.deepEqual(page.errors, []);
});
