// One axis at a glance: position vs target, speed, thrust, every lamp and
// the health of the link to its controller.
import type { Axis } from "./types";
import { h, mm, setText, toggle } from "./dom";
import { inputs, lampRow, outputs } from "./lamps";
import { ageMs, type Live } from "./live";

export interface Card {
  el: HTMLElement;
  update: (a: Axis) => void;
}

export function axisCard(axis: Axis, live: Live, href?: string): Card {
  const position = h("span", { class: "big num", "data-k": "position" });
  const target = h("span", { class: "num", "data-k": "target" });
  const speed = h("span", { class: "num", "data-k": "speed" });
  const thrust = h("span", { class: "num", "data-k": "thrust" });
  const thrustBar = h("span", { class: "bar-fill" });
  const health = h("span", { class: "health", "data-k": "health" });
  const op = h("span", { class: "op", "data-k": "operation" });
  const outs = lampRow(outputs, "outputs");
  const ins = lampRow(inputs, "inputs");
  const title = h("h2", {}, href ? h("a", { href }, axis.name) : axis.name, h("span", { class: "muted" }, ` ID ${axis.id} · ${axis.line}`));
  const el = h(
    "section",
    { class: "card", "data-axis": axis.name },
    h("header", {}, title, op),
    h(
      "div",
      { class: "readout" },
      h("div", {}, h("label", {}, "Position"), position, h("span", { class: "unit" }, " mm")),
      h("div", {}, h("label", {}, "Target"), target, h("span", { class: "unit" }, " mm")),
      h("div", {}, h("label", {}, "Speed"), speed, h("span", { class: "unit" }, " mm/s")),
    ),
    h("div", { class: "thrust" }, h("label", {}, "Thrust"), h("span", { class: "bar" }, thrustBar), thrust),
    h("div", { class: "lamp-group" }, h("label", {}, "Outputs"), outs.el),
    h("div", { class: "lamp-group" }, h("label", {}, "Inputs"), ins.el),
    health,
  );

  const update = (a: Axis) => {
    setText(position, mm(a.position_mm));
    setText(target, mm(a.target_mm));
    setText(speed, a.speed_mm_s === undefined ? "—" : String(a.speed_mm_s));
    const t = a.thrust_pct ?? 0;
    setText(thrust, a.thrust_pct === undefined ? "—" : `${t} %`);
    // The bar spans 0–100 %; moving force may allow up to 300 %.
    thrustBar.style.width = `${Math.min(100, Math.max(0, t))}%`;
    toggle(thrustBar, "over", t > 100);
    outs.update(a);
    ins.update(a);
    setText(op, a.operation ? `${a.operation.op}…` : "");
    const age = ageMs(live, a);
    const errPct = (a.error_rate * 100).toFixed(1);
    const text = !a.online
      ? `offline: ${a.offline_reason ?? "no answer"}`
      : `last answer ${age === null ? "—" : `${Math.round(age)} ms`} ago · errors ${errPct} %`;
    setText(health, text);
    toggle(el, "offline", !a.online);
    toggle(health, "warn", a.online && (a.error_rate > 0.01 || (age ?? 0) > 1000));
    toggle(el, "alarm", a.flags?.alarm === true || a.flags?.estop === true);
  };
  update(axis);
  return { el, update };
}
