// The results of commands on one axis, newest first: outcome, message and,
// for motions, the timeline (start, BUSY up, BUSY down, INP) when the daemon
// reports one.
import type { OpResult } from "./types";
import { h } from "./dom";

const KEEP = 8;
const DETAIL_KEYS: [string, string, (v: number) => string][] = [
  ["position_mm", "at", (v) => `${v.toFixed(2)} mm`],
  ["target_mm", "target", (v) => `${v.toFixed(2)} mm`],
  ["elapsed_s", "took", (v) => `${v.toFixed(2)} s`],
];
const TIMELINE: [string, string][] = [
  ["start_ms", "start"],
  ["busy_up_ms", "BUSY↑"],
  ["busy_down_ms", "BUSY↓"],
  ["inp_ms", "INP"],
];

export class ResultList {
  readonly el = h("ol", { class: "results", "aria-label": "results" });

  running(op: string, source: string): void {
    this.add(h("li", { class: "running", "data-op": op }, h("b", {}, op), ` running… (${source})`));
  }

  // Nothing runs on the axis (the daemon says so): a "running…" line whose
  // result came by another way (a refused move answers without its `op`)
  // must not stay (issue 27).
  settle(): void {
    this.el.querySelectorAll("li.running").forEach((li) => li.remove());
  }

  show(r: OpResult, status: number): void {
    // A result replaces the "running…" line of its op (the newest one; a
    // result without an op, as a move the controller refused with an alarm
    // answers: the newest running line, whose op names the result).
    const running = [...this.el.querySelectorAll<HTMLElement>("li.running")];
    const line = running.find((li) => !r.op || li.dataset.op === r.op);
    const op = r.op ?? line?.dataset.op;
    line?.remove();
    const ok = r.ok !== false && status < 400;
    const outcome = r.outcome ? h("span", { class: `outcome ${ok ? "ok" : "bad"}` }, r.outcome) : null;
    const details = DETAIL_KEYS.filter(([k]) => typeof r[k] === "number").map(
      ([k, label, f]) => `${label} ${f(r[k] as number)}`,
    );
    const li = h(
      "li",
      { class: ok ? "ok" : "bad", "data-op": op ?? "" },
      h("b", {}, op ?? "command"),
      " ",
      outcome,
      " ",
      h("span", { class: "message" }, inPageTerms(String(r.message ?? r.error ?? (ok ? "done" : `HTTP ${status}`)))),
      details.length ? h("div", { class: "muted" }, details.join(" · ")) : null,
      r.timeline ? timeline(r.timeline) : null,
    );
    this.add(li);
  }

  private add(li: HTMLElement): void {
    this.el.prepend(li);
    while (this.el.children.length > KEEP) this.el.lastElementChild?.remove();
  }
}

function timeline(t: Record<string, number | null>): HTMLElement {
  const marks = TIMELINE.filter(([k]) => typeof t[k] === "number");
  const start = (t.start_ms as number) ?? 0;
  const end = Math.max(...marks.map(([k]) => t[k] as number), start + 1);
  const bar = h("div", { class: "timeline-bar" });
  for (const [k, label] of marks) {
    const at = t[k] as number;
    const pct = ((at - start) / (end - start)) * 100;
    bar.appendChild(
      h("span", { class: "mark", style: `left:${pct.toFixed(1)}%`, title: `${label} at ${Math.round(at - start)} ms` }),
    );
  }
  const missing = TIMELINE.filter(([k]) => k in t && t[k] === null).map(([, l]) => `${l} never`);
  return h(
    "div",
    { class: "timeline" },
    bar,
    h(
      "div",
      { class: "muted" },
      [...marks.map(([k, l]) => `${l} ${Math.round((t[k] as number) - start)} ms`), ...missing].join(" · "),
    ),
  );
}

// The daemon's advice names HTTP requests (client/action_words.hpp); on this
// page the same action is a button (issue 27).
const BUTTONS: [RegExp, string][] = [
  [/`POST \/api\/axes\/[^/`]+\/serial \{"on": true\}`/g, "the Serial mode “On” button"],
  [/`POST \/api\/axes\/[^/`]+\/servo \{"on": true\}`/g, "the Servo “On” button"],
  [/`POST \/api\/axes\/[^/`]+\/servo \{"on": false\}`/g, "the Servo “Off” button"],
  [/`POST \/api\/axes\/[^/`]+\/home`/g, "the “Home” button"],
  [/`POST \/api\/axes\/[^/`]+\/reset`/g, "the “RESET” button"],
  [/`POST \/api\/axes\/[^/`]+\/stop`/g, "the “STOP” button"],
  [/`(PUT|GET) \/api\/axes\/[^/`]+\/steps[^`]*`/g, "the Steps page"],
];

export function inPageTerms(message: string): string {
  return BUTTONS.reduce((m, [pattern, words]) => m.replace(pattern, words), message);
}
