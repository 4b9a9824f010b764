// Hold-to-run jog: the axis moves while the button is held. The page renews
// a short lease on the daemon while held and releases on every way a hold
// can end (pointer up, pointer lost, window blur, tab hidden). If the page
// itself dies, the daemon stops the jog: the lease runs out, or the event
// stream named in the request closes (docs/api.md, jog).
import { post } from "./api";
import type { Live } from "./live";

const LEASE_MS = 500;
const RENEW_MS = 150; // three renewals per lease: one lost request is not a stop

export function holdToRun(
  button: HTMLButtonElement,
  axis: () => string,
  direction: "+" | "-",
  live: Live,
  report: (text: string, ok: boolean) => void,
): () => void {
  let timer: number | undefined;
  let held = false;

  const body = () => ({ direction, lease_ms: LEASE_MS, ...(live.streamId !== null ? { stream: live.streamId } : {}) });
  const url = () => `/api/axes/${encodeURIComponent(axis())}/jog`;

  const renew = async () => {
    if (!held) return;
    const a = await post(url(), body());
    if (a.status !== 200 && held) {
      release();
      report(`jog ${direction}: ${a.body.error ?? a.body.message ?? `HTTP ${a.status}`}`, false);
    }
  };

  const press = async (e: PointerEvent) => {
    if (button.disabled || held || e.button !== 0) return;
    button.setPointerCapture(e.pointerId);
    held = true;
    button.classList.add("held");
    // Started without waiting: the answer of a jog comes when it ends.
    const a = await post(`${url()}?wait=false`, body());
    if (a.status !== 202 && a.status !== 200) {
      held = false;
      button.classList.remove("held");
      report(`jog ${direction}: ${a.body.error ?? `HTTP ${a.status}`}`, false);
      return;
    }
    if (held) timer = window.setInterval(renew, RENEW_MS);
    else void post(`/api/axes/${encodeURIComponent(axis())}/jog-stop`, {});
  };

  const release = () => {
    if (!held) return;
    held = false;
    button.classList.remove("held");
    window.clearInterval(timer);
    timer = undefined;
    void post(`/api/axes/${encodeURIComponent(axis())}/jog-stop`, {});
  };
  const onHidden = () => document.visibilityState === "hidden" && release();

  button.addEventListener("pointerdown", press);
  for (const ev of ["pointerup", "pointercancel", "lostpointercapture"]) button.addEventListener(ev, release);
  button.addEventListener("contextmenu", (e) => e.preventDefault()); // long press on a touch panel
  window.addEventListener("blur", release);
  document.addEventListener("visibilitychange", onHidden);
  return () => {
    release();
    window.removeEventListener("blur", release);
    document.removeEventListener("visibilitychange", onHidden);
  };
}
