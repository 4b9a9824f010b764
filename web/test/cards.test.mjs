// The overview: one card per axis, showing the twin's position and lamps.
import { test, after, before } from "node:test";
import assert from "node:assert/strict";
import { api, launch, open, shot, startDaemon, PANEL, until } from "./harness.mjs";

let daemon, browser;
before(async () => {
  daemon = await startDaemon({ ids: "1-4" });
  browser = await launch();
});
after(async () => {
  await browser?.close();
  await daemon?.stop();
});

test("each axis has a card with the twin's position", async () => {
  const page = await open(browser, daemon, "#/overview");
  const axes = (await api(daemon, "/api/axes")).body;
  assert.equal(axes.length, 4);
  assert.equal(await page.locator(".card").count(), 4);
  for (const a of axes) {
    const card = page.locator(`.card[data-axis="${a.name}"]`);
    await until(`${a.name}'s position`, async () => (await card.locator("[data-k=position]").textContent()) === a.position_mm.toFixed(2));
    assert.match(await card.locator("h2").textContent(), new RegExp(`${a.name}\\s*ID ${a.id}`));
    // The twin powers on with the servo off, in parallel mode: SVRE and SERIAL dark.
    assert.equal(await card.locator('[data-lamp="SVRE"]').getAttribute("class"), "lamp");
    assert.equal(await card.locator('[data-lamp="SERIAL"]').getAttribute("class"), "lamp");
    assert.match(await card.locator("[data-k=health]").textContent(), /last answer \d+ ms ago · errors \d+\.\d %/);
    for (const lamp of ["BUSY", "SVRE", "SETON", "INP", "AREA", "WAREA", "ESTOP", "ALARM", "OUT0", "OUT5", "IN0", "IN5", "SETUP", "HOLD", "DRIVE", "RESET", "SVON", "SERIAL"]) {
      assert.equal(await card.locator(`[data-lamp="${lamp}"]`).count(), 1, `${a.name}: lamp ${lamp}`);
    }
  }
  // A change on the controller reaches the card by push: serial mode on axis2 lights its lamp.
  assert.equal((await api(daemon, "/api/axes/axis2/serial", { method: "POST", body: { on: true } })).status, 200);
  await page.waitForSelector('.card[data-axis="axis2"] [data-lamp="SERIAL"].on', { timeout: 5000 });
  await shot(page, "overview-desktop");
  await page.setViewportSize(PANEL);
  await shot(page, "overview-1024x768");
  // At 1024×768 all four cards fit without scrolling.
  const bottom = await page.locator(".card").last().evaluate((e) => e.getBoundingClientRect().bottom);
  assert.ok(bottom <= PANEL.height, `the last card ends at ${bottom} px, below the panel's ${PANEL.height}`);
  assert.deepEqual(page.errors, []);
});
