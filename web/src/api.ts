// Calls to lec serve's HTTP API. Writes carry the token when the listener
// needs one (kept in sessionStorage: gone when the tab closes).
import type { OpResult } from "./types";

const TOKEN_KEY = "lec6.token";

export function token(): string {
  return sessionStorage.getItem(TOKEN_KEY) ?? "";
}

export function setToken(value: string): void {
  if (value) sessionStorage.setItem(TOKEN_KEY, value);
  else sessionStorage.removeItem(TOKEN_KEY);
}

export interface Answer<T = OpResult> {
  status: number;
  body: T;
}

function headers(contentType?: string): HeadersInit {
  const h: Record<string, string> = {};
  if (contentType) h["Content-Type"] = contentType;
  if (token()) h["Authorization"] = `Bearer ${token()}`;
  return h;
}

async function parse<T>(res: Response): Promise<Answer<T>> {
  const text = await res.text();
  let body: unknown;
  try {
    body = text ? JSON.parse(text) : {};
  } catch {
    body = { error: text || res.statusText };
  }
  return { status: res.status, body: body as T };
}

export async function get<T>(path: string): Promise<T> {
  const res = await fetch(path, { headers: headers() });
  const a = await parse<T>(res);
  if (res.status !== 200) throw new Error(errorText(a.body as OpResult, res.status));
  return a.body;
}

// A write: the answer whatever its status (the page shows errors as results).
export async function send<T = OpResult>(
  method: "POST" | "PUT",
  path: string,
  body?: unknown,
  contentType = "application/json",
): Promise<Answer<T>> {
  const payload =
    body === undefined ? undefined : typeof body === "string" ? body : JSON.stringify(body);
  try {
    const res = await fetch(path, { method, headers: headers(contentType), body: payload });
    return await parse<T>(res);
  } catch (e) {
    return { status: 0, body: { ok: false, error: `lec serve did not answer: ${e}` } as T };
  }
}

export function post(path: string, body?: unknown): Promise<Answer> {
  return send("POST", path, body);
}

export function errorText(body: OpResult, status: number): string {
  const what = body.error ?? body.message ?? `HTTP ${status}`;
  if (status === 401) return `${what} (enter the token in the header)`;
  return String(what);
}
