// What the job list and the job view show of a job's progress: its state badge, a progress bar, what
// it waits for, and elapsed and remaining times that tick between events. The remaining time counts
// down from progress.eta when the gateway sends one, else from remaining_s at the last event minus the
// time since; it stands still while the job waits for something with no known end (next, TTL...).

import { el, formatDuration } from "./dom.js";

export const JOB_STATES = ["queued", "running", "paused", "succeeded", "failed", "cancelled", "interrupted"];
export const TERMINAL_STATES = new Set(["succeeded", "failed", "cancelled"]);

// The actions each state allows (POST /api/v1/jobs/{id}/<action>); "next" only while running.
export const ACTIONS_BY_STATE = {
  queued: ["cancel"],
  running: ["pause", "next", "cancel"],
  paused: ["resume", "cancel"],
  interrupted: ["resume", "cancel"],
};

const WAITING_TEXT = {
  next: "waiting for Next",
  ttl: "waiting for a TTL input",
  timer: "dwelling",
  controller: "waiting for the controller",
  storage: "waiting for storage",
  halt: "halted: resume or submit to go on",
};
// Waits whose end nobody can predict: the countdown stops during them.
const OPEN_ENDED_WAITS = new Set(["next", "ttl", "controller", "storage", "halt"]);

export const waitingText = (w) => (w ? WAITING_TEXT[w] || `waiting for ${w}` : "");

// Gateway time minus this browser's time (from the WebSocket's event times), so that an absolute eta
// counts down right even when the two clocks disagree.
let clockOffsetMs = 0;
export function noteGatewayTime(iso) {
  const t = Date.parse(iso || "");
  if (Number.isFinite(t)) clockOffsetMs = t - Date.now();
}

export function stateBadge(state, reason) {
  const badge = el("span", { class: `job-state ${state}`, "data-state": state }, state);
  if (reason) badge.title = reason;
  return badge;
}

// A progress bar: {root, set(percent, state)}.
export function progressBar() {
  const fill = el("div", { class: "progress-fill" });
  const label = el("span", { class: "progress-label" });
  const root = el("div", { class: "progress", "aria-valuemin": "0", "aria-valuemax": "100" }, fill, label);
  root.setAttribute("role", "progressbar");
  return {
    root,
    set(percent, state) {
      const p = Math.max(0, Math.min(100, Number(percent) || 0));
      fill.style.width = `${p}%`;  // a style property set from script: allowed by the page's CSP
      label.textContent = `${p.toFixed(p < 10 && p > 0 ? 1 : 0)} %`;
      root.setAttribute("aria-valuenow", p.toFixed(1));
      root.dataset.percent = p.toFixed(1);
      root.dataset.state = state || "";
    },
  };
}

// The progress of one job as last reported, and its times now.
export class ProgressClock {
  constructor() {
    this.progress = null;
    this.state = "";
    this.at = 0;  // performance.now() when it was reported
  }

  // progress: a Job's progress (or a step event's fields); state: the job's state.
  set(progress, state) {
    this.progress = { ...progress };
    this.state = state;
    this.at = performance.now();
  }

  sinceS() {
    return (performance.now() - this.at) / 1000;
  }

  ticking() {
    return this.state === "running" && !OPEN_ENDED_WAITS.has(this.progress?.waiting_for);
  }

  elapsedS() {
    const e = this.progress?.elapsed_s;
    if (typeof e !== "number") return null;
    return this.state === "running" ? e + this.sinceS() : e;
  }

  // Seconds still ahead, or null when unknown.
  remainingS() {
    const p = this.progress;
    if (!p) return null;
    if (TERMINAL_STATES.has(this.state)) return 0;
    if (this.ticking() && p.eta) {
      const end = Date.parse(p.eta);
      if (Number.isFinite(end)) return Math.max(0, (end - (Date.now() + clockOffsetMs)) / 1000);
    }
    if (typeof p.remaining_s !== "number") return null;
    return Math.max(0, this.ticking() ? p.remaining_s - this.sinceS() : p.remaining_s);
  }

  // "12.3 s", "waiting for Next (3.2 s of motion left)", "–".
  remainingText() {
    if (TERMINAL_STATES.has(this.state)) return "–";
    const r = this.remainingS();
    const wait = waitingText(this.progress?.waiting_for);
    if (wait && !this.ticking()) return r === null ? wait : `${wait} (${formatDuration(r)} of motion left)`;
    return r === null ? "–" : formatDuration(r);
  }

  elapsedText() {
    return formatDuration(this.elapsedS() ?? NaN);
  }
}

// A step event's fields as a progress (the job record's progress is the same shape).
export function progressOfStep(step, previous = {}) {
  const p = { ...previous };
  for (const k of ["steps_done", "steps_total", "percent", "remaining_s", "elapsed_s", "eta", "waiting_for"]) {
    if (k in step) p[k] = step[k];
  }
  if (step.name) p.current_step = step.name;
  return p;
}

// "12:03:04" today, "2026-11-22 12:03" otherwise.
export function formatTime(iso) {
  const t = new Date(iso || "");
  if (Number.isNaN(t.getTime())) return "–";
  const now = new Date();
  const pad = (n) => String(n).padStart(2, "0");
  const hms = `${pad(t.getHours())}:${pad(t.getMinutes())}:${pad(t.getSeconds())}`;
  if (t.toDateString() === now.toDateString()) return hms;
  return `${t.getFullYear()}-${pad(t.getMonth() + 1)}-${pad(t.getDate())} ${hms.slice(0, 5)}`;
}
