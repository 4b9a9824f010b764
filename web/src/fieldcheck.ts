// Checks what a person types against the manual's ranges, from the field
// table the daemon serves (GET /api/fields, built from lec::step_fields()),
// so the page and the daemon never disagree on a range. The daemon checks
// again on every write.
import type { FieldInfo, FieldRule, StepRecord } from "./types";

export interface Checked {
  value?: number;
  error?: string;
}

function rangeText(f: FieldInfo): string {
  const n = (v: number) => (f.is_length ? v.toFixed(2) : String(v));
  return `${n(f.min)} to ${n(f.max)}${f.unit ? ` ${f.unit}` : ""}`;
}

export function checkValue(f: FieldInfo, raw: string): Checked {
  const text = raw.trim();
  const name = f.label.toLowerCase();
  if (f.choices) {
    const c = f.choices.find((c) => c.text === text.toLowerCase() || String(c.value) === text);
    return c ? { value: c.value } : { error: `${name}: expected ${f.choices.map((c) => c.text).join(" or ")}` };
  }
  if (text === "") return { error: `${name}: a value is needed` };
  const pattern = f.is_length ? /^[-+]?\d+(\.\d{0,2})?$|^[-+]?\.\d{1,2}$/ : /^[-+]?\d+$/;
  if (!pattern.test(text)) {
    return { error: `${name} '${text}': ${f.is_length ? "a number with at most 2 decimals (0.01 mm)" : "a whole number"}` };
  }
  const value = Number(text);
  if (value < f.min || value > f.max) {
    return { error: `${name} ${text}${f.unit ? ` ${f.unit}` : ""} is out of range: allowed ${rangeText(f)}` };
  }
  return { value };
}

// The rules between fields (trigger level ≤ pushing force): the fields at fault.
export function checkRules(rules: FieldRule[], record: StepRecord): Map<string, string> {
  const out = new Map<string, string>();
  for (const r of rules) {
    const v = Number(record[r.field]);
    const limit = Number(record[r.at_most]);
    if (Number(record[r.when_positive]) > 0 && v > limit) {
      out.set(r.field, `${r.message} (${v} > ${limit})`);
    }
  }
  return out;
}
