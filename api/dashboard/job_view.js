// One job (#/jobs/<id>): its state with the reason and what it waits for, a progress bar, the current
// step, elapsed and remaining times ticking between events, the actions its state allows (pause,
// resume, cancel, next), for array jobs the plate map (a click on a well shows its step event), and
// the job's events. Loaded from REST (GET /api/v1/jobs/{id} and /events), then live from the topic
// jobs/<id>; a gap reloads the events from REST, and a retired topic says that live updates ended.

import * as api from "./api.js";
import { el, errorText, formatDuration, formatUm } from "./dom.js";
import { ACTIONS_BY_STATE, ProgressClock, formatTime, noteGatewayTime, progressBar,
         progressOfStep, stateBadge, waitingText } from "./job_status.js";
import { PlateMap } from "./plate_map.js";
import { store } from "./store.js";

const TICK_MS = 200;
const EVENTS_SHOWN = 200;

export function mount(container, { id }) {
  const view = new JobView(id);
  container.append(view.root);
  view.start();
  return () => view.stop();
}

// The position of a step event as text: "X 1234.5 · Y -67.8 µm".
const positionText = (p) => (p && typeof p === "object"
  ? `${Object.entries(p).map(([axis, um]) => `${axis} ${formatUm(um)}`).join(" · ")} µm` : "–");

class JobView {
  constructor(id) {
    this.id = id;
    this.job = null;
    this.clock = new ProgressClock();
    this.steps = new Map();  // step name -> {event, time}
    this.eventKeys = new Set();  // events already listed (REST and live overlap)
    this.buffered = [];  // live messages that came before the REST load
    this.loaded = false;
    this.plate = null;
    this.build();
  }

  build() {
    this.title = el("h2", {}, "Job ", el("span", { class: "mono" }, this.id));
    this.badge = el("span", { class: "job-state" });
    this.meta = el("div", { class: "meta job-meta" });
    this.progress = progressBar();
    this.stepText = el("dd", { class: "job-step" }, "–");
    this.elapsed = el("dd", { class: "job-elapsed live-value" }, "–");
    this.remaining = el("dd", { class: "job-remaining live-value" }, "–");
    this.estimate = el("dd", {}, "–");
    this.waiting = el("p", { class: "job-waiting", hidden: true });
    this.reason = el("p", { class: "job-reason", hidden: true });
    this.actions = el("div", { class: "job-actions", "data-needs": "operator" });
    this.actionButtons = {};
    for (const [action, label] of [["pause", "Pause"], ["resume", "Resume"], ["next", "Next"], ["cancel", "Cancel"]]) {
      const b = el("button", { type: "button", "data-action": action, hidden: true,
                               class: action === "cancel" ? "danger" : action === "next" ? "primary" : "" }, label);
      b.addEventListener("click", () => this.act(action));
      this.actionButtons[action] = b;
      this.actions.append(b);
    }
    this.actionError = el("div", { class: "error action-error", role: "alert" });
    this.notice = el("div", { class: "notice", role: "status", hidden: true });
    this.loadError = el("div", { class: "error", role: "alert" });
    this.plateCard = el("section", { class: "card plate-card", hidden: true });
    this.eventsBody = el("tbody");
    this.root = el("section", { class: "job-page" },
                   el("p", { class: "crumbs" }, el("a", { href: "#/jobs" }, "← Jobs")),
                   this.loadError,
                   el("div", { class: "page-head" }, this.title, this.badge),
                   this.meta,
                   el("section", { class: "card job-progress" },
                      this.progress.root,
                      el("dl", { class: "job-figures" },
                         el("div", {}, el("dt", {}, "Step"), this.stepText),
                         el("div", {}, el("dt", {}, "Elapsed"), this.elapsed),
                         el("div", {}, el("dt", {}, "Remaining"), this.remaining),
                         el("div", {}, el("dt", {}, "Estimated"), this.estimate)),
                      this.waiting, this.reason, this.actions, this.actionError),
                   this.notice,
                   el("div", { class: "job-body" },
                      this.plateCard,
                      el("section", { class: "card events-card" }, el("h3", {}, "Events"),
                         el("table", { class: "events" },
                            el("thead", {}, el("tr", {}, ...["#", "Time", "Event", "Detail"].map((h) => el("th", {}, h)))),
                            this.eventsBody))));
  }

  async start() {
    // Follow first, so that nothing between the REST answer and the subscription is lost.
    this.unfollow = store.follow(`jobs/${this.id}`, (msg) => (this.loaded ? this.onMessage(msg) : this.buffered.push(msg)));
    this.tickTimer = setInterval(() => this.renderTimes(), TICK_MS);
    try {
      const [job, events] = await Promise.all([api.job(this.id), api.jobEvents(this.id)]);
      this.setJob(job);
      this.applyEvents(events.events);
    } catch (e) {
      this.loadError.textContent = e.status === 404 ? `There is no job ${this.id}.` : `Could not load the job: ${errorText(e)}`;
    }
    this.loaded = true;
    for (const msg of this.buffered.splice(0)) this.onMessage(msg);
  }

