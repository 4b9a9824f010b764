// The axis tabs of the pages that show one axis.
import type { Ctx } from "../app";
import { h } from "../dom";

export function axisPicker(ctx: Ctx, current: string, route: string): HTMLElement {
  return h(
    "nav",
    { class: "picker", "aria-label": "axis" },
    ...[...ctx.live.axes.values()].map((a) =>
      h(
        "a",
        { href: `#/${route}/${encodeURIComponent(a.name)}`, class: a.name === current ? "active" : "" },
        `${a.name} (ID ${a.id})`,
      ),
    ),
  );
}

export function pickAxis(ctx: Ctx, name: string | undefined): string {
  if (name && ctx.live.axes.has(name)) return name;
  return ctx.live.axes.keys().next().value ?? "";
}
