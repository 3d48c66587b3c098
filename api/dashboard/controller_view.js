// The controller view (#/controller/<id>): the controller's state, build and modules, a big HALT, its
// lease; the position of every axis; a live XY map with trail and soft limits; a live chart of the
// positions (10 Hz) and, where the controller has a report port, of its encoder report frames (every
// frame counted, a few drawn), with TTL events marked; the motion and module controls; its shared port
// and the programs connected to it. While a job
// holds the controller (running or paused there), the controls are disabled and say why: only the
// lease it runs under may change the controller then (409 job-active); HALT always works.

import * as api from "./api.js";
import { el, errorText, formatUm, haltedText, showConnectionState } from "./dom.js";
import { LeasePanel } from "./lease_panel.js";
import { ModuleControls } from "./module_controls.js";
import { MotionControls } from "./motion_controls.js";
import { ReportStats } from "./report_stats.js";
import { SharePanel } from "./share_panel.js";
import { store } from "./store.js";
import { axisColour, TimeChart } from "./time_chart.js";
import { XYPlot } from "./xy_plot.js";

const CHART_WINDOW_S = 30;
const HOLD_POLL_MS = 2000;  // how often the view asks which job holds the controller
const REPORT_DRAW_INTERVAL_S = 0.02;  // at most 50 report frames a second are drawn; all are counted
const seconds = (iso) => Date.parse(iso) / 1000;

class ControllerView {
  constructor(id) {
    this.id = id;
    this.state = null;
    this.hold = null;  // the job that holds the controller (setHold)
    this.unmounted = false;
    this.holdTimer = null;
    this.axesKey = null;
    this.chartKey = null;
    this.axisRows = new Map();
    this.stops = [];
    this.reportStop = null;
    this.ttlStop = null;
    this.stats = null;
    this.ttlEvents = 0;
    this.lease = new LeasePanel(id);
    this.share = new SharePanel(id);
    this.motion = new MotionControls(id);
    this.modules = new ModuleControls(id);
    this.xy = new XYPlot({ title: id });
    this.chart = new TimeChart({ windowS: CHART_WINDOW_S, height: 230 });
    this.build();
    this.statsTimer = setInterval(() => this.renderStats(), 1000);
  }

  build() {
    this.badge = el("span", { class: "state" }, "unknown");
    this.halt = el("button", { class: "halt halt-big", type: "button", "data-halt": this.id, title: "stop every axis now (works even when leased)" }, "HALT");
    this.halt.addEventListener("click", () => this.haltNow());
    this.haltError = el("div", { class: "op-error", role: "alert" });
    this.haltedLine = el("div", { class: "halted-line", hidden: true, role: "status" });
    this.holdLine = el("div", { class: "hold-line", hidden: true, role: "status" });
    // Disabled together while a job holds the controller (and this page does not hold its lease).
    this.motionSet = el("fieldset", { class: "held-controls" }, this.motion.root);
    this.modulesSet = el("fieldset", { class: "held-controls" }, this.modules.root);
    this.identity = el("div", { class: "meta" }, "not identified yet");
    this.lastError = el("div", { class: "last-error", hidden: true });
    this.hint = el("div", { class: "hint", hidden: true });
    this.axesTable = el("table", { class: "axes ctl-axes" });
    this.busy = el("div", { class: "meta live-value" });
    this.chartNote = el("div", { class: "meta" });
    this.reportLine = el("div", { class: "report-stats live-value", hidden: true, "data-reports": this.id });
    this.root = el("div", { class: "ctl-view offline", "data-controller-view": this.id },
                   el("header", { class: "ctl-head" },
                      el("div", { class: "ctl-heading" },
                         el("div", { class: "ctl-title" },
                            el("h2", {}, el("a", { href: "#/" }, "Controllers"), " / ", this.id), this.badge),
                         this.identity),
                      this.halt),
                   this.haltError, this.haltedLine, this.holdLine, this.lastError, this.hint, this.lease.root, this.share.root,
                   el("div", { class: "ctl-grid" },
                      el("section", { class: "panel panel-position" }, el("h3", {}, "Position"), this.axesTable, this.busy, this.xy.root),
                      el("section", { class: "panel panel-chart" },
                         el("div", { class: "chart-head" }, el("h3", {}, `Last ${CHART_WINDOW_S} s`), this.chartNote),
                         this.reportLine, this.chart.root),
                      el("section", { class: "panel panel-motion" }, el("h3", {}, "Motion"), this.motionSet),
                      el("section", { class: "panel panel-modules" }, el("h3", {}, "Modules"), this.modulesSet)));
  }