  stop() {
    this.unfollow?.();
    clearInterval(this.tickTimer);
  }

  // A job record (REST, an action's answer or a state event); an older one than shown is ignored. A
  // state event's record comes without its spec (it never changes): the one shown keeps it.
  setJob(job) {
    if (this.job && job.updated < this.job.updated) return;
    if (!job.spec && this.job) job = { ...job, spec: this.job.spec };
    const first = !this.job;
    this.job = job;
    if (first) this.buildPlate(job);
    this.clock.set(job.progress, job.state);
    this.render();
  }

  buildPlate(job) {
    if (job.type !== "array") return;
    this.plate = new PlateMap(job.spec, { onSelect: (name) => this.showWell(name) });
    this.wellDetail = el("div", { class: "well-detail meta" }, "Click a well to see its step.");
    this.plateCounts = el("span", { class: "meta" });
    this.plateCard.hidden = false;
    this.plateCard.append(el("h3", {}, "Plate ", this.plateCounts),
                          this.plate.root || el("p", { class: "meta" }, "This grid is too large to draw."),
                          el("div", { class: "plate-legend meta" },
                             ...["pending", "current", "done", "outside"].map((k) => el("span", { class: `legend ${k}` }, k === "outside" ? "not in this job" : k))),
                          this.wellDetail);
  }

  render() {
    const job = this.job;
    const p = this.clock.progress || {};
    this.badge.replaceWith(this.badge = stateBadge(job.state, job.reason));
    this.badge.id = "job-state";
    const path = job.path ? `${job.path} path` : "";
    this.meta.replaceChildren(`${job.type} on `, el("a", { href: `#/controller/${encodeURIComponent(job.controller)}` }, job.controller),
                              ` · ${path} · by ${job.submitted_by || "?"} · created ${formatTime(job.created)}`,
                              job.started ? ` · started ${formatTime(job.started)}` : "",
                              job.finished ? ` · finished ${formatTime(job.finished)}` : "");
    this.progress.set(p.percent, job.state);
    const counts = p.steps_total ? ` (${p.steps_done} of ${p.steps_total} done)` : "";
    this.stepText.textContent = `${p.current_step || "–"}${counts}`;
    this.estimate.textContent = formatDuration(job.estimated_s);
    const wait = job.state === "running" ? waitingText(p.waiting_for) : "";
    this.waiting.hidden = !wait;
    this.waiting.textContent = wait ? `${wait[0].toUpperCase()}${wait.slice(1)}.` : "";
    this.waiting.dataset.waitingFor = p.waiting_for || "";
    const reason = job.reason && job.reason !== job.state ? job.reason : "";
    this.reason.hidden = !reason;
    this.reason.textContent = reason ? `Reason: ${reason}` : "";
    this.renderActions();
    this.renderTimes();
    this.renderPlate();
  }

  // Only what the state allows; "next" while running when the job waits for it (or, from a gateway
  // that does not say what a job waits for, when its spec advances on next calls).
  renderActions() {
    const allowed = new Set(ACTIONS_BY_STATE[this.job.state] || []);
    const p = this.clock.progress || {};
    const spec = this.job.spec || {};
    const nextByWait = "waiting_for" in p ? p.waiting_for === "next"
      : spec.advance === "next" || spec.trigger === "next" || (spec.points || []).includes("current");
    if (!nextByWait) allowed.delete("next");
    for (const [action, b] of Object.entries(this.actionButtons)) b.hidden = !allowed.has(action);
    this.actions.hidden = allowed.size === 0;
  }

  renderTimes() {
    if (!this.job) return;
    this.elapsed.textContent = this.clock.elapsedText();
    this.remaining.textContent = this.clock.remainingText();
  }

  renderPlate() {
    if (!this.plate?.root) return;
    const p = this.clock.progress || {};
    const running = this.job.state === "running";
    // Step events come when a well is done: the one in progress is the next in the visiting order.
    this.plate.setCurrent(running ? this.plate.nextWell() : null);
    const { done, total } = this.plate.counts();
    this.plateCounts.textContent = `${done} of ${total} wells done`;
  }

  async act(action) {
    this.actionError.textContent = "";
    const b = this.actionButtons[action];
    b.disabled = true;
    try {
      this.setJob(await api.jobAction(this.id, action, this.job?.controller));
    } catch (e) {
      this.actionError.textContent = `${action}: ${errorText(e)}`;
      this.reloadJob();  // the state may have moved on: show what it is now
    } finally {
      b.disabled = false;
    }
  }

  async reloadJob() {
    try {
      this.setJob(await api.job(this.id));
    } catch (e) {
      this.loadError.textContent = `Could not reload the job: ${errorText(e)}`;
    }
  }

  async reloadEvents() {
    try {
      this.applyEvents((await api.jobEvents(this.id)).events);
      await this.reloadJob();
    } catch (e) {
      this.loadError.textContent = `Could not reload the events: ${errorText(e)}`;
    }
  }

