// Bus: per line, transactions/s and utilisation over time, queue depths and
// latency per priority, a latency histogram, and errors per controller ID.
import uPlot from "uplot";
import { clockAxis, clockTime } from "../plot";
import type { Ctx, Page } from "../app";
import { h } from "../dom";
import type { Line, LineStats } from "../types";

const TREND_S = 300;

export function busPage(ctx: Ctx): Page {
  const el = h("div", { class: "page bus" });
  const updates: ((s: LineStats) => void)[] = [];
  const plots: uPlot[] = [];
  for (const line of ctx.lines) {
    const { section, update, charts } = lineSection(line);
    el.appendChild(section);
    plots.push(...charts);
    updates.push(update);
    const s = ctx.live.stats.get(line.name) ?? line.stats;
    update(s);
  }
  const off = ctx.live.statsUpdate.on((stats) =>
    ctx.lines.forEach((l, n) => {
      const s = stats.get(l.name);
      if (s) updates[n](s);
    }),
  );
  return {
    el,
    destroy: () => {
      off();
      plots.forEach((p) => p.destroy());
    },
  };
}

function lineSection(line: Line) {
  const summary = h("div", { class: "readout" });
  const utilBar = h("span", { class: "bar-fill" });
  const queues = h("tbody", {});
  const devices = h("tbody", {});
  const trendHost = h("div", { class: "chart" });
  const histHost = h("div", { class: "chart" });
  const trend: number[][] = [[], [], []];
  const trendPlot = new uPlot(
    {
      width: 480,
      height: 180,
      // tx/s from 0 (with a minimum span): 42.4 to 42.5 made noise look like a collapse.
      scales: { x: { time: true }, pct: { range: [0, 100] }, tps: { range: (_u, _min, max) => [0, Math.max(10, max * 1.15)] } },
      series: [
        { value: (_u, v) => (v == null ? "" : clockTime(v)) },
        { label: "transactions/s", stroke: "#1f6feb", width: 1.5, scale: "tps" },
        { label: "utilisation %", stroke: "#d97706", width: 1.5, scale: "pct" },
      ],
      axes: [clockAxis, { scale: "tps", label: "tx/s" }, { scale: "pct", side: 1, label: "%", grid: { show: false } }],
    },
    trend as uPlot.AlignedData,
    trendHost,
  );
  let labels: string[] = [];
  const histPlot = new uPlot(
    {
      width: 480,
      height: 180,
      scales: { x: { time: false } },
      series: [{}, { label: "exchanges", fill: "#1f6feb88", stroke: "#1f6feb", paths: uPlot.paths.bars!({ size: [0.8] }), points: { show: false } }],
      axes: [{ values: (_u, ticks) => ticks.map((t) => labels[t] ?? ""), label: "latency ≤ ms" }, { label: "count" }],
    },
    [[], []],
    histHost,
  );
  const section = h(
    "section",
    { class: "panel", "data-line": line.name },
    h("h2", {}, `${line.name} `, h("span", { class: "muted" }, busTitle(line))),
    summary,
    h("div", { class: "thrust" }, h("label", {}, "Utilisation of the line's limit"), h("span", { class: "bar" }, utilBar)),
    h("div", { class: "charts" }, h("figure", {}, trendHost), h("figure", {}, histHost)),
    h("h3", {}, "Queues and latency by priority"),
    h("table", { class: "stats" }, h("thead", {}, h("tr", {}, ...["Priority", "Queued", "Exchanges", "p50 ms", "p99 ms"].map((t) => h("th", {}, t)))), queues),
    h("h3", {}, "Errors per controller"),
    h(
      "table",
      { class: "stats" },
      h("thead", {}, h("tr", {}, ...["ID", "Axis", "Exchanges", "Answers", "Timeouts", "CRC", "Framing", "Exceptions", "Error %"].map((t) => h("th", {}, t)))),
      devices,
    ),
  );

  const update = (s: LineStats) => {
    const util = s.utilisation * 100;
    summary.replaceChildren(
      stat("Transactions/s", s.transactions_per_s.toFixed(1)),
      stat("Utilisation", `${util.toFixed(1)} %`),
      stat("Busy", `${(s.busy * 100).toFixed(1)} %`),
      stat("Exchanges", String(s.transactions)),
      stat("Cache hits", String(s.cache_hits)),
    );
    utilBar.style.width = `${Math.min(100, util)}%`;
    const now = Date.now() / 1000;
    trend[0].push(now);
    trend[1].push(s.transactions_per_s);
    trend[2].push(util);
    while (trend[0].length && trend[0][0] < now - TREND_S) trend.forEach((c) => c.shift());
    trendPlot.setData(trend as uPlot.AlignedData);
    const prios = Object.entries(s.priorities);
    queues.replaceChildren(
      ...prios.map(([name, p]) =>
        h("tr", {}, h("td", {}, name), num(p.queue_depth), num(p.count), num(p.p50_ms.toFixed(1)), num(p.p99_ms.toFixed(1))),
      ),
    );
    // The buckets are cumulative (≤ bound), as in Prometheus: per-bucket counts are the steps.
    const le = prios[0]?.[1].buckets_le_ms ?? [];
    labels = le.map(String);
    const counts = le.map((_b, i) => prios.reduce((sum, [, p]) => sum + p.buckets[i] - (i ? p.buckets[i - 1] : 0), 0));
    histPlot.setData([le.map((_b, i) => i), counts]);
    devices.replaceChildren(
      ...s.devices.map((d) => {
        const errors = d.timeouts + d.crc_errors + d.framing_errors;
        const pct = d.transactions ? (errors / d.transactions) * 100 : 0;
        return h(
          "tr",
          { class: errors ? "warn" : "" },
          num(d.id), h("td", {}, d.axis), num(d.transactions), num(d.answers), num(d.timeouts),
          num(d.crc_errors), num(d.framing_errors), num(d.exceptions), num(pct.toFixed(2)),
        );
      }),
    );
  };
  const resize = new ResizeObserver(() => {
    const w = Math.max(280, Math.floor((section.clientWidth - 48) / 2));
    trendPlot.setSize({ width: w, height: 180 });
    histPlot.setSize({ width: w, height: 180 });
  });
  resize.observe(section);
  return { section, update, charts: [trendPlot, histPlot] };
}

const stat = (label: string, value: string) => h("div", {}, h("label", {}, label), h("span", { class: "num big" }, value));
const num = (v: number | string) => h("td", { class: "num" }, String(v));

// Port and baud once: a serial line's description already says both
// ("/dev/ttyUSB0 @ 38400"), the twin's says neither.
function busTitle(line: { port: string; describe: string; baud: number }): string {
  const parts = line.describe.startsWith(line.port) ? [line.describe] : [line.port, line.describe];
  if (!line.describe.includes(`@ ${line.baud}`)) parts.push(`${line.baud} baud`);
  return parts.join(" · ");
}
