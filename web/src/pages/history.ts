// History: per axis, the odometer, service notices, drift warnings (each
// linking to the moves that caused it) and a trend plot per group of
// comparable moves (duration, peak thrust, settle time), from
// GET /api/axes/{name}/health?trend=1 and /history (docs/history.md).
// Refreshed when lec serve reports a new record (SSE "health").
import uPlot from "uplot";
import "uplot/dist/uPlot.min.css";
import type { Ctx, Page } from "../app";
import { get } from "../api";
import { h, setText } from "../dom";

interface TrendPoint {
  id: number;
  start_ms: number;
  duration_s: number;
  peak_thrust_pct: number | null;
  settle_s: number;
}
interface Group {
  group_id: number;
  group: string;
  moves: number;
  baseline: Record<string, { reference: number; spread: number }> | null;
  trend?: TrendPoint[];
}
interface Warning {
  group_id: number;
  metric: string;
  drift_pct: number;
  since: string;
  moves: number[];
  message: string;
}
interface Health {
  ok: boolean;
  odometer: { moves: number; distance_m: number; motion_h: number; pushes: number; alarms: number };
  service: { what: string; message: string }[];
  warnings: Warning[];
  groups: Group[];
  storage: { disabled?: string };
}
interface MotionRecord {
  id: number;
  start: string;
  kind: string;
  source: string;
  outcome: string;
  target_mm: number | null;
  duration_s: number;
  settle_s: number | null;
  peak_thrust_pct: number | null;
}

const num = (v: number | null | undefined, d: number) => (v == null ? "–" : v.toFixed(d));

function trendPlot(host: HTMLElement, g: Group): uPlot | null {
  const pts = g.trend ?? [];
  if (pts.length === 0) return null;
  const data: uPlot.AlignedData = [
    pts.map((_p, i) => i + 1),
    pts.map((p) => p.duration_s),
    pts.map((p) => p.peak_thrust_pct),
    pts.map((p) => p.settle_s),
  ];
  return new uPlot(
    {
      width: Math.max(300, host.clientWidth || 600),
      height: 180,
      scales: { x: { time: false } },
      series: [
        { label: "move" },
        { label: "Duration", scale: "s", stroke: "#1f6feb", width: 1.5, value: (_u, v) => `${num(v, 3)} s` },
        { label: "Peak thrust", scale: "%", stroke: "#16a34a", width: 1.5, value: (_u, v) => `${num(v, 0)} %` },
        { label: "Settle", scale: "s", stroke: "#d97706", width: 1, value: (_u, v) => `${num(v, 3)} s` },
      ],
      axes: [{}, { scale: "s", label: "s" }, { scale: "%", label: "%", side: 1, grid: { show: false } }],
    },
    data,
    host,
  );
}

export function historyPage(ctx: Ctx, param?: string): Page {
  const names = [...ctx.live.axes.keys()];
  const axis = param && names.includes(param) ? param : names[0];
  const el = h("div", { class: "page history" });
  if (!axis) return { el };
  const url = `/api/axes/${encodeURIComponent(axis)}`;
  const picker = h(
    "div",
    { class: "picker" },
    ...names.map((n) => h("a", { href: `#/history/${encodeURIComponent(n)}`, class: n === axis ? "active" : "" }, n)),
  );
  const odometer = h("p", { class: "odometer" });
  const notices = h("ul", { class: "notices" });
  const warnings = h("ul", { class: "warnings" });
  const groups = h("div", { class: "groups" });
  const movesTitle = h("h3", {}, "Latest moves");
  const moves = h("tbody", {});
  const state = h("p", { class: "muted" });
  let plots: uPlot[] = [];

  const showMoves = async (query: string, title: string) => {
    const r = await get<{ records: MotionRecord[] }>(`${url}/history?${query}`).catch(() => null);
    setText(movesTitle, title);
    moves.replaceChildren(
      ...(r?.records ?? []).map((m) =>
        h(
          "tr",
          { "data-id": String(m.id) },
          h("td", {}, String(m.id)),
          h("td", {}, m.start.replace("T", " ").slice(0, 23)),
          h("td", {}, m.kind),
          h("td", { class: m.outcome === "reached" || m.outcome === "pushed" ? "" : "bad" }, m.outcome),
          h("td", {}, num(m.target_mm, 2)),
          h("td", {}, num(m.duration_s, 3)),
          h("td", {}, num(m.settle_s, 3)),
          h("td", {}, num(m.peak_thrust_pct, 0)),
          h("td", {}, m.source),
        ),
      ),
    );
  };

  const refresh = async () => {
    const hl = await get<Health>(`${url}/health?trend=1`).catch((e: Error) => {
      setText(state, e.message);
      return null;
    });
    if (!hl) return;
    setText(state, hl.storage.disabled ?? "");
    const o = hl.odometer;
    setText(
      odometer,
      `${o.moves} moves · ${(o.distance_m / 1000).toFixed(3)} km · ${o.motion_h.toFixed(2)} h in motion · ${o.pushes} pushes · ${o.alarms} alarms`,
    );
    notices.replaceChildren(...hl.service.map((s) => h("li", { class: "bad" }, `Service due: ${s.message}`)));
    warnings.replaceChildren(
      ...(hl.warnings.length
        ? hl.warnings.map((w) => {
            const link = h("a", { href: `#/history/${encodeURIComponent(axis)}`, class: "moves-link" }, `the ${w.moves.length} moves`);
            link.addEventListener("click", (ev) => {
              ev.preventDefault();
              const newest = Math.max(...w.moves);
              void showMoves(`before=${newest + 1}&limit=${w.moves.length}`, `Moves behind the warning on group #${w.group_id}`);
            });
            return h("li", { class: "bad warning", "data-group": String(w.group_id) }, `${w.message} — `, link);
          })
        : [h("li", { class: "muted" }, "no drift warning")]),
    );
    plots.forEach((p) => p.destroy());
    plots = [];
    groups.replaceChildren();
    for (const g of hl.groups) {
      const host = h("div", { class: "trend" });
      groups.appendChild(
        h(
          "section",
          { class: "panel", "data-group": String(g.group_id) },
          h("h3", {}, `#${g.group_id} ${g.group} `, h("span", { class: "muted" }, `${g.moves} moves${g.baseline ? "" : ", learning its baseline"}`)),
          host,
        ),
      );
      const p = trendPlot(host, g);
      if (p) plots.push(p);
    }
  };

  el.append(
    picker,
    h("section", { class: "panel" }, h("h2", {}, `${axis} `, h("span", { class: "muted" }, "odometer")), odometer, notices, state),
    h("section", { class: "panel" }, h("h3", {}, "Drift warnings"), warnings),
    groups,
    h(
      "section",
      { class: "panel" },
      movesTitle,
      h(
        "table",
        { class: "moves" },
        h(
          "thead",
          {},
          h("tr", {}, ...["id", "start (UTC)", "kind", "outcome", "target mm", "time s", "settle s", "thrust %", "source"].map((t) => h("th", {}, t))),
        ),
        moves,
      ),
    ),
  );
  void refresh();
  void showMoves("limit=20", "Latest moves");
  let pending = false;
  const off = ctx.live.health.on((data) => {
    if (data.axis !== axis || pending) return;
    pending = true; // at most one refresh in flight, however fast the moves come
    setTimeout(() => {
      pending = false;
      void refresh();
      void showMoves("limit=20", "Latest moves");
    }, 250);
  });
  return {
    el,
    destroy: () => {
      off();
      plots.forEach((p) => p.destroy());
    },
  };
}
