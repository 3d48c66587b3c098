// The job list (#/jobs): newest first, filtered by controller and state (GET /api/v1/jobs), a page at
// a time ("More" follows the `next` cursor). Live from the WebSocket topic jobs/+ (every job's state
// and step events), times ticking between events, and a slow refresh from REST that catches whatever
// the feed could not say (a gap, a job deleted from the store).

import * as api from "./api.js";
import { el, errorText, fillControllerFilter } from "./dom.js";
import { JOB_STATES, ProgressClock, formatTime, noteGatewayTime, progressBar, progressOfStep,
         stateBadge } from "./job_status.js";
import { store } from "./store.js";

const PAGE_SIZE = 25;
const REFRESH_MS = 10000;
const TICK_MS = 500;

export function mount(container) {
  const list = new JobList();
  container.append(list.root);
  list.load();
  return () => list.stop();
}

class JobList {
  constructor() {
    this.rows = new Map();  // job id -> {job, tr, clock, cells}
    this.order = [];  // job ids as shown, newest first
    this.next = null;
    this.loadSerial = 0;
    this.build();
    this.stops = [
      store.follow("jobs/+", (msg) => this.onMessage(msg)),
      store.on("controllers", () => this.fillControllers()),
    ];
    this.tickTimer = setInterval(() => this.tick(), TICK_MS);
    this.refreshTimer = setInterval(() => this.refresh(), REFRESH_MS);
  }

  stop() {
    for (const s of this.stops) s();
    clearInterval(this.tickTimer);
    clearInterval(this.refreshTimer);
  }

  build() {
    this.controllerFilter = el("select", { id: "job-filter-controller", "aria-label": "controller" });
    this.stateFilter = el("select", { id: "job-filter-state", "aria-label": "state" },
                          el("option", { value: "" }, "every state"),
                          ...JOB_STATES.map((s) => el("option", { value: s }, s)));
    this.fillControllers();
    for (const f of [this.controllerFilter, this.stateFilter]) f.addEventListener("change", () => this.load());
    this.status = el("span", { class: "meta list-status" });
    this.error = el("div", { class: "error", role: "alert" });
    this.tbody = el("tbody");
    this.empty = el("p", { class: "meta empty", hidden: true }, "No jobs match.");
    this.more = el("button", { type: "button", class: "more", hidden: true }, "More");
    this.more.addEventListener("click", () => this.loadMore());
    const head = ["Job", "Controller", "Type", "State", "Progress", "Step", "Elapsed", "Remaining", "Created"];
    this.root = el("section", { class: "jobs-page" },
                   el("div", { class: "page-head" },
                      el("h2", {}, "Jobs"),
                      el("label", {}, "Controller ", this.controllerFilter),
                      el("label", {}, "State ", this.stateFilter),
                      this.status,
                      el("a", { class: "button primary", href: "#/jobs/new", "data-needs": "operator" }, "New job…")),
                   this.error,
                   el("table", { class: "jobs" }, el("thead", {}, el("tr", {}, ...head.map((h) => el("th", {}, h)))),
                      this.tbody),
                   this.empty, this.more);
  }

  fillControllers() {
    fillControllerFilter(this.controllerFilter, store.controllers.keys());
  }

  query(extra = {}) {
    return { controller: this.controllerFilter.value, state: this.stateFilter.value, ...extra };
  }

  // The first page for the filters chosen (a later answer wins over an earlier one).
  async load() {
    const serial = ++this.loadSerial;
    this.status.textContent = "loading…";
    try {
      const page = await api.listJobs(this.query({ limit: PAGE_SIZE }));
      if (serial !== this.loadSerial) return;
      this.replaceAll(page);
    } catch (e) {
      if (serial === this.loadSerial) this.showError(e);
    }
  }

  async loadMore() {
    if (!this.next) return;
    const serial = this.loadSerial;
    this.more.disabled = true;
    try {
      const page = await api.listJobs(this.query({ limit: PAGE_SIZE, before: this.next }));
      if (serial !== this.loadSerial) return;
      for (const job of page.jobs) this.upsert(job, "append");
      this.next = page.next;
      this.afterChange();
    } catch (e) {
      this.showError(e);
    } finally {
      this.more.disabled = false;
    }
  }

  // Every row shown so far again (the feed may have missed an event, a job may be gone).
  async refresh() {
    const serial = this.loadSerial;
    try {
      const limit = Math.min(500, Math.max(PAGE_SIZE, this.order.length));
      const page = await api.listJobs(this.query({ limit }));
      if (serial === this.loadSerial) this.replaceAll(page);
    } catch (e) {
      this.showError(e);
    }
  }

