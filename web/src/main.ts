// The dashboard served by `lec serve`: routes, the header (pages, access,
// link state) and the boot sequence. Everything it does goes through the
// HTTP API (docs/api.md); live data arrive by Server-Sent Events.
import "./style.css";
import { get, setToken, token } from "./api";
import { fieldsLoader, type Ctx, type Page } from "./app";
import { h, setText, toggle } from "./dom";
import { Live } from "./live";
import { alarmsPage } from "./pages/alarms";
import { axisPage } from "./pages/axis";
import { busPage } from "./pages/bus";
import { historyPage } from "./pages/history";
import { overviewPage } from "./pages/overview";
import { stepsPage } from "./pages/steps";
import { twinPage } from "./pages/twin";
import type { Info, Line } from "./types";

type Route = { label: string; make: (ctx: Ctx, param?: string) => Page; axis?: boolean };

const routes: Record<string, Route> = {
  overview: { label: "Overview", make: overviewPage },
  axis: { label: "Axis", make: axisPage, axis: true },
  steps: { label: "Step table", make: stepsPage, axis: true },
  alarms: { label: "Alarms", make: alarmsPage },
  history: { label: "History", make: historyPage, axis: true },
  bus: { label: "Bus", make: busPage },
  twin: { label: "Twin", make: twinPage },
};

let current: Page | null = null;

function parseHash(): [string, string | undefined] {
  const [, name, param] = location.hash.match(/^#\/([^/]*)\/?(.*)$/) ?? [];
  return [routes[name] ? name : "overview", param ? decodeURIComponent(param) : undefined];
}

function show(ctx: Ctx): void {
  const [name, param] = parseHash();
  current?.destroy?.();
  current = routes[name].make(ctx, param);
  document.getElementById("page")!.replaceChildren(current.el);
  document.querySelectorAll<HTMLAnchorElement>("#nav a").forEach((a) => toggle(a, "active", a.dataset.route === name));
  document.title = `lec6 — ${routes[name].label}`;
}

function nav(ctx: Ctx): void {
  const hasSim = ctx.lines.some((l) => l.sim);
  const links = Object.entries(routes)
    .filter(([name]) => name !== "twin" || hasSim)
    .map(([name, r]) => h("a", { href: `#/${name}`, "data-route": name }, r.label));
  document.getElementById("nav")!.replaceChildren(...links);
}

// Read-only pages say so; a listener that wants a token gets a field for it.
function access(ctx: Ctx): void {
  const el = document.getElementById("access")!;
  if (ctx.info.read_only) {
    el.replaceChildren(h("span", { class: "badge" }, "read-only"));
    return;
  }
  if (!ctx.info.token_required) return;
  const input = h("input", { type: "password", placeholder: "token", autocomplete: "off", value: token(), size: 10 });
  const state = h("span", { class: "badge" });
  const apply = () => {
    setToken(input.value.trim());
    setText(state, token() ? "token set" : "no token: read-only");
    show(ctx); // controls re-evaluate their gates
  };
  input.addEventListener("change", apply);
  setText(state, token() ? "token set" : "no token: read-only");
  el.replaceChildren(input, state);
}

async function boot(): Promise<void> {
  const [info, lines] = await Promise.all([get<Info>("/api/info"), get<Line[]>("/api/lines")]);
  const live = new Live();
  await live.start();
  const ctx: Ctx = { info, live, lines, fields: fieldsLoader() };
  (window as unknown as { lecLive: Live }).lecLive = live; // for the browser tests
  const link = document.getElementById("link")!;
  const showLink = (up: boolean) => {
    setText(link, up ? "live" : "reconnecting…");
    toggle(link, "down", !up);
  };
  live.link.on(showLink);
  showLink(live.connected);
  nav(ctx);
  access(ctx);
  window.addEventListener("hashchange", () => show(ctx));
  show(ctx);
}

boot().catch((e: Error) => {
  document.getElementById("page")!.replaceChildren(h("p", { class: "bad" }, `lec serve did not answer: ${e.message}`));
});
