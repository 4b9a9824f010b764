// Restore upload: the daemon plans the restore against the controller
// (POST …/steps/plan, nothing written) and the page shows that plan — or the
// file's errors — before anything is written.
import { send } from "../api";
import { changeTable, openDialog } from "../dialog";
import { h } from "../dom";

interface Plan {
  ok: boolean;
  error?: string;
  errors?: string[];
  to_write?: number;
  unchanged?: number;
  notes?: string[];
  steps?: { step: number; blanks: boolean; fields: { field: string; label: string; controller: string; file: string }[] }[];
}

interface Report {
  ok: boolean;
  summary?: string;
  error?: string;
  steps?: { step: number; outcome: string; error?: string }[];
}

export async function restoreFile(axis: string, file: File, done: (note: string) => Promise<void>): Promise<void> {
  const text = await file.text();
  // The CLI's formats: CSV (by name, or a first line that is a comment or the header) or JSON.
  const csv = /\.csv$/i.test(file.name) || /^\s*(#|step\s*,)/i.test(text);
  const type = csv ? "text/csv" : "application/json";
  const base = `/api/axes/${encodeURIComponent(axis)}/steps`;
  const a = await send<Plan>("POST", `${base}/plan`, text, type);
  const plan = a.body;
  if (a.status !== 200 || !plan.ok) {
    const errors = plan.errors ?? [plan.error ?? `HTTP ${a.status}`];
    openDialog(
      `${file.name}: not restored`,
      h(
        "div",
        { class: "restore-errors" },
        h("p", { class: "bad" }, `The file has ${errors.length} error${errors.length === 1 ? "" : "s"}. Nothing was written.`),
        h("ul", { class: "field-errors" }, ...errors.map((e) => h("li", {}, e))),
      ),
      [{ label: "Close" }],
    );
    return;
  }
  const rows = (plan.steps ?? []).flatMap((s) =>
    s.fields.map((f) => ({ step: s.step, label: f.label, controller: f.controller, wanted: f.file })),
  );
  const n = plan.to_write ?? 0;
  openDialog(
    `Restore ${file.name} to ${axis}`,
    h(
      "div",
      {},
      h("p", {}, `${n} step${n === 1 ? "" : "s"} to write, ${plan.unchanged ?? 0} unchanged.`),
      rows.length ? changeTable(rows, "File") : null,
      ...(plan.notes ?? []).map((note) => h("p", { class: "muted" }, note)),
    ),
    [
      { label: "Cancel" },
      {
        label: `Restore ${n} step${n === 1 ? "" : "s"}`,
        cls: "primary",
        disabled: n ? null : "the controller already holds this file",
        action: async () => {
          const r = await send<Report>("POST", base, text, type);
          const failed = (r.body.steps ?? []).filter((s) => s.outcome !== "written");
          const detail = failed.map((s) => `step ${s.step}: ${s.outcome}${s.error ? ` (${s.error})` : ""}`);
          await done([r.body.summary ?? r.body.error ?? `HTTP ${r.status}`, ...detail].join("; "));
        },
      },
    ],
  );
}
