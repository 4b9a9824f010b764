// The monitor graph of one axis: position, speed and thrust against time,
// fed sample by sample from the telemetry stream and drawn at most once per
// animation frame (uPlot redraws thousands of points in well under 1 ms).
import uPlot from "uplot";
import "uplot/dist/uPlot.min.css";
import type { Axis } from "./types";
import { frameScheduler } from "./dom";

const KEEP_S = 60; // the longest window
const CAPTURE_MAX = 30000; // 10 min at 50 Hz: a forgotten capture cannot eat the tab

export interface Sample {
  t: number; // s since the epoch
  position_mm: number;
  speed_mm_s: number;
  thrust_pct: number;
  busy: boolean;
  inp: boolean;
}

export class TracePlot {
  windowS = 10;
  private paused = false;
  private cols: [number[], number[], number[], number[]] = [[], [], [], []];
  private bits: number[] = []; // BUSY | INP << 1, beside the plotted columns
  private capture: Sample[] | null = null;
  private capturing = false;
  private plot: uPlot;
  private resize: ResizeObserver;
  readonly redraw = frameScheduler(() => this.draw());
  onChange: () => void = () => undefined;

  constructor(host: HTMLElement) {
    const opts: uPlot.Options = {
      width: Math.max(300, host.clientWidth),
      height: 300,
      cursor: { drag: { x: true, y: false, setScale: true } },
      scales: { x: { time: true } },
      series: [
        { value: (_u, v) => (v == null ? "" : clockTime(v, 1)) },
        { label: "Position", scale: "mm", stroke: "#1f6feb", width: 2, value: (_u, v) => fmt(v, 2, "mm") },
        { label: "Speed", scale: "mm/s", stroke: "#d97706", width: 1.5, value: (_u, v) => fmt(v, 0, "mm/s") },
        { label: "Thrust", scale: "%", stroke: "#16a34a", width: 1.5, value: (_u, v) => fmt(v, 0, "%") },
      ],
      axes: [
        clockAxis,
        { scale: "mm", label: "mm", stroke: "#1f6feb" },
        { scale: "mm/s", label: "mm/s", side: 1, stroke: "#d97706", grid: { show: false } },
        { scale: "%", label: "%", side: 1, stroke: "#16a34a", grid: { show: false } },
      ],
      hooks: {
        // A drag-to-zoom freezes the view so the zoom stays put.
        setSelect: [(u) => u.select.width > 0 && this.setPaused(true)],
      },
    };
    this.plot = new uPlot(opts, this.cols as unknown as uPlot.AlignedData, host);
    this.resize = new ResizeObserver(() =>
      this.plot.setSize({ width: Math.max(300, host.clientWidth), height: this.height() }),
    );
    this.resize.observe(host);
  }

  private height(): number {
    return window.innerHeight <= 800 ? 220 : 300;
  }

  push(axis: Axis): void {
    if (axis.position_mm === undefined) return;
    const s: Sample = {
      t: Date.now() / 1000,
      position_mm: axis.position_mm,
      speed_mm_s: axis.speed_mm_s ?? 0,
      thrust_pct: axis.thrust_pct ?? 0,
      busy: axis.flags?.busy ?? false,
      inp: axis.flags?.inp ?? false,
    };
    const [t, p, v, f] = this.cols;
    t.push(s.t);
    p.push(s.position_mm);
    v.push(s.speed_mm_s);
    f.push(s.thrust_pct);
    this.bits.push(+s.busy | (+s.inp << 1));
    // Trim in batches: one splice per ~quarter window, not one per sample.
    if (t[t.length - 1] - t[0] > KEEP_S * 1.25) {
      const cut = t.findIndex((x) => x >= s.t - KEEP_S);
      for (const c of [...this.cols, this.bits]) c.splice(0, cut);
    }
    if (this.capturing && this.capture) {
      this.capture.push(s);
      if (this.capture.length >= CAPTURE_MAX) this.capturing = false;
    }
    if (!this.paused) this.redraw();
  }

  private draw(): void {
    if (this.paused) return;
    const [t] = this.cols;
    const from = t.length ? t[t.length - 1] - this.windowS : 0;
    let i = 0;
    while (i < t.length && t[i] < from) i++;
    this.plot.setData(this.cols.map((c) => c.slice(i)) as unknown as uPlot.AlignedData);
  }

  setWindow(seconds: number): void {
    this.windowS = seconds;
    this.setPaused(false);
  }

  setPaused(paused: boolean): void {
    this.paused = paused;
    if (!paused) this.redraw();
    this.onChange();
  }

  isPaused(): boolean {
    return this.paused;
  }

  // The data on screen, for the tests and anyone who asks: [t, pos, speed, thrust].
  data(): number[][] {
    return this.plot.data as unknown as number[][];
  }

  startCapture(): void {
    this.capture = [];
    this.capturing = true;
    this.onChange();
  }

  stopCapture(): void {
    this.capturing = false;
    this.onChange();
  }

  captureState(): { capturing: boolean; samples: number; seconds: number } {
    const c = this.capture ?? [];
    return {
      capturing: this.capturing,
      samples: c.length,
      seconds: c.length > 1 ? c[c.length - 1].t - c[0].t : 0,
    };
  }

  // The capture as CSV (or, with none, the last 60 s): time from its start.
  csv(): string {
    const rows: Sample[] = this.capture?.length
      ? this.capture
      : this.cols[0].map((t, n) => ({
          t,
          position_mm: this.cols[1][n],
          speed_mm_s: this.cols[2][n],
          thrust_pct: this.cols[3][n],
          busy: (this.bits[n] & 1) !== 0,
          inp: (this.bits[n] & 2) !== 0,
        }));
    const t0 = rows.length ? rows[0].t : 0;
    const lines = ["time_s,position_mm,speed_mm_s,thrust_pct,busy,inp"];
    for (const r of rows) {
      lines.push(
        `${(r.t - t0).toFixed(3)},${r.position_mm.toFixed(2)},${r.speed_mm_s},${r.thrust_pct},${+r.busy},${+r.inp}`,
      );
    }
    return lines.join("\n") + "\n";
  }

  destroy(): void {
    this.resize.disconnect();
    this.plot.destroy();
  }
}

function fmt(v: number | null, decimals: number, unit: string): string {
  return v === null || v === undefined ? "—" : `${v.toFixed(decimals)} ${unit}`;
}

// Time axes read as clock time, the same in every locale (issue 27):
// "14:05:37", and tenths or hundredths when the ticks are closer than a second.
export function clockTime(epochS: number, decimals = 0): string {
  const d = new Date(epochS * 1000);
  const p2 = (n: number) => String(n).padStart(2, "0");
  const hms = `${p2(d.getHours())}:${p2(d.getMinutes())}:${p2(d.getSeconds())}`;
  return decimals > 0 ? `${hms}.${String(Math.floor((d.getMilliseconds() / 1000) * 10 ** decimals)).padStart(decimals, "0")}` : hms;
}

export const clockAxis: uPlot.Axis = {
  space: 90, // px between ticks: room for "14:05:37.25"
  values: (_u, ticks, _axis, _space, incr) =>
    ticks.map((t) => clockTime(t, incr < 0.1 ? 2 : incr < 1 ? 1 : 0)),
};
