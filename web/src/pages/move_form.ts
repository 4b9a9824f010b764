// "Move to": a direct operation with the move's fields, checked against the
// manual's ranges as they are typed (the same table as the step grid). An
// empty field takes the daemon's default (GET /api/fields, the one set of
// defaults of every front end), or with "keep" the controller's value; the
// line under the fields says what the next move will use (issue 27).
import type { Ctx } from "../app";
import { h, setText, toggle } from "../dom";
import { checkValue } from "../fieldcheck";
import type { FieldInfo } from "../types";

interface Spec {
  key: string; // the move command's key (docs/api.md)
  column: string; // the step field it is checked as
  label: string;
  pushing?: boolean; // only sent for a pushing move
  short: string; // in the "next move" line
}

const SPECS: Spec[] = [
  { key: "position_mm", column: "position_mm", label: "Position mm", short: "to" },
  { key: "speed_mm_s", column: "speed_mm_s", label: "Speed mm/s", short: "speed" },
  { key: "accel_mm_s2", column: "accel_mm_s2", label: "Accel mm/s²", short: "accel" },
  { key: "decel_mm_s2", column: "decel_mm_s2", label: "Decel mm/s²", short: "decel" },
  { key: "moving_force_pct", column: "moving_force_pct", label: "Thrust (moving force) %", short: "moving force" },
  { key: "in_position_mm", column: "in_position_mm", label: "In position ± mm", short: "in position ±" },
  { key: "push_pct", column: "pushing_force_pct", label: "Pushing force %", pushing: true, short: "push" },
  { key: "trigger_pct", column: "trigger_level_pct", label: "Trigger level %", pushing: true, short: "trigger" },
  { key: "push_speed_mm_s", column: "pushing_speed_mm_s", label: "Pushing speed mm/s", pushing: true, short: "pushing speed" },
];

export interface MoveForm {
  el: HTMLElement;
  submit: HTMLButtonElement;
  showError: (key: string, message: string) => void;
}

export function moveForm(ctx: Ctx, send: (body: Record<string, unknown>) => void): MoveForm {
  let fields = new Map<string, FieldInfo>();
  const inputs = new Map<string, HTMLInputElement>();
  const errors = h("p", { class: "field-errors", "aria-live": "polite" });
  const pushing = h("input", { type: "checkbox", id: "move-pushing" });
  const keep = h("input", { type: "checkbox", id: "move-keep" });
  const next = h("p", { class: "next-move muted", "data-k": "next-move" });
  const labels = new Map<string, HTMLElement>();
  const submit = h("button", { type: "submit", class: "primary" }, "Move to");

  const boxes = SPECS.map((s) => {
    const input = h("input", {
      name: s.key,
      inputmode: "decimal",
      autocomplete: "off",
      placeholder: s.key === "position_mm" ? "required" : "",
      oninput: () => validate(false),
    });
    inputs.set(s.key, input);
    const label = h("span", {}, s.label);
    labels.set(s.key, label);
    return h("label", { class: `field${s.pushing ? " push-only" : ""}` }, label, input);
  });

  // Placeholders and the "next move" line: typed value, else the default
  // (or, with keep, the controller's value).
  const describeNext = () => {
    const parts: string[] = [];
    for (const s of SPECS) {
      if (s.pushing && !pushing.checked) continue;
      const info = fields.get(s.column);
      const input = inputs.get(s.key)!;
      if (s.key !== "position_mm") input.placeholder = keep.checked ? "keep" : info ? String(info.default) : "";
      const text = input.value.trim();
      const unit = info?.unit ? ` ${info.unit}` : "";
      const short = s.key === "in_position_mm" && pushing.checked ? "pushing distance" : s.short;
      if (text !== "") parts.push(`${short} ${text}${unit}`);
      else if (s.key === "position_mm") parts.push("to ?");
      else if (!keep.checked && info) parts.push(`${short} ${info.default}${unit}`);
      else if (keep.checked) parts.push(`${short} kept`);
    }
    setText(labels.get("in_position_mm")!, pushing.checked ? "Pushing distance mm" : "In position ± mm");
    setText(next, `Next move: ${parts.join(", ")}${pushing.checked ? "" : " (positioning)"}`);
  };

  // Errors by key; an empty optional field takes the default (or, with keep, the controller's value).
  // The position is needed, but only said so on submit, not while typing.
  const check = (submitting: boolean): Map<string, string> => {
    const out = new Map<string, string>();
    for (const s of SPECS) {
      const text = inputs.get(s.key)!.value;
      const info = fields.get(s.column);
      if (s.pushing && !pushing.checked) continue;
      if (text.trim() === "" && !(submitting && s.key === "position_mm")) continue;
      if (!info) continue;
      const c = checkValue(info, text);
      if (c.error) out.set(s.key, c.error);
    }
    return out;
  };

  const validate = (submitting = false): boolean => {
    const bad = check(submitting);
    for (const [key, input] of inputs) {
      toggle(input, "bad", bad.has(key));
      input.title = bad.get(key) ?? "";
    }
    setText(errors, [...bad.values()].join("; "));
    toggle(form, "invalid", bad.size > 0);
    describeNext();
    return bad.size === 0;
  };

  const form = h(
    "form",
    {
      class: "move",
      onsubmit: (e: Event) => {
        e.preventDefault();
        if (!validate(true)) return;
        const body: Record<string, unknown> = {};
        for (const s of SPECS) {
          const text = inputs.get(s.key)!.value.trim();
          if (text === "" || (s.pushing && !pushing.checked)) continue;
          body[s.key] = Number(text);
        }
        if (keep.checked) body.keep = true;
        send(body);
      },
    },
    h("div", { class: "fields" }, ...boxes),
    next,
    h(
      "div",
      { class: "row" },
      h("label", { class: "check" }, pushing, " pushing"),
      h("label", { class: "check", title: "empty fields keep the controller's values instead of the defaults" }, keep, " keep controller's values"),
      submit,
    ),
    errors,
  );
  keep.addEventListener("change", () => validate());
  pushing.addEventListener("change", () => {
    toggle(form, "pushing", pushing.checked);
    validate();
  });
  void ctx.fields().then((f) => {
    fields = new Map(f.fields.map((i) => [i.csv_column, i]));
    validate();
  });

  return {
    el: form,
    submit,
    showError: (key, message) => {
      const input = inputs.get(key) ?? inputs.get(SPECS.find((s) => s.column === key)?.key ?? "");
      if (input) {
        input.classList.add("bad");
        input.title = message;
      }
      setText(errors, message);
    },
  };
}