  async haltNow() {
    this.haltError.textContent = "";
    try {
      await api.halt(this.id);
    } catch (e) {
      this.haltError.textContent = `halt: ${errorText(e)}`;
    }
  }

  // The job that holds the controller (a Job: running or paused here), or null.
  setHold(job) {
    this.hold = job;
    this.root.dataset.heldBy = job ? job.id : "";
    this.holdLine.hidden = !job;
    const blocked = Boolean(job) && !this.lease.mine;
    this.motionSet.disabled = blocked;
    this.modulesSet.disabled = blocked;
    if (!job) return this.holdLine.replaceChildren();
    this.holdLine.replaceChildren(
      el("a", { href: `#/jobs/${encodeURIComponent(job.id)}` }, `${job.type} job`), ` is ${job.state} here: `,
      this.lease.mine
        ? "this page holds the lease it runs under, so its controls stay open."
        : "moves and settings belong to it until it ends (or to the holder of its lease); HALT works always.");
  }

  async pollHold() {
    try {
      const [running, paused] = await Promise.all(
        ["running", "paused"].map((state) => api.listJobs({ controller: this.id, state, limit: 1 })));
      this.setHold(running.jobs[0] || paused.jobs[0] || null);
    } catch {
      // the live banner says when the gateway is away; the last answer stands
    }
    if (!this.unmounted) this.holdTimer = setTimeout(() => this.pollHold(), HOLD_POLL_MS);
  }

  // A ControllerState (REST or a state event).
  setState(s) {
    this.state = s;
    showConnectionState(this.root, this.badge, s.state);
    this.haltedLine.hidden = !s.halted;
    this.haltedLine.textContent = haltedText(s.halted);
    this.root.dataset.halted = s.halted ? "yes" : "no";
    const err = s.last_error;
    const down = s.state !== "connected";
    this.lastError.hidden = !down || !err;
    this.lastError.textContent = err ? `${err.text || err.name} (${err.time})` : "";
    this.hint.hidden = !down || !err?.hint;
    this.hint.textContent = err?.hint ? `hint: ${err.hint}` : "";
    const id = s.identity;
    this.identity.textContent = id
      ? `build ${id.build} · firmware ${id.version} · modules: ${id.modules.length ? id.modules.join(", ") : "none"}`
      : "not identified yet";
    this.modules.setState(s);
    if (s.axes?.length) this.setAxes(s.axes);
    this.followReports(Boolean(s.report_port && s.report_port !== "none"));
    this.setupChart();
    if (s.axes?.length) {
      this.xy.setLimits(Object.fromEntries(s.axes.map((a) => [a.axis, a.soft_limits_um])));
      this.setPositions(s.axes, s.busy, s.updated);
    }
  }

  setAxes(axes) {
    const key = axes.map((a) => a.axis).join("");
    if (key === this.axesKey) return;
    this.axesKey = key;
    this.axisRows.clear();
    this.axesTable.replaceChildren();
    for (const a of axes) {
      const pos = el("td", { class: "pos live-value", "data-axis": a.axis });
      const busy = el("td", { class: "busy live-value" });
      this.axesTable.append(el("tr", {}, el("td", { class: "axis" }, a.axis), pos, el("td", { class: "unit" }, "µm"), busy));
      this.axisRows.set(a.axis, { pos, busy });
    }
    this.motion.setAxes(axes);
    this.xy.root.hidden = !(key.includes("X") && key.includes("Y"));
  }

  setPositions(axes, busy, time) {
    for (const a of axes) {
      const row = this.axisRows.get(a.axis);
      if (!row) continue;
      row.pos.textContent = formatUm(a.position_um);
      row.busy.textContent = a.busy ? "moving" : "";
    }
    this.root.dataset.busy = busy ? "yes" : "no";
    this.busy.textContent = busy ? "moving" : "idle";
    this.motion.setPositions(axes);
    const at = (axis) => axes.find((a) => a.axis === axis)?.position_um;
    this.xy.setPosition(at("X"), at("Y"));
    if (time) this.chart.push("position", seconds(time), this.letters().map((l) => at(l) ?? null));
  }

