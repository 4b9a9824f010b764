// Twin: the built-in twin's workpiece and fault-injection rates (lines with
// port: sim), so a user can rehearse failures on a laptop.
import type { Ctx, Page } from "../app";
import { get, post } from "../api";
import { gate, h, setText } from "../dom";
import { accessReason } from "../gates";

interface Twin {
  drop_rate: number;
  corrupt_rate: number;
  garbage_rate: number;
  workpiece_mm?: number | null;
  ids: number[];
  [key: string]: unknown;
}

const RATES: [string, string][] = [
  ["drop_rate", "Dropped replies"],
  ["corrupt_rate", "Corrupted replies (bad CRC)"],
  ["garbage_rate", "Garbage bytes on the line"],
];

export function twinPage(ctx: Ctx): Page {
  const el = h("div", { class: "page twin" });
  const sims = ctx.lines.filter((l) => l.sim);
  if (!sims.length) el.appendChild(h("p", { class: "muted" }, "No line here is the built-in twin (port: sim)."));
  for (const line of sims) el.appendChild(twinSection(ctx, line.name));
  return { el };
}

function twinSection(ctx: Ctx, line: string): HTMLElement {
  const url = `/api/lines/${encodeURIComponent(line)}/twin`;
  const result = h("p", { class: "status", "aria-live": "polite" });
  const inputs = new Map<string, HTMLInputElement>();
  const rateRows = RATES.map(([key, label]) => {
    const input = h("input", { type: "number", min: 0, max: 100, step: 0.1, name: key, class: "num" });
    inputs.set(key, input);
    return h("label", { class: "field" }, h("span", {}, `${label} %`), input);
  });
  const workpiece = h("input", { type: "number", step: 0.01, name: "workpiece_mm", placeholder: "none", class: "num" });
  const workpieceNote = h("small", { class: "muted" });
  const apply = h("button", { class: "primary", type: "submit" }, "Apply");
  const refused = accessReason(ctx.info);
  let offersWorkpiece = false;

  const show = (t: Twin) => {
    for (const [key] of RATES) inputs.get(key)!.value = String(+((t[key] as number) * 100).toFixed(3));
    offersWorkpiece = "workpiece_mm" in t;
    workpiece.value = t.workpiece_mm === null || t.workpiece_mm === undefined ? "" : String(t.workpiece_mm);
    gate(workpiece, refused ?? (offersWorkpiece ? null : "this lec serve does not offer workpiece_mm yet"));
    setText(workpieceNote, offersWorkpiece ? "empty: no workpiece (a push misses)" : "this lec serve does not offer workpiece_mm yet");
    setText(ids, `controllers ${t.ids.join(", ")}`);
    gate(apply, refused);
    inputs.forEach((i) => gate(i, refused));
  };
  const ids = h("span", { class: "muted" });

  const form = h(
    "form",
    {
      class: "twin-form",
      onsubmit: async (e: Event) => {
        e.preventDefault();
        const body: Record<string, number | null> = {};
        for (const [key] of RATES) body[key] = Number(inputs.get(key)!.value || 0) / 100;
        if (offersWorkpiece) body.workpiece_mm = workpiece.value.trim() === "" ? null : Number(workpiece.value);
        const a = await post(url, body);
        if (a.status === 200) {
          show(a.body as unknown as Twin);
          setText(result, "applied");
        } else {
          setText(result, `not applied: ${a.body.error ?? `HTTP ${a.status}`}`);
        }
      },
    },
    h("h3", {}, "Workpiece"),
    h("label", { class: "field" }, h("span", {}, "Workpiece position mm"), workpiece, workpieceNote),
    h("h3", {}, "Fault injection (probability per reply)"),
    ...rateRows,
    h("div", { class: "row" }, apply),
    result,
  );
  // Nothing to apply until the twin's settings are shown: an Apply before
  // that sent empty rates (0 %) and no workpiece, undoing what was set, and
  // the load overwrote what was typed meanwhile (a browser test on a loaded
  // host: the workpiece typed came back null).
  const loading = "reading the twin's settings…";
  gate(apply, refused ?? loading);
  inputs.forEach((i) => gate(i, refused ?? loading));
  gate(workpiece, refused ?? loading);
  void get<Twin>(url)
    .then(show)
    .catch((e: Error) => setText(result, `could not read the twin: ${e.message}`));
  return h("section", { class: "panel", "data-line": line }, h("h2", {}, `${line} `, ids), form);
}
