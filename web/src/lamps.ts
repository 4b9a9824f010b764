// The status lamps, named as in the manual: outputs X40–X4F, inputs Y10–Y30.
import type { Axis } from "./types";
import { h, toggle } from "./dom";

interface Lamp {
  label: string;
  title: string;
  on: (a: Axis) => boolean | undefined;
  fault?: boolean; // lit means trouble: shown red
}

const bit = (v: number | undefined, n: number) => (v === undefined ? undefined : ((v >> n) & 1) === 1);

export const outputs: Lamp[] = [
  { label: "BUSY", title: "X48 BUSY: the actuator is operating", on: (a) => a.flags?.busy },
  { label: "SVRE", title: "X49 SVRE: servo is on", on: (a) => a.flags?.svre },
  { label: "SETON", title: "X4A SETON: return to origin done", on: (a) => a.flags?.seton },
  { label: "INP", title: "X4B INP: in position (or pushing reached the trigger level)", on: (a) => a.flags?.inp },
  { label: "AREA", title: "X4C AREA: inside area 1–area 2", on: (a) => a.flags?.area },
  { label: "WAREA", title: "X4D WAREA: inside the W-AREA setting", on: (a) => a.flags?.warea },
  { label: "ESTOP", title: "X4E ESTOP: emergency stop active", on: (a) => a.flags?.estop, fault: true },
  { label: "ALARM", title: "X4F ALARM: an alarm is present", on: (a) => a.flags?.alarm, fault: true },
  ...[0, 1, 2, 3, 4, 5].map((n) => ({
    label: `OUT${n}`,
    title: `X4${n} OUT${n}: step number output bit ${n}`,
    on: (a: Axis) => bit(a.flags?.out, n),
  })),
];

export const inputs: Lamp[] = [
  ...[0, 1, 2, 3, 4, 5].map((n) => ({
    label: `IN${n}`,
    title: `Y1${n} IN${n}: step number input bit ${n}`,
    on: (a: Axis) => bit(a.inputs?.in, n),
  })),
  { label: "SETUP", title: "Y1C SETUP: return to origin", on: (a) => a.inputs?.setup },
  { label: "HOLD", title: "Y18 HOLD: operation suspended", on: (a) => a.inputs?.hold },
  { label: "DRIVE", title: "Y1A DRIVE: start the selected step", on: (a) => a.inputs?.drive },
  { label: "RESET", title: "Y1B RESET: alarm reset / stop", on: (a) => a.inputs?.reset },
  { label: "SVON", title: "Y19 SVON: servo on", on: (a) => a.inputs?.svon },
  { label: "JOG−", title: "Y1D JOG−", on: (a) => a.inputs?.jog_minus },
  { label: "JOG+", title: "Y1E JOG+", on: (a) => a.inputs?.jog_plus },
  { label: "SERIAL", title: "Y30 serial mode: the controller takes its inputs from the bus", on: (a) => a.inputs?.serial_mode },
];

// A row of lamps and the function that lights them from an axis.
export function lampRow(lamps: Lamp[], label: string): { el: HTMLElement; update: (a: Axis) => void } {
  const els = lamps.map((l) =>
    h("span", { class: `lamp${l.fault ? " fault" : ""}`, title: l.title, "data-lamp": l.label }, l.label),
  );
  const el = h("div", { class: "lamps", "aria-label": label }, ...els);
  return {
    el,
    update: (a) =>
      lamps.forEach((l, n) => {
        const v = l.on(a);
        toggle(els[n], "on", v === true);
        toggle(els[n], "unknown", v === undefined);
      }),
  };
}
