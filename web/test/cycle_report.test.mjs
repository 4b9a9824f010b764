// `lec cycle run --report FILE.html` (docs/cycles.md): the standalone report
// of the example cycle on the twin, opened in chromium from the file. The
// Gantt chart has a lane per axis and one for the line, a bar per activity
// inside the chart, the critical path outlined, the figures add up, and the
// page needs nothing but itself (no script, no request).
import { test, after, before } from "node:test";
import assert from "node:assert/strict";
import { execFile } from "node:child_process";
import { mkdtempSync } from "node:fs";
import { tmpdir } from "node:os";
import { join, resolve } from "node:path";
import { promisify } from "node:util";
import { LEC, launch, shot, DESKTOP } from "./harness.mjs";

const here = new URL(".", import.meta.url).pathname;
const example = resolve(here, "../../examples/cycles/pick-place.yaml");
let browser, report, json;

before(async () => {
  const dir = mkdtempSync(join(tmpdir(), "lec6-cycle-report-"));
  report = join(dir, "pick-place.html");
  await promisify(execFile)(LEC, ["cycle", "run", example, "--port", "sim", "--report", report]);
  json = JSON.parse((await promisify(execFile)(LEC, ["--json", "cycle", "run", example, "--port", "sim"])).stdout);
  browser = await launch();
});
after(async () => {
  await browser?.close();
});

test("the report shows the cycle's Gantt chart and where its time went", async () => {
  const context = await browser.newContext({ viewport: DESKTOP });
  const page = await context.newPage();
  const requests = [];
  page.on("request", (r) => requests.push(r.url()));
  const errors = [];
  page.on("pageerror", (e) => errors.push(String(e)));
  await page.goto(`file://${report}`);
  assert.deepEqual(requests, [`file://${report}`], "the page loads nothing else");
  assert.deepEqual(errors, []);
  assert.match(await page.locator("#ended").textContent(), /Completed: 2 passes/);

  // A lane per axis, then the dwells and the line.
  const lanes = await page.locator("#gantt text.lane").allTextContents();
  assert.deepEqual(lanes, ["x", "z", "dwell", "line"]);
  // One bar per activity of the run, each inside the chart and at least a pixel wide.
  const activities = json.steps.reduce((n, s) => n + s.axes.length, 0);
  const bars = page.locator("#gantt rect.bar");
  assert.equal(await bars.count(), activities);
  const chart = await page.locator("#gantt").boundingBox();
  assert.ok(chart.width <= DESKTOP.width, `chart ${chart.width} px wide`);
  for (const box of await bars.evaluateAll((els) => els.map((e) => e.getBoundingClientRect().toJSON()))) {
    assert.ok(box.width >= 1 && box.left >= chart.x - 0.5 && box.right <= chart.x + chart.width + 0.5, JSON.stringify(box));
  }
  // The critical path runs through one member of every step: the one that ended last.
  assert.equal(await page.locator("#gantt rect.bar.critical").count(), json.steps.length);
  for (const [i, s] of json.analysis.steps.entries()) {
    const last = Math.max(...json.steps[i].axes.map((a) => a.end_s));
    const bar = page.locator(`#gantt rect.bar.critical[data-step="${json.steps[i].step}"]`);
    assert.equal(await bar.getAttribute("data-axis"), s.critical_axis, `step ${s.step}`);
    assert.equal(json.steps[i].axes.find((a) => a.end_s === last).axis, s.critical_axis, `step ${s.step}`);
  }
  assert.ok((await page.locator("#gantt rect.line").count()) > 0, "the line's share has its lane");
  // Motion + line + dwells = the cycle time, as printed.
  const figure = async (id) => Number.parseFloat(await page.locator(`[data-figure=${id}] b`).textContent());
  const sum = (await figure("motion")) + (await figure("line")) + (await figure("program"));
  assert.ok(Math.abs(sum - (await figure("cycle"))) <= 0.003, `shares ${sum} vs cycle ${await figure("cycle")}`);
  assert.equal(await page.locator("#steps tr").count(), json.steps.length + 1);
  await shot(page, "cycle-report");
  await context.close();
});
