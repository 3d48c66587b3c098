// The controller's shared port (its "share" in GET /api/v1/controllers/{id}): where programs that speak
// MS-2000 themselves reach it (the pty path, the TCP address), the role they have, whether the port
// holds the lease, and who is connected with what they sent. Shares have no events: the panel asks
// every 2 s while the view is open. Hidden for a controller without a share.

import * as api from "./api.js";
import { el, formatDuration } from "./dom.js";

const POLL_MS = 2000;

export class SharePanel {
  constructor(id) {
    this.id = id;
    this.destroyed = false;
    this.timer = null;
    this.where = el("span", { class: "share-where" });
    this.counts = el("span", { class: "share-counts live-value" });
    this.clients = el("tbody");
    this.root = el("section", { class: "share-panel", hidden: true, "data-share-panel": id },
                   el("div", { class: "share-line" }, el("strong", {}, "Shared port"), this.where, this.counts),
                   el("table", { class: "share-clients" },
                      el("thead", {}, el("tr", {}, ...["program", "connected for", "commands", "refused", "unread bytes dropped"]
                        .map((h) => el("th", {}, h)))),
                      this.clients));
    this.poll();
  }

  async poll() {
    try {
      this.show((await api.controller(this.id)).share ?? null);
    } catch {
      // the live banner says when the gateway is away; the last answer stands
    }
    if (!this.destroyed) this.timer = setTimeout(() => this.poll(), POLL_MS);
  }

  show(share) {
    this.root.hidden = !share;
    if (!share) return;
    const places = [share.pty && `pty ${share.pty}`, share.tcp && `tcp ${share.tcp}`,
                    share.report_pty && `reports ${share.report_pty}`, share.report_tcp && `reports tcp ${share.report_tcp}`];
    this.where.textContent = [...places.filter(Boolean), `role ${share.role}`,
                              share.lease ? (share.holds_lease ? "holds the lease" : "takes the lease when a program connects") : ""]
      .filter(Boolean).join(" · ");
    this.counts.textContent = `${share.commands} commands, ${share.refused} refused`;
    const programs = [...share.clients, ...share.report_readers];
    this.root.dataset.clients = String(programs.length);
    if (!programs.length) {
      this.clients.replaceChildren(el("tr", {}, el("td", { colspan: 5, class: "meta" }, "no program connected")));
      return;
    }
    this.clients.replaceChildren(...programs.map((c) => el("tr", { "data-share-client": c.name },
      el("td", {}, c.name),
      el("td", {}, formatDuration((Date.now() - Date.parse(c.since)) / 1000)),
      el("td", { class: "num" }, String(c.commands)),
      el("td", { class: "num" }, String(c.refused)),
      el("td", { class: "num" }, String(c.dropped_bytes)))));
  }

  destroy() {
    this.destroyed = true;
    clearTimeout(this.timer);
  }
}
