// Axis view: the live monitor graph, the controls and the results.
import type { Ctx, Page } from "../app";
import { watchAxes } from "../app";
import { post } from "../api";
import { axisCard } from "../card";
import { download, gate, h, setText, toggle } from "../dom";
import { reason, type Control } from "../gates";
import { holdToRun } from "../jog";
import { isMotion } from "../live";
import { TracePlot } from "../plot";
import { ResultList } from "../results";
import type { Axis, OpResult } from "../types";
import { axisPicker, pickAxis } from "./picker";
import { moveForm } from "./move_form";

// Answers that no `op` event will follow (refused before anything ran).
const refusedAtOnce = (status: number) => status === 0 || (status >= 400 && status < 410) || status === 503;

export function axisPage(ctx: Ctx, param?: string): Page {
  const name = pickAxis(ctx, param);
  const axis = ctx.live.axes.get(name) as Axis;
  const url = (op: string) => `/api/axes/${encodeURIComponent(name)}/${op}`;
  const results = new ResultList();
  const report = (text: string, ok: boolean) => results.show({ ok, message: text }, ok ? 200 : 400);

  // ---- plot and its toolbar
  const plotHost = h("div", { class: "plot", id: "plot" });
  const plot = new TracePlot(plotHost);
  (window as unknown as { lecPlot: TracePlot }).lecPlot = plot; // for the browser tests
  const win10 = h("button", { onclick: () => plot.setWindow(10) }, "10 s");
  const win60 = h("button", { onclick: () => plot.setWindow(60) }, "60 s");
  const pause = h("button", { onclick: () => plot.setPaused(!plot.isPaused()) });
  const onMove = h("input", { type: "checkbox", id: "capture-on-move" });
  const capture = h("button", {
    onclick: () => (plot.captureState().capturing ? plot.stopCapture() : plot.startCapture()),
  });
  const capState = h("span", { class: "muted", "data-k": "capture" });
  const csv = h("button", { onclick: () => download(`${name}-trace.csv`, plot.csv(), "text/csv") }, "Export CSV");
  const syncToolbar = () => {
    toggle(win10, "active", plot.windowS === 10);
    toggle(win60, "active", plot.windowS === 60);
    setText(pause, plot.isPaused() ? "▶ Live" : "❚❚ Pause");
    const c = plot.captureState();
    setText(capture, c.capturing ? "■ Stop capture" : "● Capture");
    toggle(capture, "recording", c.capturing);
    setText(capState, c.samples ? `${c.samples} samples, ${c.seconds.toFixed(1)} s${c.capturing ? " (recording)" : ""}` : "");
  };
  plot.onChange = syncToolbar;
  syncToolbar();

  // ---- controls
  const controls = new Map<Control, HTMLButtonElement[]>();
  const reasons = new Map<Control, HTMLElement>();
  const button = (control: Control, label: string, body: () => unknown, cls = "") => {
    const b = h("button", { class: cls, onclick: () => void command(control === "step" ? "run-step" : control, body()) }, label);
    controls.set(control, [...(controls.get(control) ?? []), b]);
    return b;
  };
  const why = (control: Control) => {
    const el = h("p", { class: "reason" });
    reasons.set(control, el);
    return el;
  };
  const command = async (op: string, body: unknown) => {
    const a = await post(url(op), body);
    if (refusedAtOnce(a.status)) results.show({ ...a.body, op }, a.status);
    if (a.status === 400 && a.body.field) move.showError(String(a.body.field), String(a.body.error));
  };

  const jogMinus = h("button", { class: "jog" }, "◀ JOG−");
  const jogPlus = h("button", { class: "jog" }, "JOG+ ▶");
  controls.set("jog", [jogMinus, jogPlus]);
  const releaseMinus = holdToRun(jogMinus, () => name, "-", ctx.live, report);
  const releasePlus = holdToRun(jogPlus, () => name, "+", ctx.live, report);

  const move = moveForm(ctx, (body) => command("move", body));
  controls.set("move", [move.submit]);
  const stepNo = h("input", { type: "number", min: 0, max: 63, value: 0, class: "step-no", "aria-label": "step number" });
  const hold = button("hold", "HOLD", () => ({ on: !(ctx.live.axes.get(name)?.inputs?.hold ?? false) }));

  const panel = h(
    "div",
    { class: "controls" },
    h("div", { class: "row" }, h("label", {}, "Serial mode"), button("serial", "On", () => ({ on: true })), button("serial", "Off", () => ({ on: false })), why("serial")),
    h("div", { class: "row" }, h("label", {}, "Servo"), button("servo", "On", () => ({ on: true })), button("servo", "Off", () => ({ on: false })), why("servo")),
    h("div", { class: "row" }, h("label", {}, "Motion"), button("home", "Home", () => ({})), jogMinus, jogPlus, why("home")),
    h("div", { class: "row" }, h("label", {}, "Run step"), stepNo, button("step", "Run step", () => ({ step: Number(stepNo.value) })), why("step")),
    move.el,
    why("move"),
    h("div", { class: "row stops" }, hold, button("stop", "STOP", () => ({}), "danger"), button("reset", "RESET", () => ({})), why("stop")),
  );

  const card = axisCard(axis, ctx.live);
  const render = () => {
    const a = ctx.live.axes.get(name);
    if (!a) return;
    card.update(a);
    // One note per reason: the same "… stop it first" under every motion
    // control pushed STOP and HOLD out of a 900 px window (issue 27).
    for (const [control, buttons] of controls) {
      const r = reason(control, a, ctx.info);
      buttons.forEach((b) => gate(b, r));
    }
    const said = new Set<string>();
    for (const [control, shown] of reasons) {  // top to bottom, as on the page
      const r = reason(control, a, ctx.info);
      setText(shown, r && !said.has(r) ? r : "");
      if (r) said.add(r);
    }
    toggle(hold, "active", a.inputs?.hold === true);
    if (!a.operation) results.settle();
  };
  const stopWatch = watchAxes(ctx.live, (names) => names.has(name) && render());
  const offTelemetry = ctx.live.telemetry.on((a) => a.name === name && plot.push(a));
  const offOps = ctx.live.ops.on((e) => {
    if (e.axis !== name) return;
    if (e.event === "started") {
      results.running(String(e.op), e.source ?? "");
      if (onMove.checked && isMotion(String(e.op))) plot.startCapture();
    } else {
      results.show(e as OpResult, e.status ?? 200);
      // A little after the end, so the capture shows the axis settle.
      if (onMove.checked && isMotion(String(e.op))) setTimeout(() => plot.stopCapture(), 500);
    }
  });
  const ticker = window.setInterval(syncToolbar, 500);
  if (axis.last_result) results.show(axis.last_result, axis.last_result.ok === false ? 422 : 200);
  render();

  const el = h(
    "div",
    { class: "page axis" },
    axisPicker(ctx, name, "axis"),
    h(
      "section",
      { class: "monitor" },
      h("div", { class: "toolbar" }, win10, win60, pause, h("label", { class: "check" }, onMove, " capture on move start"), capture, csv, capState),
      plotHost,
    ),
    h("div", { class: "axis-grid" }, card.el, h("section", { class: "panel" }, h("h3", {}, "Controls"), panel), h("section", { class: "panel" }, h("h3", {}, "Results"), results.el)),
  );
  return {
    el,
    destroy: () => {
      releaseMinus();
      releasePlus();
      stopWatch();
      offTelemetry();
      offOps();
      window.clearInterval(ticker);
      plot.destroy();
    },
  };
}
