// The page's view of the daemon: every axis from GET /api/axes, then kept
// current by the Server-Sent Events of /api/events (telemetry, op, stats).
// The browser never polls; all tabs read the daemon's cache.
import { get } from "./api";
import type { Axis, LineStats, OpEvent, Telemetry } from "./types";

type Listener<T> = (value: T) => void;

class Topic<T> {
  private listeners = new Set<Listener<T>>();
  on(fn: Listener<T>): () => void {
    this.listeners.add(fn);
    return () => this.listeners.delete(fn);
  }
  emit(value: T): void {
    for (const fn of this.listeners) fn(value);
  }
}

export class Live {
  readonly axes = new Map<string, Axis>();
  // When each axis' last telemetry arrived (ms, performance.now()).
  readonly arrived = new Map<string, number>();
  readonly stats = new Map<string, LineStats>();
  // Op events seen per axis: a refresh answered after a newer event is stale.
  private readonly opSeq = new Map<string, number>();
  streamId: number | null = null;
  connected = false;

  readonly telemetry = new Topic<Axis>();
  readonly ops = new Topic<OpEvent>();
  readonly statsUpdate = new Topic<Map<string, LineStats>>();
  readonly link = new Topic<boolean>();
  // The move history's health of an axis after each record (docs/history.md).
  readonly health = new Topic<{ axis: string }>();

  private source: EventSource | null = null;

  async start(): Promise<void> {
    await this.refresh();
    this.connect();
  }

  // Operation and last result are not in the telemetry: read them whole
  // at start and after a reconnect.
  async refresh(): Promise<void> {
    const axes = await get<Axis[]>("/api/axes");
    for (const a of axes) {
      this.axes.set(a.name, a);
      this.arrived.set(a.name, performance.now());
    }
  }

  close(): void {
    this.source?.close();
    this.source = null;
    this.setConnected(false);
  }

  private connect(): void {
    const es = new EventSource("/api/events");
    this.source = es;
    es.addEventListener("hello", (e) => {
      this.streamId = JSON.parse((e as MessageEvent).data).stream;
      const wasDown = !this.connected;
      this.setConnected(true);
      if (wasDown) void this.refresh().catch(() => undefined);
    });
    es.addEventListener("telemetry", (e) => this.onTelemetry(JSON.parse((e as MessageEvent).data)));
    es.addEventListener("op", (e) => this.onOp(JSON.parse((e as MessageEvent).data)));
    es.addEventListener("health", (e) => this.health.emit(JSON.parse((e as MessageEvent).data)));
    es.addEventListener("stats", (e) => {
      const data = JSON.parse((e as MessageEvent).data) as { lines: { name: string; stats: LineStats }[] };
      for (const l of data.lines) this.stats.set(l.name, l.stats);
      this.statsUpdate.emit(this.stats);
    });
    // EventSource reconnects by itself; a new hello gives a new stream id.
    es.onerror = () => {
      this.streamId = null;
      this.setConnected(false);
    };
  }

  private setConnected(up: boolean): void {
    if (this.connected === up) return;
    this.connected = up;
    this.link.emit(up);
  }

  private onTelemetry(t: Telemetry): void {
    const axis = this.axes.get(t.name);
    if (!axis) return;
    Object.assign(axis, t);
    this.arrived.set(t.name, performance.now());
    this.telemetry.emit(axis);
  }

  private onOp(e: OpEvent): void {
    const axis = this.axes.get(e.axis);
    this.opSeq.set(e.axis, (this.opSeq.get(e.axis) ?? 0) + 1);
    // Only motions occupy an axis; stop, servo… come and go beside them.
    if (axis && e.event === "started" && isMotion(String(e.op))) {
      axis.operation = { op: String(e.op), source: e.source ?? "" };
      this.telemetry.emit(axis);
    } else if (axis && e.event !== "started") {
      if (isMotion(String(e.op))) {
        axis.operation = null;
        axis.last_result = e;
        this.telemetry.emit(axis);
      }
      // Whatever ended (a move the controller refused with an alarm answers
      // without an `op`; a RESET may end a motion), the daemon's own state
      // decides what runs now, not the page's guess (issue 27).
      void this.refreshAxis(e.axis).catch(() => undefined);
    }
    this.ops.emit(e);
  }

  // The daemon's view of one axis' operation; dropped when another op event
  // arrived meanwhile (it is newer than this answer).
  private async refreshAxis(name: string): Promise<void> {
    const seq = this.opSeq.get(name);
    const a = await get<Axis>(`/api/axes/${encodeURIComponent(name)}`);
    const axis = this.axes.get(name);
    if (!axis || this.opSeq.get(name) !== seq) return;
    axis.operation = a.operation;
    if (a.last_result) axis.last_result = a.last_result;
    this.telemetry.emit(axis);
  }
}

export function isMotion(op: string): boolean {
  return op === "move" || op === "home" || op === "run-step" || op === "jog";
}

// Age of the controller's last answer now, from the age it had when sent.
export function ageMs(live: Live, axis: Axis): number | null {
  if (axis.age_ms === null || axis.age_ms === undefined) return null;
  return axis.age_ms + (performance.now() - (live.arrived.get(axis.name) ?? performance.now()));
}
