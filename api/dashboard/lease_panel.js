// The lease of one controller: who holds it and until when (counting down), and take (ttl_s, an
// optional holder label) / renew / release for this page. While this page holds it, api.js sends its
// Lease-Id with every call about the controller. Leases have no events: the store polls them every
// 5 s and at once after this panel changes one.

import * as api from "./api.js";
import { actionButton, labelled, numberInput, numberValue } from "./controls.js";
import { el, formatDuration } from "./dom.js";
import { store } from "./store.js";

const DEFAULT_TTL_S = 60;

export class LeasePanel {
  constructor(id) {
    this.id = id;
    this.lease = null;
    this.deadline = null;  // local ms when the lease ends (from expires_in_s when it was read)
    this.build();
    this.timer = setInterval(() => this.renderCountdown(), 1000);
  }

  build() {
    this.status = el("span", { class: "lease-status live-value", "data-lease": "free" }, "lease: …");
    this.countdown = el("span", { class: "lease-countdown live-value" });
    this.error = el("div", { class: "op-error", role: "alert" });
    this.ttl = numberInput({ name: "lease-ttl", min: 1, max: 86400, step: 1, value: DEFAULT_TTL_S, size: "short" });
    this.holder = el("input", { type: "text", name: "lease-holder", placeholder: "label (optional)", maxLength: 64, "data-input": "lease-holder" });
    const done = () => store.refreshLeases();
    this.takeButton = actionButton("Take lease", this.error, () => api.takeLease(this.id, this.ttlS(), this.holder.value.trim()),
                                   { name: "lease-take", onDone: done });
    this.renewButton = actionButton("Renew", this.error, () => api.renewLease(this.id, this.ttlS()), { name: "lease-renew", onDone: done });
    this.releaseButton = actionButton("Release", this.error, () => api.releaseLease(this.id), { name: "lease-release", onDone: done });
    this.forceButton = actionButton("Force release", this.error,
                                    () => api.request("DELETE", `/api/v1/controllers/${encodeURIComponent(this.id)}/lease?force=true`),
                                    { name: "lease-force", onDone: done, title: "admin: end whoever's lease this is" });
    this.forceButton.dataset.needs = "admin";
    this.controls = el("div", { class: "lease-controls", "data-needs": "operator" },
                       labelled("for (s)", this.ttl), this.holder, this.takeButton, this.renewButton, this.releaseButton,
                       this.forceButton);
    this.root = el("section", { class: "lease-panel", "data-lease-panel": this.id },
                   el("div", { class: "lease-line" }, this.status, this.countdown), this.controls, this.error);
    this.show(null, "pending", false);
  }

  ttlS() {
    const v = numberValue(this.ttl);
    if (v === null || v < 1 || v > 86400) throw new Error("the lease time is 1 to 86400 s");
    return v;
  }

  // From the store's "lease" events: lease is the GET answer (null when free), mine whether this page
  // holds it.
  show(lease, error, mine) {
    this.lease = lease;
    this.mine = mine;
    this.deadline = lease ? Date.now() + (lease.expires_in_s ?? (Date.parse(lease.expires) - Date.now()) / 1000) * 1000 : null;
    const state = error ? "unknown" : !lease ? "free" : mine ? "mine" : "other";
    this.status.dataset.lease = state;
    this.root.dataset.lease = state;
    if (error === "pending") this.status.textContent = "lease: …";
    else if (state === "unknown") this.status.textContent = `lease: unknown (${error})`;
    else if (state === "free") this.status.textContent = "lease: free";
    else if (state === "mine") this.status.textContent = `leased by this page (${lease.holder})`;
    else this.status.textContent = `leased by ${lease.holder}: moves from this page are refused`;
    this.takeButton.hidden = state !== "free";
    this.renewButton.hidden = state !== "mine";
    this.releaseButton.hidden = state !== "mine";
    this.forceButton.hidden = state !== "other";
    this.holder.hidden = state !== "free";
    this.renderCountdown();
  }

  renderCountdown() {
    if (!this.lease || this.deadline === null) {
      this.countdown.textContent = "";
      return;
    }
    const left = (this.deadline - Date.now()) / 1000;
    const until = new Date(Date.parse(this.lease.expires)).toLocaleTimeString();
    const rest = left >= 60 ? formatDuration(left) : `${Math.ceil(left)} s`;
    this.countdown.textContent = left > 0 ? `until ${until} (${rest} left)` : `expired at ${until}`;
  }

  destroy() {
    clearInterval(this.timer);
  }
}
