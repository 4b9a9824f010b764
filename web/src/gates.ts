// Which controls the axis' state allows, and in the manual's words why not.
// The daemon and the controller refuse the same things; saying so before the
// click saves a round trip and an alarm (98: start while servo off, 99: ABS
// move before homing).
import type { Axis, Info } from "./types";
import { token } from "./api";

export type Control = "serial" | "servo" | "home" | "move" | "step" | "jog" | "hold" | "stop" | "reset";

// Why writes are refused on this page at all, or null.
export function accessReason(info: Info): string | null {
  if (info.read_only) return "read-only listener: this page can only look";
  if (info.token_required && !token()) return "enter the token to control the axes";
  return null;
}

export function reason(control: Control, axis: Axis, info: Info): string | null {
  const access = accessReason(info);
  if (access) return access;
  if (!axis.online) return `the controller does not answer${axis.offline_reason ? `: ${axis.offline_reason}` : ""}`;
  if (control === "stop" || control === "reset" || control === "serial") return null;
  const f = axis.flags;
  const i = axis.inputs;
  if (!f || !i) return "no status read from the controller yet";
  if (!i.serial_mode) return "parallel input mode: turn serial mode on first";
  if (control === "hold") return null;
  if (control === "servo") return axis.operation ? `${axis.operation.op} running: stop it first` : null;
  if (!f.svre) return "servo is off";
  if (f.estop) return "ESTOP is active";
  if (f.alarm) return "alarm active: reset it first";
  if (i.hold) return "HOLD is on: release it first";
  if (axis.operation && !(control === "jog" && axis.operation.op === "jog")) {
    return `${axis.operation.op} running (${axis.operation.source}): stop it first`;
  }
  if ((control === "move" || control === "step") && !f.seton) return "not homed (SETON is off): home first";
  return null;
}
