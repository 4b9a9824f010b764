// Restore upload: a file with a bad row shows its errors in the preview and
// writes nothing; a good file shows its diff first, then writes only that.
import { test, after, before } from "node:test";
import assert from "node:assert/strict";
import { api, launch, lec, open, shot, startDaemon, writeTemp } from "./harness.mjs";

let daemon, browser, backup;
before(async () => {
  daemon = await startDaemon({ ids: "1" });
  browser = await launch();
  for (const [step, body] of [[1, { position_mm: 50, speed_mm_s: 200 }], [2, { position_mm: 100, speed_mm_s: 250 }]]) {
    const r = await api(daemon, `/api/axes/axis1/steps/${step}`, { method: "PUT", body });
    assert.equal(r.status, 200, JSON.stringify(r.body));
  }
  backup = (await api(daemon, "/api/axes/axis1/steps?format=csv")).body;
});
after(async () => {
  await browser?.close();
  await daemon?.stop();
});

// The backup with rows changed: { step: [column, value] }.
function edited(changes) {
  const lines = backup.split("\n");
  const header = lines.find((l) => l.startsWith("step,")).split(",");
  return lines
    .map((l) => {
      const cells = l.split(",");
      const change = changes[cells[0]];
      if (!change || l.startsWith("#")) return l;
      cells[header.indexOf(change[0])] = change[1];
      return cells.join(",");
    })
    .join("\n");
}

test("a backup file with a bad row: the preview shows the error and nothing is written", async () => {
  const before1 = await lec(daemon, "step", "get", "1");
  const before2 = await lec(daemon, "step", "get", "2");
  // Step 1 changed (valid), step 2 with a speed of 0 (out of range).
  const file = writeTemp("bad.csv", edited({ 1: ["speed_mm_s", "222"], 2: ["speed_mm_s", "0"] }));
  const page = await open(browser, daemon, "#/steps/axis1");
  await page.waitForSelector('.grid [data-step="2"][data-field="speed_mm_s"]');
  await page.setInputFiles("#restore-file", file);
  const dialog = page.locator("dialog.modal");
  await dialog.waitFor();
  assert.match(await dialog.locator("h3").textContent(), /not restored/);
  assert.match(await dialog.textContent(), /Nothing was written/);
  assert.match(await dialog.locator(".field-errors li").first().textContent(), /step 2.*speed.*0.*out of range/i);
  await shot(page, "steps-restore-bad-row");
  assert.equal(await dialog.locator("button.primary").count(), 0, "no way to write from an error preview");
  await dialog.locator('button:text("Close")').click();
  assert.equal(await lec(daemon, "step", "get", "1"), before1);
  assert.equal(await lec(daemon, "step", "get", "2"), before2);
  // The plan's refusal (400, the file's errors) is the one console line:
  // chromium logs every fetch answered 4xx.
  assert.deepEqual(page.errors, ["Failed to load resource: the server responded with a status of 400 (Bad Request)"]);
});

test("a good backup file: the preview shows the diff, then only that is written", async () => {
  const file = writeTemp("good.csv", edited({ 1: ["speed_mm_s", "222"] }));
  const page = await open(browser, daemon, "#/steps/axis1");
  await page.waitForSelector('.grid [data-step="1"][data-field="speed_mm_s"]');
  await page.setInputFiles("#restore-file", file);
  const dialog = page.locator("dialog.modal");
  await dialog.waitFor();
  assert.match(await dialog.textContent(), /1 step to write, 63 unchanged/);
  assert.deepEqual(await dialog.locator("table.diff tbody tr").allTextContents(), ["1Speed200222"]);
  await shot(page, "steps-restore-preview");
  await dialog.locator('button:text("Restore 1 step")').click();
  await page.waitForSelector('.status:text("1 step written, 63 unchanged")', { timeout: 20000 });
  assert.match(await lec(daemon, "step", "get", "1"), /speed\D+222\b/i);
  assert.equal(await page.inputValue('.grid [data-step="1"][data-field="speed_mm_s"]'), "222");
  assert.deepEqual(page.errors, []);
});
