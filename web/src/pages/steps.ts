// Step table: the 64 steps in an editable grid, checked as typed; writes show
// the diff against the controller first and send only the changed steps.
// Backup download and restore upload in the CLI's CSV/JSON formats.
import type { Ctx, Page } from "../app";
import { get, send } from "../api";
import { changeTable, openDialog } from "../dialog";
import { download, gate, h, setText, toggle } from "../dom";
import { accessReason } from "../gates";
import { StepModel } from "../steptable";
import type { FieldInfo, StepRecord } from "../types";
import { axisPicker, pickAxis } from "./picker";
import { restoreFile } from "./restore";

interface TableAnswer {
  table: { equipment_name: string; controller_id: number; steps: StepRecord[] };
}

export function stepsPage(ctx: Ctx, param?: string): Page {
  const name = pickAxis(ctx, param);
  const base = `/api/axes/${encodeURIComponent(name)}/steps`;
  const status = h("p", { class: "status", "aria-live": "polite" });
  const errorList = h("ul", { class: "field-errors" });
  const grid = h("table", { class: "grid" });
  const gridBox = h("div", { class: "grid-box" }, grid);
  const write = h("button", { class: "primary" }, "Write…");
  const discard = h("button", {}, "Discard edits");
  const reload = h("button", {}, "Read controller");
  const fileInput = h("input", { type: "file", accept: ".csv,.json,text/csv,application/json", id: "restore-file" });
  const writeRefused = accessReason(ctx.info);
  let model: StepModel | null = null;
  const cells = new Map<string, HTMLInputElement | HTMLSelectElement>(); // "step:column"

  const readController = async (): Promise<StepRecord[]> => {
    const a = await get<TableAnswer>(base);
    const steps: StepRecord[] = [];
    for (const s of a.table.steps) steps[Number(s.step)] = s;
    return steps;
  };

  const load = async (note?: string) => {
    setText(status, "reading the 64 steps from the controller…");
    try {
      const fields = await ctx.fields();
      model ??= new StepModel(fields);
      model.controller = await readController();
      model.edits.clear();
      build(model);
      setText(status, note ?? "read from the controller");
    } catch (e) {
      setText(status, `could not read the steps: ${(e as Error).message}`);
    }
  };

  const build = (m: StepModel) => {
    cells.clear();
    const head = h(
      "tr",
      {},
      h("th", {}, "Step"),
      ...m.columns.map((f) => h("th", { title: rangeTitle(f) }, f.label, f.unit ? h("small", {}, ` ${f.unit}`) : null)),
    );
    const rows = [];
    for (let step = 0; step < m.fields.steps; step++) {
      const tds = m.columns.map((f) => h("td", {}, cell(m, step, f)));
      rows.push(h("tr", { "data-step": step }, h("th", {}, String(step)), ...tds));
    }
    grid.replaceChildren(h("thead", {}, head), h("tbody", {}, ...rows));
    refresh();
  };

  const cell = (m: StepModel, step: number, f: FieldInfo) => {
    const onInput = (el: HTMLInputElement | HTMLSelectElement) => {
      if (m.isBlank(step) && !m.edits.has(step)) {
        m.set(step, f, el.value);
        m.startFromDefaults(step);
        syncRow(m, step);
      } else {
        m.set(step, f, el.value);
      }
      refresh();
    };
    let el: HTMLInputElement | HTMLSelectElement;
    if (f.choices) {
      el = h(
        "select",
        { "aria-label": `step ${step} ${f.label}` },
        ...(m.isBlank(step) ? [h("option", { value: "blank", disabled: true }, "blank")] : []),
        ...f.choices.map((c) => h("option", { value: c.text }, c.text)),
      );
      el.value = m.value(step, f);
      el.addEventListener("change", () => onInput(el));
    } else {
      el = h("input", { value: m.value(step, f), inputmode: "decimal", "aria-label": `step ${step} ${f.label}`, size: 7 });
      el.addEventListener("input", () => onInput(el));
    }
    el.dataset.step = String(step);
    el.dataset.field = f.csv_column;
    if (writeRefused) el.disabled = true;
    cells.set(`${step}:${f.csv_column}`, el);
    return el;
  };

  const syncRow = (m: StepModel, step: number) => {
    for (const f of m.columns) {
      const el = cells.get(`${step}:${f.csv_column}`);
      if (el && el.value !== m.value(step, f)) el.value = m.value(step, f);
    }
  };

  // Marks edited and bad cells, lists the errors, gates the write.
  const refresh = () => {
    if (!model) return;
    const errors = model.errors();
    const items: HTMLElement[] = [];
    for (const [key, el] of cells) {
      const [s, column] = key.split(":");
      const step = Number(s);
      const err = errors.get(step)?.get(column);
      toggle(el, "changed", model.edits.get(step)?.has(column) ?? false);
      toggle(el, "bad", !!err);
      el.title = err ?? "";
      if (err) items.push(h("li", {}, `step ${step}: ${err}`));
    }
    errorList.replaceChildren(...items);
    const edited = model.edits.size;
    const why =
      writeRefused ?? (edited === 0 ? "no edits to write" : errors.size ? `fix the field errors first (${items.length})` : null);
    gate(write, why);
    setText(write, edited ? `Write ${edited} step${edited === 1 ? "" : "s"}…` : "Write…");
    gate(discard, edited ? null : "no edits");
  };

  write.addEventListener("click", async () => {
    if (!model || model.errors().size) return;
    setText(status, "reading the controller to compare…");
    const fresh = await readController().catch((e: Error) => {
      setText(status, `could not read the steps: ${e.message}`);
      return null;
    });
    if (!fresh) return;
    const m = model;
    const changes = m.diff(fresh);
    const elsewhere = m.changedElsewhere(fresh);
    const steps = [...new Set(changes.map((c) => c.step))];
    setText(status, "");
    const body = h(
      "div",
      {},
      changes.length
        ? changeTable(changes, "New")
        : h("p", {}, "The controller already holds these values: nothing to write."),
      elsewhere.length
        ? h("p", { class: "warn" }, `Changed on the controller since this grid read it: step ${elsewhere.join(", ")}. Only your edited fields are written.`)
        : null,
    );
    openDialog(`Write to ${name}`, body, [
      { label: "Cancel" },
      {
        label: `Write ${steps.length} step${steps.length === 1 ? "" : "s"}`,
        cls: "primary",
        disabled: steps.length ? null : "nothing differs",
        action: () => writeSteps(m, steps, changes),
      },
    ]);
  });

  const writeSteps = async (m: StepModel, steps: number[], changes: ReturnType<StepModel["diff"]>) => {
    const failed = new Map<number, string>();
    for (const step of steps) {
      setText(status, `writing step ${step}…`);
      const fields: Record<string, string> = {};
      for (const c of changes.filter((c) => c.step === step)) fields[c.column] = c.wanted;
      const a = await send("PUT", `${base}/${step}`, fields);
      if (a.status !== 200 || a.body.ok === false) failed.set(step, a.body.error ?? a.body.message ?? `HTTP ${a.status}`);
    }
    const kept = new Map(m.edits);
    const written = steps.length - failed.size;
    const note = [
      written ? `${written} step${written === 1 ? "" : "s"} written and read back` : "",
      ...[...failed].map(([step, why]) => `step ${step} not written: ${why}`),
    ].filter(Boolean);
    await load(note.join("; "));
    // The edits of steps that failed stay in the grid: nothing typed is lost.
    for (const step of failed.keys()) {
      for (const [column, text] of kept.get(step) ?? []) {
        const f = m.columns.find((c) => c.csv_column === column);
        if (f) m.set(step, f, text);
      }
      syncRow(m, step);
    }
    refresh();
  };

  discard.addEventListener("click", () => model && (model.edits.clear(), build(model)));
  reload.addEventListener("click", () => void load());
  fileInput.addEventListener("change", async () => {
    const file = fileInput.files?.[0];
    fileInput.value = "";
    if (file) await restoreFile(name, file, (note) => load(note));
  });
  gate(fileInput, writeRefused);

  const backupJson = async () => {
    const a = await get<TableAnswer>(base);
    download(`${name}-steps.json`, JSON.stringify(a.table, null, 2) + "\n", "application/json");
  };

  void load();
  const el = h(
    "div",
    { class: "page steps" },
    axisPicker(ctx, name, "steps"),
    h(
      "div",
      { class: "toolbar" },
      reload,
      write,
      discard,
      h("span", { class: "sep" }),
      h("span", { class: "muted" }, "Backup"),
      h("a", { class: "button", href: `${base}?format=csv`, download: `${name}-steps.csv` }, "CSV"),
      h("button", { onclick: backupJson }, "JSON"),
      h("span", { class: "sep" }),
      h("label", { class: "button file", title: writeRefused ?? "" }, "Restore…", fileInput),
    ),
    status,
    errorList,
    gridBox,
  );
  return { el };
}

function rangeTitle(f: FieldInfo): string {
  if (f.choices) return f.choices.map((c) => c.text).join(" or ");
  const n = (v: number) => (f.is_length ? v.toFixed(2) : String(v));
  return `${n(f.min)} to ${n(f.max)} ${f.unit}`.trim();
}
