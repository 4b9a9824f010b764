// The step grid's model: the controller's 64 steps as last read, the user's
// edits as typed, and the checks and diffs between them.
import { checkRules, checkValue } from "./fieldcheck";
import type { FieldInfo, Fields, StepRecord } from "./types";

export interface Change {
  step: number;
  column: string;
  label: string;
  controller: string;
  wanted: string;
}

export class StepModel {
  controller: StepRecord[] = [];
  readonly edits = new Map<number, Map<string, string>>();

  constructor(readonly fields: Fields) {}

  get columns(): FieldInfo[] {
    return this.fields.fields;
  }

  // The controller's value as the grid shows it: "abs", "150.00", "300".
  shown(step: number, f: FieldInfo, record = this.controller[step]): string {
    const v = record?.[f.csv_column];
    if (v === undefined) return "";
    if (typeof v === "string") return v;
    return f.is_length ? v.toFixed(f.decimals) : String(v);
  }

  value(step: number, f: FieldInfo): string {
    return this.edits.get(step)?.get(f.csv_column) ?? this.shown(step, f);
  }

  isBlank(step: number): boolean {
    return this.controller[step]?.mode === "blank";
  }

  // Records an edit; an edit back to the controller's value is no edit.
  set(step: number, f: FieldInfo, text: string): void {
    const row = this.edits.get(step) ?? new Map<string, string>();
    if (text === this.shown(step, f)) row.delete(f.csv_column);
    else row.set(f.csv_column, text);
    if (row.size) this.edits.set(step, row);
    else this.edits.delete(step);
  }

  // A blank step is not registered: editing it starts from the daemon's
  // defaults for a new step (the same as PUT does), shown so nothing is hidden.
  startFromDefaults(step: number): void {
    for (const f of this.columns) {
      if (this.edits.get(step)?.has(f.csv_column)) continue;
      const text = f.choices ? f.choices[0].text : f.is_length ? f.default.toFixed(f.decimals) : String(f.default);
      this.set(step, f, text);
    }
  }

  // Field errors of the edited rows, by step and column.
  errors(): Map<number, Map<string, string>> {
    const out = new Map<number, Map<string, string>>();
    for (const step of this.edits.keys()) {
      const row = new Map<string, string>();
      const record: StepRecord = {};
      for (const f of this.columns) {
        const c = checkValue(f, this.value(step, f));
        if (c.error) row.set(f.csv_column, c.error);
        else record[f.csv_column] = c.value as number;
      }
      for (const [column, message] of checkRules(this.fields.rules, record)) {
        if (!row.has(column)) row.set(column, message);
      }
      if (row.size) out.set(step, row);
    }
    return out;
  }

  // What a write would change, against a fresh read of the controller: only
  // the fields the user edited, and only where they differ from it.
  diff(fresh: StepRecord[]): Change[] {
    const out: Change[] = [];
    for (const [step, row] of this.edits) {
      for (const f of this.columns) {
        const wanted = row.get(f.csv_column);
        if (wanted === undefined) continue;
        const have = this.shown(step, f, fresh[step]);
        const same = f.choices ? have === wanted : Number(have) === Number(wanted);
        if (!same) out.push({ step, column: f.csv_column, label: f.label, controller: have, wanted });
      }
    }
    return out.sort((a, b) => a.step - b.step);
  }

  // Steps whose controller values changed since the grid read them.
  changedElsewhere(fresh: StepRecord[]): number[] {
    return [...this.edits.keys()].filter((s) =>
      this.columns.some((f) => this.shown(s, f) !== this.shown(s, f, fresh[s])),
    );
  }
}
