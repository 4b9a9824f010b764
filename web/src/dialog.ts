// A modal for previews and confirmations (the native <dialog>).
import { h } from "./dom";

export interface DialogButton {
  label: string;
  cls?: string;
  disabled?: string | null; // why it is disabled
  action?: () => Promise<void> | void; // none: just closes
}

export function openDialog(title: string, body: HTMLElement, buttons: DialogButton[]): HTMLDialogElement {
  const footer = h("footer", {});
  const dlg = h("dialog", { class: "modal" }, h("h3", {}, title), h("div", { class: "dialog-body" }, body), footer);
  for (const b of buttons) {
    const el = h("button", { class: b.cls ?? "", disabled: !!b.disabled, title: b.disabled ?? "" }, b.label);
    el.addEventListener("click", async () => {
      if (b.action) {
        footer.querySelectorAll("button").forEach((x) => (x.disabled = true));
        await b.action();
      }
      dlg.close();
    });
    footer.appendChild(el);
  }
  dlg.addEventListener("close", () => dlg.remove());
  document.body.appendChild(dlg);
  dlg.showModal();
  return dlg;
}

export function changeTable(rows: { step: number; label: string; controller: string; wanted: string }[], wantedHeader: string): HTMLElement {
  return h(
    "table",
    { class: "diff" },
    h("thead", {}, h("tr", {}, h("th", {}, "Step"), h("th", {}, "Field"), h("th", {}, "Controller"), h("th", {}, wantedHeader))),
    h(
      "tbody",
      {},
      ...rows.map((r) =>
        h("tr", {}, h("td", {}, String(r.step)), h("td", {}, r.label), h("td", { class: "old" }, r.controller), h("td", { class: "new" }, r.wanted)),
      ),
    ),
  );
}
