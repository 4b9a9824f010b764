// Overview: one card per axis.
import type { Ctx, Page } from "../app";
import { watchAxes } from "../app";
import { axisCard, type Card } from "../card";
import { h } from "../dom";

export function overviewPage(ctx: Ctx): Page {
  const cards = new Map<string, Card>();
  const grid = h("div", { class: "cards" });
  for (const a of ctx.live.axes.values()) {
    const c = axisCard(a, ctx.live, `#/axis/${encodeURIComponent(a.name)}`);
    cards.set(a.name, c);
    grid.appendChild(c.el);
  }
  const stop = watchAxes(ctx.live, (names) => {
    for (const n of names) {
      const a = ctx.live.axes.get(n);
      if (a) cards.get(n)?.update(a);
    }
  });
  return { el: h("div", { class: "page overview" }, grid), destroy: stop };
}
