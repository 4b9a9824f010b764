// Alarms: the active alarms and the 16-group history of every axis, with the
// meanings lec serve gives, and a reset.
import type { Ctx, Page } from "../app";
import { get, post } from "../api";
import { gate, h, setText } from "../dom";
import { accessReason } from "../gates";
import type { Alarm } from "../types";

interface Alarms {
  alarms: Alarm[];
  history: { group: number; alarms: Alarm[] }[];
}

const alarmText = (a: Alarm) => `${a.code}: ${a.meaning}${a.resettable ? "" : " (not resettable: power cycle)"}`;

export function alarmsPage(ctx: Ctx): Page {
  const sections = new Map<string, { refresh: () => Promise<void>; key: string }>();
  const el = h("div", { class: "page alarms" });
  for (const axis of ctx.live.axes.values()) {
    const active = h("ul", { class: "active-alarms" });
    const history = h("tbody", {});
    const result = h("span", { class: "muted" });
    const reset = h("button", {}, "RESET");
    gate(reset, accessReason(ctx.info));
    const url = `/api/axes/${encodeURIComponent(axis.name)}`;
    reset.addEventListener("click", async () => {
      const a = await post(`${url}/reset`, {});
      setText(result, String(a.body.message ?? a.body.error ?? `HTTP ${a.status}`));
    });
    const refresh = async () => {
      const a = await get<Alarms>(`${url}/alarms`).catch(() => null);
      if (!a) return;
      active.replaceChildren(
        ...(a.alarms.length ? a.alarms.map((x) => h("li", { class: "bad" }, alarmText(x))) : [h("li", { class: "muted" }, "no alarm active")]),
      );
      history.replaceChildren(
        ...(a.history.length
          ? a.history.map((g) => h("tr", {}, h("td", {}, String(g.group)), h("td", {}, g.alarms.map(alarmText).join("; "))))
          : [h("tr", {}, h("td", { colspan: 2, class: "muted" }, "the history is empty"))]),
      );
    };
    sections.set(axis.name, { refresh, key: "" });
    el.appendChild(
      h(
        "section",
        { class: "panel", "data-axis": axis.name },
        h("h2", {}, `${axis.name} `, h("span", { class: "muted" }, `ID ${axis.id}`)),
        h("h3", {}, "Active"),
        active,
        h("div", { class: "row" }, reset, result),
        h("h3", {}, "History (group 0 is the newest)"),
        h("table", { class: "history" }, h("thead", {}, h("tr", {}, h("th", {}, "Group"), h("th", {}, "Alarms"))), history),
      ),
    );
    void refresh();
  }
  // Read again when an axis' alarms change (the daemon reads the history when ALARM rises).
  const off = ctx.live.telemetry.on((a) => {
    const s = sections.get(a.name);
    const key = `${a.flags?.alarm}:${a.alarms.map((x) => x.code).join(",")}`;
    if (s && s.key !== key) {
      s.key = key;
      // Twice: the daemon reads the history in the background once ALARM rises.
      for (const ms of [300, 1500]) setTimeout(() => void s.refresh(), ms);
    }
  });
  return { el, destroy: off };
}
