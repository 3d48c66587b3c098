// One card per controller: connection state (and the last error when not connected), build and
// modules, every axis's position in um, busy, TTL modes, the lease holder, the running job with its
// progress, the encoder-report rate and gaps where there is a report port, a HALT button, a jog pad
// and a link to the controller view. Values come from the WebSocket's state and position events; a
// card greys them out when they are not live (feed down or controller not connected).

import * as api from "./api.js";
import { el, formatDuration, formatUm, haltedText, showConnectionState } from "./dom.js";

const STEPS_UM = [1, 10, 100, 1000, 10000];

export class ControllerCard {
  constructor(id) {
    this.id = id;
    this.state = null;
    this.axisRows = new Map();  // axis -> {pos, busy}
    this.axesKey = "";
    this.gaps = 0;
    this.build();
  }

  build() {
    this.stateBadge = el("span", { class: "state" }, "unknown");
    this.haltButton = el("button", { class: "halt", type: "button", "data-halt": this.id }, "HALT");
    this.haltButton.addEventListener("click", () => this.halt());
    this.lastError = el("div", { class: "last-error", hidden: true });
    this.haltedLine = el("div", { class: "halted-line", hidden: true, role: "status" });
    this.identity = el("div", { class: "meta" });
    this.modules = el("div", { class: "meta" });
    this.axesTable = el("table", { class: "axes" });
    this.status = el("div", { class: "meta live-value" });
    this.leaseLine = el("div", { class: "meta" }, "lease: …");
    this.jobLine = el("div", { class: "card-job live-value", hidden: true });
    this.reportLine = el("div", { class: "meta live-value", hidden: true, "data-reports": this.id });
    this.stepSelect = el("select", { title: "jog step" },
                         ...STEPS_UM.map((s) => el("option", { value: String(s), selected: s === 100 }, `${s} µm`)));
    this.jog = el("div", { class: "jog", "data-needs": "operator" }, el("span", {}, "jog"), this.stepSelect);
    this.opError = el("div", { class: "op-error" });
    this.root = el("section", { class: "card offline", "data-controller": this.id },
                   el("div", { class: "card-head" }, el("h2", {}, el("a", { href: `#/controller/${encodeURIComponent(this.id)}` }, this.id)), this.stateBadge, this.haltButton),
                   this.haltedLine, this.lastError, this.identity, this.modules, this.axesTable, this.status, this.leaseLine,
                   this.jobLine, this.reportLine, this.jog, this.opError,
                   el("a", { class: "card-open", href: `#/controller/${encodeURIComponent(this.id)}`, "data-open": this.id },
                      "Open controller view →"));
  }

  async halt() {
    this.opError.textContent = "";
    try {
      await api.halt(this.id);
    } catch (e) {
      this.opError.textContent = `halt: ${e.message}`;
    }
  }

  async jogBy(axis, sign) {
    this.opError.textContent = "";
    try {
      await api.moveRelative(this.id, { [axis]: sign * Number(this.stepSelect.value) });
    } catch (e) {
      this.opError.textContent = `move ${axis}: ${e.message}`;
    }
  }

  // The axes table and the jog buttons, rebuilt only when the controller's axes change.
  setAxes(axes) {
    const key = axes.map((a) => a.axis).join("");
    if (key === this.axesKey) return;
    this.axesKey = key;
    this.axesTable.replaceChildren();
    this.axisRows.clear();
    for (const b of this.jog.querySelectorAll("button")) b.remove();
    for (const a of axes) {
      const pos = el("td", { class: "pos live-value", "data-axis": a.axis });
      const busy = el("td", { class: "busy live-value" });
      this.axesTable.append(el("tr", {}, el("td", { class: "axis" }, a.axis), pos, el("td", {}, "µm"), busy));
      this.axisRows.set(a.axis, { pos, busy });
      for (const sign of [-1, 1]) {
        const b = el("button", { type: "button", "data-jog": `${a.axis}${sign < 0 ? "-" : "+"}` },
                     `${a.axis}${sign < 0 ? "−" : "+"}`);
        b.addEventListener("click", () => this.jogBy(a.axis, sign));
        this.jog.append(b);
      }
    }
  }

