// The position recordings (#/recordings): newest first, filtered by controller and state (GET
// /api/v1/recordings), "Older" pages back; each row opens #/recordings/<id>. Refreshed from REST every
// 2 s while one shown records (its frames grow), else every 10 s. Above the list, for operators, the
// form that starts a recording (recording_form.js).

import * as api from "./api.js";
import { el, errorText, fillControllerFilter } from "./dom.js";
import { formatTime } from "./job_status.js";
import { RecordingForm } from "./recording_form.js";
import { store } from "./store.js";

const PAGE_SIZE = 50;
const REFRESH_MS = 10000;
const REFRESH_RECORDING_MS = 2000;
export const RECORDING_STATES = ["recording", "stopped", "failed"];

export function recordingBadge(state, reason) {
  const badge = el("span", { class: `rec-state ${state}`, "data-state": state }, state);
  if (reason) badge.title = reason;
  return badge;
}

export const rateText = (hz) => (typeof hz === "number" ? `${hz.toFixed(1)} frames/s` : "–");

export function mount(container) {
  const list = new RecordingList();
  const form = new RecordingForm();
  container.append(el("section", { class: "recordings-page" }, list.head, form.root, list.root));
  list.load();
  return () => {
    list.stop();
    form.stop();
  };
}

class RecordingList {
  constructor() {
    this.shown = [];  // recordings, newest first
    this.until = null;  // "Older": the start (ms) of the oldest shown
    this.serial = 0;
    this.timer = null;
    this.build();
    this.stopControllers = store.on("controllers", () => this.fillControllers());
  }

  stop() {
    this.stopControllers();
    clearTimeout(this.timer);
    this.serial++;  // an answer still on its way is dropped
  }

  build() {
    this.controllerFilter = el("select", { id: "rec-filter-controller", "aria-label": "controller" });
    this.stateFilter = el("select", { id: "rec-filter-state", "aria-label": "state" },
                          el("option", { value: "" }, "every state"),
                          ...RECORDING_STATES.map((s) => el("option", { value: s }, s)));
    this.fillControllers();
    for (const f of [this.controllerFilter, this.stateFilter]) f.addEventListener("change", () => this.load());
    this.status = el("span", { class: "meta list-status", id: "rec-list-status" });
    this.error = el("div", { class: "error", role: "alert" });
    this.tbody = el("tbody", { id: "rec-rows" });
    this.empty = el("p", { class: "meta empty", hidden: true }, "No recordings match.");
    this.older = el("button", { type: "button", id: "rec-older", hidden: true }, "Older");
    this.older.addEventListener("click", () => this.loadOlder());
    this.head = el("div", { class: "page-head" },
                   el("h2", {}, "Recordings"),
                   el("label", {}, "Controller ", this.controllerFilter),
                   el("label", {}, "State ", this.stateFilter),
                   this.status);
    const columns = ["Name", "Controller", "State", "Frames", "Losses", "Started", "Rate"];
    this.root = el("div", { class: "recordings-list" }, this.error,
                   el("table", { class: "recordings" },
                      el("thead", {}, el("tr", {}, ...columns.map((h) => el("th", {}, h)))), this.tbody),
                   this.empty, this.older);
  }

  fillControllers() {
    fillControllerFilter(this.controllerFilter, store.controllers.keys());
  }

  query(extra) {
    return { controller: this.controllerFilter.value, state: this.stateFilter.value, ...extra };
  }

  // The newest (as many as shown, at least a page) for the filters chosen; a later answer wins.
  async load() {
    const serial = ++this.serial;
    clearTimeout(this.timer);
    try {
      const limit = Math.min(500, Math.max(PAGE_SIZE, this.shown.length));
      const page = await api.listRecordings(this.query({ limit }));
      if (serial !== this.serial) return;
      this.shown = page.recordings;
      this.until = page.recordings.length === limit ? this.oldestStart() : null;
      this.error.textContent = "";
      this.render();
    } catch (e) {
      if (serial !== this.serial) return;
      this.error.textContent = `Could not load the recordings: ${errorText(e)}`;
    }
    const recording = this.shown.some((r) => r.state === "recording");
    this.timer = setTimeout(() => this.load(), recording ? REFRESH_RECORDING_MS : REFRESH_MS);
  }

  // Recordings that started before the oldest shown: `until` is exclusive, so the same millisecond is
  // asked again and the rows already shown are dropped.
  async loadOlder() {
    const serial = this.serial;
    this.older.disabled = true;
    try {
      const page = await api.listRecordings(this.query({ limit: PAGE_SIZE, until: this.until + 1 }));
      if (serial !== this.serial) return;
      const have = new Set(this.shown.map((r) => r.id));
      const fresh = page.recordings.filter((r) => !have.has(r.id));
      this.shown.push(...fresh);
      this.until = page.recordings.length === PAGE_SIZE && fresh.length ? this.oldestStart() : null;
      this.render();
    } catch (e) {
      this.error.textContent = `Could not load older recordings: ${errorText(e)}`;
    } finally {
      this.older.disabled = false;
    }
  }

  oldestStart() {
    const last = this.shown[this.shown.length - 1];
    return last ? Date.parse(last.started) : null;
  }

  render() {
    this.tbody.replaceChildren(...this.shown.map((r) => row(r)));
    this.empty.hidden = this.shown.length > 0;
    this.older.hidden = this.until === null;
    const n = this.shown.length;
    this.status.textContent = `${n} recording${n === 1 ? "" : "s"}`;
  }
}

function row(r) {
  const reason = r.reason && r.reason !== r.state ? el("div", { class: "reason" }, r.reason) : "";
  return el("tr", { "data-recording": r.id, "data-state": r.state },
            el("td", {}, el("a", { href: `#/recordings/${encodeURIComponent(r.id)}`, title: r.id }, r.name)),
            el("td", {}, r.controller),
            el("td", {}, recordingBadge(r.state, r.reason), reason),
            el("td", { class: "num rec-frames" }, String(r.frames)),
            el("td", { class: `num rec-losses${r.losses ? " lossy" : ""}` }, String(r.losses)),
            el("td", { class: "num", title: r.started }, formatTime(r.started)),
            el("td", { class: "num" }, rateText(r.rate_hz)));
}