  letters() {
    return this.axesKey ? [...this.axesKey] : [];
  }

  // The chart's tracks: the positions, and the report frames where there is a report port.
  setupChart() {
    const key = `${this.axesKey}|${Boolean(this.reportStop)}`;
    if (!this.axesKey || key === this.chartKey) return;
    this.chartKey = key;
    const letters = this.letters();
    const tracks = [{ name: "position", holdLast: true, series: letters.map((l, i) => ({ label: l, colour: axisColour(l, i) })) }];
    if (this.reportStop) {
      tracks.push({ name: "reports", minIntervalS: REPORT_DRAW_INTERVAL_S,
                    series: letters.map((l, i) => ({ label: `${l} report`, colour: axisColour(l, i), points: true })) });
    }
    this.chart.setTracks(tracks);
    this.chartNote.textContent = `positions in µm (lines)${this.reportStop ? ", encoder report frames (dots)" : ""}; TTL events: red lines`;
  }

  followReports(on) {
    if (on && !this.reportStop) {
      this.stats = new ReportStats();
      this.reportLine.hidden = false;
      this.reportStop = store.follow(`controllers/${this.id}/reports`, (msg) => this.onReport(msg));
    } else if (!on && this.reportStop) {
      this.reportStop();
      this.reportStop = null;
      this.reportLine.hidden = true;
    }
  }

  onReport(msg) {
    const frame = this.stats.count(msg);
    if (!frame?.time) return;
    const byAxis = new Map(frame.axes.map((a) => [a.axis, a.position_um]));
    this.chart.push("reports", seconds(frame.time), this.letters().map((l) => byAxis.get(l) ?? null));
  }

  onTtl(msg) {
    if (msg.type !== "event") return;
    this.ttlEvents += 1;
    if (msg.data?.time) this.chart.mark(seconds(msg.data.time));
    this.renderStats();
  }

  renderStats() {
    if (this.stats) {
      this.stats.updateRate();
      this.reportLine.textContent = `encoder reports: ${this.stats.summary()}`;
      this.reportLine.dataset.frames = String(this.stats.frames);
      this.reportLine.dataset.gaps = String(this.stats.gaps);
    }
    this.chartNote.dataset.ttlEvents = String(this.ttlEvents);
  }

  mount() {
    const known = store.controllers.get(this.id);
    if (known?.state) this.setState(known.state);
    else this.load();
    if (known?.position) this.setPositions(known.position.axes, known.position.busy, known.position.time);
    const entry = store.leases.get(this.id);
    if (entry) this.lease.show(entry.lease, entry.error, Boolean(api.heldLeases()[this.id]));
    this.pollHold();
    this.stops.push(
      store.on("controller", ({ id, controller, what }) => {
        if (id !== this.id) return;
        if (what === "state") this.setState(controller.state);
        else if (what === "position") this.setPositions(controller.position.axes, controller.position.busy, controller.position.time);
      }),
      store.on("lease", ({ id, lease, error, mine }) => {
        if (id !== this.id) return;
        this.lease.show(lease, error, mine);
        this.setHold(this.hold);  // whether the controls open for this page's lease
      }),
      store.follow(`controllers/${this.id}/ttl`, (msg) => this.onTtl(msg)),
    );
  }

  // A controller the store has not heard of yet (the page opened on this address): REST tells.
  async load() {
    try {
      const s = await api.controller(this.id);
      store.setState(s);
    } catch (e) {
      this.identity.textContent = e.status === 404 ? `There is no controller ${this.id}.` : `Cannot load ${this.id}: ${errorText(e)}`;
      this.root.dataset.missing = e.status === 404 ? "yes" : "no";
    }
  }

  unmount() {
    this.unmounted = true;
    clearTimeout(this.holdTimer);
    for (const stop of this.stops) stop();
    this.reportStop?.();
    clearInterval(this.statsTimer);
    this.lease.destroy();
    this.share.destroy();
    this.chart.destroy();
  }
}

export function mount(container, { id }) {
  const view = new ControllerView(id);
  container.append(view.root);
  view.mount();
  return () => view.unmount();
}
