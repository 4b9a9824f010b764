// What every page gets: the daemon's info, the live store, the lines, the
// step field table (fetched once, when first needed).
import { get } from "./api";
import type { Live } from "./live";
import type { Fields, Info, Line } from "./types";

export interface Ctx {
  info: Info;
  live: Live;
  lines: Line[];
  fields: () => Promise<Fields>;
}

export interface Page {
  el: HTMLElement;
  destroy?: () => void;
}

export function fieldsLoader(): () => Promise<Fields> {
  let p: Promise<Fields> | null = null;
  return () => (p ??= get<Fields>("/api/fields"));
}

// Renders changed axes once per frame, and ages (which grow between events) twice a second.
export function watchAxes(live: Live, render: (names: Set<string>) => void): () => void {
  const dirty = new Set<string>();
  let pending = false;
  const flush = () => {
    pending = false;
    const names = new Set(dirty);
    dirty.clear();
    render(names);
  };
  const off = live.telemetry.on((a) => {
    dirty.add(a.name);
    if (!pending) {
      pending = true;
      requestAnimationFrame(flush);
    }
  });
  const tick = window.setInterval(() => render(new Set(live.axes.keys())), 500);
  return () => {
    off();
    window.clearInterval(tick);
  };
}
