// The history page (docs/history.md): the odometer, a trend plot per group
// of comparable moves, and a drift warning that links to its moves. The twin
// wears fast (wear_pct_per_m) and the baseline is short, so a repeated move
// drifts past +10 % within a few dozen moves.
import { test, after, before } from "node:test";
import assert from "node:assert/strict";
import { mkdtempSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { api, launch, open, ready, shot, startDaemon, until } from "./harness.mjs";

let daemon, browser;
before(async () => {
  const state = mkdtempSync(join(tmpdir(), "lec6-history-web-"));
  daemon = await startDaemon({
    config: `lines:
  - port: sim
    sim: {timing: fast, wear_pct_per_m: 40}
    axes: [{id: 1, name: axis1, telemetry_hz: 20}]
http: {listen: "127.0.0.1:0"}
history: {state_dir: ${state}, drift_baseline_moves: 5}
`,
  });
  browser = await launch();
});
after(async () => {
  await browser?.close();
  await daemon?.stop();
});

test("history: odometer, trend plot per group, and a drift warning linking to its moves", async () => {
  await ready(daemon);
  const page = await open(browser, daemon, "#/history/axis1");
  await page.locator(".odometer", { hasText: "1 moves" }).waitFor();
  // A repeated move on a wearing twin, until the history warns.
  let warned = null;
  for (let i = 0; i < 80 && !warned; ++i) {
    const r = await api(daemon, "/api/axes/axis1/move", {
      method: "POST",
      body: { position_mm: i % 2 ? 20 : 160, speed_mm_s: 400 },
    });
    assert.equal(r.status, 200, JSON.stringify(r.body));
    const h = (await api(daemon, "/api/axes/axis1/health")).body;
    if (h.warnings.length) warned = h.warnings[0];
  }
  assert.ok(warned, "no drift warning after 80 moves on a twin wearing 40 %/m");
  // The page shows it (a health event refreshes it), with a plot per group.
  const item = page.locator("li.warning").first();
  await item.waitFor();
  assert.ok((await item.textContent()).includes("rose"), await item.textContent());
  await page.locator(".groups section .uplot").first().waitFor();
  assert.ok((await page.locator(".groups section .uplot canvas").count()) >= 1, "the trend plot draws");
  // Its link shows the moves behind it.
  await item.locator("a.moves-link").click();
  const ids = warned.moves.map(String);
  await until("the warning's moves in the table", async () => {
    const shown = await page.locator("table.moves tbody tr").evaluateAll((rows) => rows.map((r) => r.dataset.id));
    return ids.every((id) => shown.includes(id));
  });
  await shot(page, "history-desktop");
  assert.deepEqual(page.errors, []);
});