  setPositions(axes, busy) {
    this.setAxes(axes);
    for (const a of axes) {
      const row = this.axisRows.get(a.axis);
      if (!row) continue;
      row.pos.textContent = formatUm(a.position_um);
      row.busy.textContent = a.busy ? "busy" : "";
    }
    this.busy = busy;
    this.root.dataset.busy = busy ? "yes" : "no";
    this.renderStatus();
  }

  // A ControllerState (REST or a controllers/<id>/state event).
  setState(s) {
    this.state = s;
    showConnectionState(this.root, this.stateBadge, s.state);
    const err = s.last_error;
    this.lastError.hidden = s.state === "connected" || !err;
    this.lastError.textContent = err ? `${err.text || err.name} (${err.time})` : "";
    this.haltedLine.hidden = !s.halted;
    this.haltedLine.textContent = haltedText(s.halted);
    this.root.dataset.halted = s.halted ? "yes" : "no";
    const id = s.identity;
    this.identity.textContent = id ? `build ${id.build}, firmware ${id.version}, axes ${id.motor_axes}` : "not identified";
    this.modules.textContent = id ? `modules: ${id.modules.length ? id.modules.join(", ") : "none"}` : "";
    this.ttl = s.ttl;
    if (s.axes?.length) this.setPositions(s.axes, s.busy);
    else this.renderStatus();
  }

  renderStatus() {
    const ttl = this.ttl ? `TTL in0 mode ${this.ttl.in0_mode ?? "?"}, out0 mode ${this.ttl.out0_mode ?? "?"}` : "";
    const gaps = this.gaps ? `, ${this.gaps} gap${this.gaps > 1 ? "s" : ""} in the feed` : "";
    this.status.textContent = `${this.busy ? "busy" : "idle"} · ${ttl}${gaps}`;
  }

  setLease(lease, error) {
    if (error) this.leaseLine.textContent = `lease: unknown (${error})`;
    else if (!lease) this.leaseLine.textContent = "lease: free";
    else this.leaseLine.textContent = `lease: ${lease.holder} until ${lease.expires}`;
  }

  // The controller's running job (a Job from GET /api/v1/jobs), or null.
  setJob(job) {
    this.jobLine.hidden = !job;
    this.root.dataset.job = job ? job.id : "";
    // The job holds the controller: its moves are the job's (409 job-active); HALT stays.
    for (const b of this.jog.querySelectorAll("button")) {
      b.disabled = Boolean(job);
      b.title = job ? "a job runs here: open the controller view" : "";
    }
    if (!job) return this.jobLine.replaceChildren();
    const p = job.progress || {};
    const percent = Math.max(0, Math.min(100, p.percent ?? 0));
    const step = p.current_step ? ` · ${p.current_step}` : "";
    const waiting = p.waiting_for ? ` · waiting for ${p.waiting_for}` : "";
    const endS = p.eta ? (Date.parse(p.eta) - Date.now()) / 1000 : p.remaining_s;
    const left = typeof endS === "number" ? ` · ${formatDuration(Math.max(0, endS))} left` : "";
    this.jobLine.replaceChildren(
      el("a", { href: `#/jobs/${encodeURIComponent(job.id)}` }, `${job.type} job`),
      ` ${percent.toFixed(0)} % (${p.steps_done ?? 0}/${p.steps_total ?? "?"})${step}${waiting}${left}`,
      el("progress", { max: 100, value: percent }));
  }

  // The counts of the encoder report stream (report_stats.js), or null without a report port.
  setReports(stats) {
    this.reportLine.hidden = !stats;
    if (stats) {
      this.reportLine.textContent = `encoder reports: ${stats.summary()}`;
      this.reportLine.dataset.frames = String(stats.frames);
    }
  }

  gap() {
    this.gaps += 1;
    this.renderStatus();
  }
}