  // Stored events have no time of their own; a state event's record says when it changed.
  applyEvents(events) {
    events.forEach((e, i) => this.addEvent(e, e.type === "state" ? e.job?.updated : null, i + 1));
  }

  onMessage(msg) {
    if (msg.type === "gap") {
      this.showNotice("Some live events of this job were missed (a gap in the feed); reloaded them from the gateway.");
      this.reloadEvents();
    } else if (msg.type === "retired") {
      this.showNotice("This job's live topic has retired (the job ended a while ago): what is shown comes from its stored events.");
      this.reloadEvents();
    } else if (msg.type === "event" && msg.data) {
      noteGatewayTime(msg.time);
      this.addEvent(msg.data, msg.time, msg.seq);
    }
  }

  showNotice(text) {
    this.notice.hidden = false;
    this.notice.textContent = text;
  }

  // One event (stored or live): listed once, and applied to the progress and the plate map.
  addEvent(e, time, seq) {
    const key = eventKey(e);
    if (this.eventKeys.has(key)) {
      if (time && e.type === "step" && this.steps.has(e.name)) this.steps.get(e.name).time ??= time;
      return;
    }
    this.eventKeys.add(key);
    if (e.type === "state" && e.job) this.setJob(e.job);
    if (e.type === "step") this.applyStep(e, time);
    this.listEvent(e, time, seq);
  }

  applyStep(e, time) {
    this.steps.set(e.well || e.name, { event: e, time });
    if (this.plate && e.well) this.plate.setDone(e.well);
    if (!this.job) return;
    const done = this.clock.progress?.steps_done ?? 0;
    if (typeof e.steps_done === "number" && e.steps_done < done) {
      this.renderPlate();
      return;  // an old step (REST after live): the progress shown is newer
    }
    this.clock.set(progressOfStep(e, this.clock.progress), this.job.state);
    this.render();
    if (this.plate?.selected === (e.well || e.name)) this.showWell(this.plate.selected);
  }

  listEvent(e, time, seq) {
    const detail = e.type === "step"
      ? `${e.name}: ${e.steps_done}/${e.steps_total}${e.position ? ` at ${positionText(e.position)}` : ""}`
      : e.type === "state" ? `${e.state}${e.reason && e.reason !== e.state ? `: ${e.reason}` : ""}`
      : e.type === "recording" ? recordingDetail(e) : JSON.stringify(e).slice(0, 160);
    const tr = el("tr", { "data-event": e.type }, el("td", { class: "num" }, seq ?? ""),
                  el("td", { class: "num" }, time ? formatTime(time) : elapsedLabel(e)),
                  el("td", {}, e.type), el("td", {}, detail));
    this.eventsBody.prepend(tr);
    while (this.eventsBody.children.length > EVENTS_SHOWN) this.eventsBody.lastChild.remove();
  }

  showWell(name) {
    const s = this.steps.get(name);
    if (!s) {
      const current = this.plate.current === name;
      this.wellDetail.replaceChildren(el("strong", {}, name), current ? " — the stage is on its way there." : " — not visited yet.");
      this.wellDetail.dataset.well = name;
      return;
    }
    const e = s.event;
    const when = s.time ? `at ${formatTime(s.time)}, ` : "";
    this.wellDetail.dataset.well = name;
    this.wellDetail.replaceChildren(
      el("strong", {}, name), ` — step ${e.index + 1} of ${e.steps_total}, done ${when}${formatDuration(e.elapsed_s)} into the job`,
      el("div", {}, "target ", el("span", { class: "mono" }, positionText(e.target))),
      el("div", {}, "measured ", el("span", { class: "mono well-measured" }, positionText(e.position))),
      offsetLine(e.target, e.position));
  }
}

// Events carry no id: a step is known by its index, a state event by its state and time.
// A recording run's recording (spec.record): a link to it, and how it ended.
function recordingDetail(e) {
  const link = el("a", { href: `#/recordings/${encodeURIComponent(e.recording)}`, "data-recording": e.recording }, e.recording);
  const counts = typeof e.frames === "number" ? `: ${e.frames} frames, ${e.losses ?? 0} losses` : "";
  const reason = e.state === "failed" || e.state === "unknown" ? ` (${e.reason})` : "";
  return el("span", {}, link, ` ${e.state}${counts}${reason}`);
}

function eventKey(e) {
  if (e.type === "step") return `step:${e.index}:${e.steps_done}`;
  if (e.type === "state") return `state:${e.state}:${e.job?.updated ?? ""}`;
  return JSON.stringify(e);
}

function elapsedLabel(e) {
  return typeof e.elapsed_s === "number" ? `+${formatDuration(e.elapsed_s)}` : "";
}

// How far the measured position is from the target, in um.
function offsetLine(target, measured) {
  if (!target || !measured) return "";
  const d = Object.keys(target).filter((a) => typeof measured[a] === "number")
    .map((a) => (measured[a] - target[a]) ** 2);
  if (!d.length) return "";
  return el("div", {}, `off by ${Math.sqrt(d.reduce((s, v) => s + v, 0)).toFixed(1)} µm`);
}
