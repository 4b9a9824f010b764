// The axis view: servo on, home and move to 150 mm from the page; the plot
// rises, the card ends at 150.00 with INP lit, the result says "reached".
import { test, after, before } from "node:test";
import assert from "node:assert/strict";
import { api, launch, lecJson, open, shot, startDaemon, PANEL } from "./harness.mjs";

let daemon, browser;
before(async () => {
  daemon = await startDaemon({ ids: "1-2" });
  browser = await launch();
});
after(async () => {
  await browser?.close();
  await daemon?.stop();
});

const card = '.card[data-axis="axis1"]';
const lit = (lamp) => `${card} [data-lamp="${lamp}"].on`;
const row = (label) => `.controls .row:has(> label:text-is("${label}"))`;

test("servo on, home, move to 150 mm: the plot rises and the card ends at 150.00 with INP", async () => {
  const page = await open(browser, daemon, "#/axis/axis1");
  // Before serial mode the motion controls are off, and say why.
  const home = page.locator(`${row("Motion")} button:text-is("Home")`);
  assert.equal(await home.isDisabled(), true);
  // One note per reason, at the first row it applies to (issue 27: repeated
  // notes pushed STOP out of the window).
  assert.match(await page.locator(`${row("Servo")} .reason`).textContent(), /parallel input mode/);
  assert.equal(await page.locator(`${row("Motion")} .reason`).textContent(), "");

  await page.click(`${row("Serial mode")} button:text-is("On")`);
  await page.waitForSelector(lit("SERIAL"));
  assert.equal(await page.locator(`${row("Motion")} .reason`).textContent(), "servo is off");
  await page.click(`${row("Servo")} button:text-is("On")`);
  await page.waitForSelector(lit("SVRE"));
  assert.match(await page.locator(`${row("Run step")} .reason`).textContent(), /not homed/);
  await page.click(`${row("Motion")} button:text-is("Home")`);
  await page.waitForSelector(lit("SETON"), { timeout: 30000 });
  await page.waitForSelector(`.results li[data-op="home"] .outcome:text("reached")`, { timeout: 30000 });

  await page.check("#capture-on-move");
  await page.fill('input[name="position_mm"]', "150");
  await page.fill('input[name="speed_mm_s"]', "200");
  await page.click('button:text-is("Move to")');
  await page.waitForSelector(`.results li[data-op="move"] .outcome:text("reached")`, { timeout: 30000 });
  await page.waitForFunction(
    (sel) => document.querySelector(sel)?.textContent === "150.00",
    `${card} [data-k=position]`,
    { timeout: 5000 },
  );
  await page.waitForSelector(lit("INP"));

  // The plot drew the rise: from near 0 after homing to 150, in time order.
  const [t, pos] = await page.evaluate(() => window.lecPlot.data().slice(0, 2));
  assert.ok(t.length > 20, `only ${t.length} samples on the plot`);
  for (let i = 1; i < t.length; i++) assert.ok(t[i] >= t[i - 1], "time runs forward");
  const rising = pos.filter((p) => p > 1 && p < 149);
  assert.ok(rising.length >= 3, `the plot shows ${rising.length} samples between 1 and 149 mm`);
  assert.ok(Math.min(...pos) < 1 && Math.max(...pos) >= 149.99, `plot spans ${Math.min(...pos)}–${Math.max(...pos)}`);
  // The capture started with the move: its CSV holds the rise and ends in position.
  await page.waitForFunction(() => !window.lecPlot.captureState().capturing);
  const csv = await page.evaluate(() => window.lecPlot.csv());
  const rows = csv.trim().split("\n");
  assert.equal(rows[0], "time_s,position_mm,speed_mm_s,thrust_pct,busy,inp");
  assert.match(rows.at(-1), /^[\d.]+,150\.00,0,\d+,0,1$/);

  // The daemon agrees: the CLI through it sees 150.00 with INP.
  const status = await lecJson(daemon, "status");
  assert.equal(status.position_mm, 150);
  assert.equal(status.flags?.inp ?? status.inp, true);

  // A speed out of range is refused on the page before anything is sent.
  await page.fill('input[name="speed_mm_s"]', "70000");
  assert.match(await page.locator("form.move .field-errors").textContent(), /speed 70000 mm\/s is out of range: allowed 1 to 65535 mm\/s/);

  await shot(page, "axis-desktop");
  await page.setViewportSize(PANEL);
  await shot(page, "axis-1024x768");
  assert.deepEqual(page.errors, []);
  assert.equal((await api(daemon, "/api/axes/axis1")).body.last_result.outcome, "reached");
});
