// The shapes of lec serve's JSON (docs/api.md), as far as the page reads them.

export interface Info {
  read_only: boolean;
  token_required: boolean;
  listener_loopback: boolean;
  lines: string[];
  axes: number;
}

export interface Flags {
  busy: boolean;
  svre: boolean;
  seton: boolean;
  inp: boolean;
  area: boolean;
  warea: boolean;
  estop: boolean;
  alarm: boolean;
  out: number;
}

export interface Inputs {
  in: number;
  hold: boolean;
  svon: boolean;
  drive: boolean;
  reset: boolean;
  setup: boolean;
  jog_minus: boolean;
  jog_plus: boolean;
  serial_mode: boolean;
}

export interface Alarm {
  code: number;
  meaning: string;
  resettable: boolean;
}

export interface Telemetry {
  name: string;
  line: string;
  id: number;
  online: boolean;
  offline_reason?: string;
  age_ms: number | null;
  error_rate: number;
  position_mm?: number;
  speed_mm_s?: number;
  thrust_pct?: number;
  target_mm?: number;
  step?: number;
  flags?: Flags;
  inputs?: Inputs;
  alarms: Alarm[];
}

export interface Operation {
  op: string;
  source: string;
  running_s?: number;
}

// A command's answer or an `op` event's "finished" result: keys vary by op.
export interface OpResult {
  ok?: boolean;
  op?: string;
  outcome?: string;
  message?: string;
  error?: string;
  field?: string;
  position_mm?: number;
  target_mm?: number;
  elapsed_s?: number;
  timeline?: Record<string, number | null>;
  [key: string]: unknown;
}

export interface Axis extends Telemetry {
  alarm_history: { group: number; alarms: Alarm[] }[];
  telemetry_hz: number;
  operation: Operation | null;
  last_result: OpResult | null;
}

export interface OpEvent extends OpResult {
  axis: string;
  event: "started" | "finished";
  source?: string;
  status?: number;
}

export interface PriorityStats {
  queue_depth: number;
  count: number;
  p50_ms: number;
  p99_ms: number;
  buckets_le_ms: number[];
  buckets: number[];
}

export interface DeviceStats {
  id: number;
  axis: string;
  transactions: number;
  answers: number;
  timeouts: number;
  crc_errors: number;
  framing_errors: number;
  exceptions: number;
}

export interface LineStats {
  transactions_per_s: number;
  utilisation: number;
  busy: number;
  transactions: number;
  cache_hits: number;
  priorities: Record<string, PriorityStats>;
  devices: DeviceStats[];
}

export interface Line {
  name: string;
  port: string;
  describe: string;
  baud: number;
  sim: boolean;
  up: boolean;
  down_reason?: string;
  axes: { id: number; name: string }[];
  stats: LineStats;
}

export interface FieldInfo {
  name: string;
  csv_column: string;
  label: string;
  unit: string;
  min: number;
  max: number;
  is_length: boolean;
  decimals: number;
  default: number;
  choices?: { value: number; text: string }[];
}

export interface FieldRule {
  field: string;
  at_most: string;
  when_positive: string;
  message: string;
}

export interface Fields {
  fields: FieldInfo[];
  rules: FieldRule[];
  steps: number;
}

// One step as the CLI's JSON writes it (csv_column keys; mode as text).
export type StepRecord = Record<string, number | string>;