  replaceAll(page) {
    const keep = new Set(page.jobs.map((j) => j.id));
    for (const id of this.order) if (!keep.has(id)) this.rows.get(id)?.tr.remove();
    for (const id of [...this.rows.keys()]) if (!keep.has(id)) this.rows.delete(id);
    this.order = [];
    for (const job of page.jobs) this.upsert(job, "append");
    this.next = page.next;
    this.error.textContent = "";
    this.afterChange();
  }

  afterChange() {
    this.tbody.replaceChildren(...this.order.map((id) => this.rows.get(id).tr));
    this.empty.hidden = this.order.length > 0;
    this.more.hidden = !this.next;
    this.status.textContent = `${this.order.length} job${this.order.length === 1 ? "" : "s"}${this.next ? " (more below)" : ""}`;
  }

  showError(e) {
    this.status.textContent = "";
    this.error.textContent = `Could not load the jobs: ${errorText(e)}`;
  }

  matches(job) {
    const q = this.query();
    return (!q.controller || job.controller === q.controller) && (!q.state || job.state === q.state);
  }

  // A job record (REST or a state event): its row updated, or a new row (where: "append" or "top").
  upsert(job, where) {
    let row = this.rows.get(job.id);
    if (!row) {
      row = this.newRow(job.id);
      this.rows.set(job.id, row);
      if (where === "top") this.order.unshift(job.id);
      else this.order.push(job.id);
    } else if (where === "append" && !this.order.includes(job.id)) {
      this.order.push(job.id);
    }
    row.job = job;
    row.clock.set(job.progress, job.state);
    this.render(row);
  }

  newRow(id) {
    const cells = {
      id: el("td", { class: "job-id" }, el("a", { href: `#/jobs/${encodeURIComponent(id)}` }, id)),
      controller: el("td"),
      type: el("td"),
      state: el("td", { class: "job-state-cell" }),
      progress: progressBar(),
      step: el("td", { class: "num" }),
      elapsed: el("td", { class: "num live-value" }),
      remaining: el("td", { class: "num live-value" }),
      created: el("td", { class: "num" }),
    };
    const tr = el("tr", { "data-job": id }, cells.id, cells.controller, cells.type, cells.state,
                  el("td", { class: "progress-cell" }, cells.progress.root), cells.step, cells.elapsed,
                  cells.remaining, cells.created);
    return { job: null, tr, cells, clock: new ProgressClock() };
  }

  render(row) {
    const { job, cells } = row;
    const p = row.clock.progress || {};
    row.tr.dataset.state = job.state;
    row.tr.dataset.controller = job.controller;
    cells.controller.textContent = job.controller;
    cells.type.textContent = job.type;
    const reason = job.reason && job.reason !== job.state ? job.reason : "";
    cells.state.replaceChildren(stateBadge(job.state, job.reason), reason ? el("div", { class: "reason" }, reason) : "");
    cells.progress.set(p.percent, job.state);
    const counts = p.steps_total ? ` (${p.steps_done}/${p.steps_total})` : "";
    cells.step.textContent = `${p.current_step || "–"}${counts}`;
    cells.created.textContent = formatTime(job.created);
    cells.created.title = job.created;
    this.renderTimes(row);
  }

  renderTimes(row) {
    row.cells.elapsed.textContent = row.clock.elapsedText();
    row.cells.remaining.textContent = row.clock.remainingText();
  }

  tick() {
    for (const row of this.rows.values()) if (row.clock.state === "running") this.renderTimes(row);
  }

  onMessage(msg) {
    const id = (msg.topic || "").split("/")[1];
    if (msg.type === "gap") return this.refresh();
    if (msg.type !== "event" || !msg.data) return;
    noteGatewayTime(msg.time);
    const e = msg.data;
    if (e.type === "state" && e.job) {
      if (this.rows.has(id) || (this.matches(e.job) && this.isNewest(id))) {
        this.upsert(e.job, "top");
        this.afterChange();
      }
    } else if (e.type === "step" && this.rows.has(id)) {
      const row = this.rows.get(id);
      row.clock.set(progressOfStep(e, row.clock.progress), row.job.state);
      row.job = { ...row.job, progress: row.clock.progress };
      this.render(row);
    }
  }

  // Ids sort by creation time: a job newer than the first row belongs at the top.
  isNewest(id) {
    return !this.order.length || id > this.order[0];
  }
}
