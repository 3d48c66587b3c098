// The focus modules' controls: CRISP (the continuous focus lock: lock, unlock, LED off, the lock
// offset, saving, and its readings) and AUTOFOCUS (a focus scan, waited for). The CRISP state line
// follows the controller's state events; the readings are those of the last call.

import * as api from "./api.js";
import { actionButton, controlGroup, labelled, numberInput, numberValue } from "./controls.js";
import { el } from "./dom.js";

const shown = (v, digits = 0) => (typeof v === "number" ? v.toFixed(digits) : "–");

export class CrispControls {
  constructor(id) {
    this.id = id;
    const g = controlGroup("CRISP focus lock", { name: "crisp" });
    this.root = g.root;
    this.state = el("div", { class: "meta live-value", "data-crisp-state": "" }, "state: unknown");
    this.readings = el("div", { class: "meta", "data-crisp-readings": "" });
    const call = (label, name, args) => actionButton(label, g.error, () => api.operation(this.id, "crisp", args),
                                                     { name, onDone: (r) => this.showReadings(r.crisp) });
    const offset = numberInput({ name: "crisp-offset", min: -32767, max: 32767, step: 1, placeholder: "offset" });
    const setOffset = actionButton("Set offset", g.error, () => {
      const v = numberValue(offset);
      if (v === null) throw new Error("enter a lock offset (-32767 to 32767)");
      return api.operation(this.id, "crisp", { lock_offset: v });
    }, { name: "crisp-offset", onDone: (r) => this.showReadings(r.crisp) });
    g.body.append(this.state,
                  el("div", { class: "row" }, call("Lock", "crisp-lock", { action: "lock", wait: true }),
                     call("Unlock", "crisp-unlock", { action: "unlock" }), call("LED off", "crisp-off", { action: "off" }),
                     call("Read", "crisp-read", {})),
                  el("div", { class: "row" }, labelled("lock offset", offset), setOffset,
                     call("Save settings", "crisp-save", { save: true })),
                  this.readings);
  }

  // The state's crisp: {state: "F", name: "locked"} or null.
  setState(crisp) {
    this.state.dataset.crispState = crisp?.state ?? "";
    this.state.textContent = crisp ? `state: ${crisp.name.replaceAll("_", " ")} (${crisp.state})` : "state: unknown";
  }

  showReadings(c) {
    this.setState(c);
    this.readings.textContent = `focus error ${shown(c.focus_error)}, sum ${shown(c.sum)}, ` +
      `SNR ${shown(c.snr, 1)}, lock offset ${shown(c.lock_offset)}`;
  }
}

export function autofocusGroup(id) {
  const g = controlGroup("Autofocus", { name: "autofocus" });
  const done = el("span", { class: "meta", "data-last": "autofocus" });
  const run = actionButton("Run focus scan", g.error, () => api.operation(id, "autofocus", {}), {
    name: "autofocus",
    onDone: (r) => { done.textContent = `in focus at Z = ${r.z_um.toFixed(1)} µm`; },
  });
  g.body.append(el("div", { class: "row" }, run, done));
  return g.root;
}
