// The G-code view (#/gcode): upload or paste a program, see the gateway's preview and the plan
// summary (bounds, segments, estimated time, warnings, an error with its line), check it on a
// controller (a dry run: the estimate) and run it as a `gcode` job while the traced position draws
// over the preview, TTL-on stretches in their own colour, with the job's progress (line N of M).
// Public API only: /api/v1/gcode/*, /api/v1/jobs and the WebSocket topics jobs/<id> and
// controllers/<id>/position (through the store).

import * as api from "./api.js";
import { el, errorText, formatDuration } from "./dom.js";
import { store } from "./store.js";
import { XYPlot } from "./xy_plot.js";

// The preview is asked for about as wide as it is shown, so that its 1 px lines stay visible.
const PREVIEW_WIDTH_PX = 400;
// Above this many lines the plan is asked for without its move list (moves=false): the preview still
// comes from the gateway, but the trace is drawn in one colour (the TTL stretches come from the moves).
const MAX_LINES_WITH_MOVES = 20000;
const TRACE_ENDS = new Set(["succeeded", "failed", "cancelled", "interrupted"]);
const MOTION = new Set(["rapid", "linear", "arc"]);

const enc = encodeURIComponent;
const mm = (v) => (typeof v === "number" ? `${v.toFixed(3)} mm` : "–");
// replaceChildren() without the null children (it would show them as the text "null").
const fill = (node, ...children) => node.replaceChildren(...children.filter((c) => c !== null && c !== undefined && c !== false));
const lineCount = (text) => text.split("\n").length - (text.endsWith("\n") ? 1 : 0);

// Where the gateway's preview.svg lies on the stage, in um: it scales the plan's XY bounds to
// width_px minus a margin of width_px/80 (2..20 px) on each side (gateway/gcode/gcode_preview_svg.cpp),
// so placing the image over these bounds puts the traced position exactly on its lines.
function previewExtent(bounds, widthPx) {
  const [x0, y0] = bounds.min;
  const [x1, y1] = bounds.max;
  const extent = Math.max(x1 - x0, y1 - y0) || 1;
  const marginPx = Math.min(Math.max(widthPx / 80, 2), 20);
  const marginMm = (marginPx * extent) / (widthPx - 2 * marginPx);
  return { min: { X: (x0 - marginMm) * 1000, Y: (y0 - marginMm) * 1000 },
           max: { X: (x1 + marginMm) * 1000, Y: (y1 + marginMm) * 1000 } };
}

// The program lines that move, in order, each with the TTL output's state while it runs (M03/M05
// switch before the motion of their block).
function motionLines(moves) {
  const out = [];
  let ttl = false;
  for (const m of moves) {
    if (m.kind === "ttl") ttl = m.ttl === "on";
    else if (MOTION.has(m.kind) && out[out.length - 1]?.line !== m.line) out.push({ line: m.line, ttl });
  }
  return out;
}

// The TTL state of the first moving line after `doneLine` (the one running once it is done).
function ttlAfter(lines, doneLine) {
  let lo = 0;
  let hi = lines.length;
  while (lo < hi) {
    const mid = (lo + hi) >> 1;
    if (lines[mid].line <= doneLine) lo = mid + 1;
    else hi = mid;
  }
  return lo < lines.length ? lines[lo].ttl : false;
}

// "line 12" or "lines 41-48" (a step's name) -> 12 or 48.
function lastLineOf(stepName) {
  const m = /(\d+)\s*$/.exec(stepName || "");
  return m ? Number(m[1]) : 0;
}

function axisUm(position, axis) {
  return position?.axes?.find((a) => a.axis === axis)?.position_um;
}

function fileSize(bytes) {
  if (bytes < 1024) return `${bytes} B`;
  if (bytes < 1024 * 1024) return `${(bytes / 1024).toFixed(1)} kB`;
  return `${(bytes / 1024 / 1024).toFixed(1)} MB`;
}

class GcodeView {
  constructor(container) {
    this.source = null;  // {kind: "file", id, name, lines} | {kind: "text", text, name, lines}
    this.plan = null;
    this.ttlLines = null;  // motionLines() of the plan, when it came with its moves
    this.planSeq = 0;  // answers for an older selection are dropped
    this.checked = null;  // the {controller, source} a dry run accepted: Run needs one
    this.trace = null;  // the job being traced
    this.traceNames = [];
    this.stops = [];
    this.build(container);
    this.stops.push(store.on("controllers", () => this.fillControllers()),
                    store.on("controller", (e) => this.onController(e)));
    this.fillControllers();
    this.refreshFiles();
    this.attachToRunningJob();
  }

  // ---------------------------------------------------------------------------------------------
  // Layout

  build(container) {
    this.fileInput = el("input", { type: "file", id: "gcode-file", accept: ".ngc,.nc,.gcode,.gc,.tap,.txt,text/plain" });
    this.text = el("textarea", { id: "gcode-text", rows: 9, spellcheck: false, "aria-label": "G-code program",
                                 placeholder: "G21 G90\nG00 X1 Y1\nM03\nG01 X5 F120\nG02 X7 Y-1 I0 J-2\nM05" });
    this.nameInput = el("input", { id: "gcode-name", type: "text", placeholder: "name (for an upload)", maxLength: 255 });
    this.sourceError = el("div", { id: "gcode-source-error", class: "error", role: "alert" });
    this.filesBody = el("tbody");
    this.filesNote = el("p", { class: "meta" }, "Loading…");
    const program = el("section", { class: "card gcode-program" },
      el("h2", {}, "Program"),
      el("label", { class: "file-pick", "data-needs": "operator" }, "Upload a file ", this.fileInput),
      el("label", { for: "gcode-text", class: "meta" }, "or paste a program:"),
      this.text,
      el("div", { class: "gcode-row" }, this.nameInput,
         el("button", { type: "button", id: "gcode-check", onclick: () => this.checkText() }, "Preview"),
         el("button", { type: "button", id: "gcode-upload", "data-needs": "operator", onclick: () => this.uploadText() }, "Upload")),
      this.sourceError);
    const files = el("section", { class: "card gcode-files" },
      el("div", { class: "card-head" }, el("h2", {}, "Uploaded programs"),
         el("button", { type: "button", class: "small", onclick: () => this.refreshFiles() }, "Refresh")),
      el("table", { class: "files", id: "gcode-files" }, this.filesBody),
      this.filesNote);

    this.plot = new XYPlot({ title: "G-code", width: 640, height: 640 });
    this.title = el("h2", { id: "gcode-title" }, "No program chosen");
    this.previewNote = el("p", { class: "meta", id: "gcode-preview-note" }, "Upload, pick or paste a program to see its path.");
    const legend = el("div", { class: "gcode-legend" },
      ...[["feed", "feed"], ["rapid", "rapid"], ["ttl", "TTL on (planned)"], ["traced", "traced"],
          ["traced-ttl", "traced, TTL on"]].map(([k, text]) => el("span", {}, el("i", { class: `swatch ${k}` }), text)));
    const map = el("section", { class: "card gcode-map" }, this.title, this.plot.root, legend, this.previewNote);

    this.summary = el("dl", { class: "plan-summary", id: "gcode-summary" });
    this.warnings = el("ul", { class: "warnings", id: "gcode-warnings" });
    this.planError = el("div", { class: "plan-error", id: "gcode-error", role: "alert", hidden: true });
    const plan = el("section", { class: "card gcode-plan" }, el("h2", {}, "Plan"), this.summary, this.planError, this.warnings);

    this.controllerSelect = el("select", { id: "gcode-controller", "aria-label": "controller",
                                           onchange: () => this.resetCheck() });
    this.dryRunButton = el("button", { type: "button", id: "gcode-dry-run", disabled: true, onclick: () => this.dryRun() }, "Dry run");
    this.runButton = el("button", { type: "button", id: "gcode-run", class: "primary", disabled: true, onclick: () => this.run() }, "Run");
    this.estimate = el("div", { id: "gcode-estimate", class: "estimate" });
    this.runError = el("div", { id: "gcode-run-error", class: "error", role: "alert" });
    this.progress = el("div", { id: "gcode-progress", class: "gcode-progress", hidden: true });
    const run = el("section", { class: "card gcode-run", "data-needs": "operator" },
      el("h2", {}, "Run"),
      el("div", { class: "gcode-row" }, el("label", { for: "gcode-controller" }, "on "), this.controllerSelect,
         this.dryRunButton, this.runButton),
      el("p", { class: "meta" }, "A dry run plans it on the controller (its speeds, where the stage stands) first."),
      this.estimate, this.runError);
    const watch = el("section", { class: "card gcode-watch" }, el("h2", {}, "Job"), this.progress);
    this.watchCard = watch;
    watch.hidden = true;

    this.root = el("div", { class: "gcode", id: "gcode" },
      el("div", { class: "gcode-side" }, program, files),
      map,
      el("div", { class: "gcode-side" }, plan, run, watch));
    container.append(this.root);
    this.fileInput.addEventListener("change", () => this.uploadFile());
  }

  destroy() {
    for (const stop of this.stops) stop();
    this.stopFollow?.();
    clearInterval(this.clock);
  }

  // ---------------------------------------------------------------------------------------------
  // Files

  async refreshFiles() {
    try {
      const { files } = await api.request("GET", "/api/v1/gcode/files");
      this.filesBody.replaceChildren(...files.map((f) => this.fileRow(f)));
      this.filesNote.textContent = files.length ? "" : "No programs uploaded yet.";
      this.markSelected();
    } catch (e) {
      this.filesNote.textContent = `Could not list the programs: ${errorText(e)}`;
    }
  }

  fileRow(f) {
    const created = new Date(f.created);
    const when = created.toLocaleString([], { dateStyle: "short", timeStyle: "short" });
    return el("tr", { "data-file": f.id },
      el("td", { class: "file-name" },
         el("button", { type: "button", class: "link", title: f.id, onclick: () => this.choose({ kind: "file", ...f }) }, f.name),
         el("div", { class: "meta", title: f.created }, `${f.lines} lines · ${fileSize(f.bytes)} · ${when}`)),
      el("td", { class: "file-actions" }, el("button", { type: "button", class: "small danger", "data-needs": "operator", title: `delete ${f.name}`,
                                  "aria-label": `delete ${f.name}`, onclick: (ev) => this.remove(f, ev.currentTarget) }, "Delete")));
  }

  markSelected() {
    for (const tr of this.filesBody.children) {
      tr.classList.toggle("selected", this.source?.kind === "file" && tr.dataset.file === this.source.id);
    }
  }

  async upload(body, name) {
    this.sourceError.textContent = "";
    try {
      const f = await api.request("POST", `/api/v1/gcode/files?name=${enc(name || "untitled")}`, undefined, { text: body });
      await this.refreshFiles();
      this.choose({ kind: "file", ...f });
    } catch (e) {
      this.sourceError.textContent = `Upload failed: ${errorText(e)}`;
    }
  }

  uploadFile() {
    const file = this.fileInput.files[0];
    if (!file) return;
    this.upload(file, file.name).finally(() => { this.fileInput.value = ""; });
  }

  uploadText() {
    if (!this.text.value.trim()) {
      this.sourceError.textContent = "Paste a program first.";
      return;
    }
    this.upload(this.text.value, this.nameInput.value.trim() || "pasted.ngc");
  }

  checkText() {
    const text = this.text.value;
    if (!text.trim()) {
      this.sourceError.textContent = "Paste a program first.";
      return;
    }
    this.sourceError.textContent = "";
    this.choose({ kind: "text", text, name: this.nameInput.value.trim() || "pasted program", lines: lineCount(text) });
  }

  // The first click arms the button ("Really delete?"), a second one within 4 s deletes.
  async remove(f, button) {
    if (!button.classList.contains("armed")) {
      button.classList.add("armed");
      button.textContent = "Really delete?";
      setTimeout(() => {
        button.classList.remove("armed");
        button.textContent = "Delete";
      }, 4000);
      return;
    }
    try {
      await api.request("DELETE", `/api/v1/gcode/files/${enc(f.id)}`);
    } catch (e) {
      if (e.status !== 404) {
        this.sourceError.textContent = `Delete failed: ${errorText(e)}`;
        return;
      }
    }
    if (this.source?.kind === "file" && this.source.id === f.id) this.choose(null);
    this.refreshFiles();
  }

  // ---------------------------------------------------------------------------------------------
  // Plan and preview

  // The program to show and run (null: none).
  async choose(source) {
    this.source = source;
    this.plan = null;
    this.ttlLines = null;
    this.resetCheck();
    this.markSelected();
    this.summary.replaceChildren();
    this.warnings.replaceChildren();
    this.planError.hidden = true;
    this.plot.removeOverlay("preview");
    if (this.trace?.ended) this.clearTrace();  // a running job's trace stays until it ends
    this.title.textContent = source ? source.name : "No program chosen";
    this.previewNote.textContent = source ? "Planning…" : "Upload, pick or paste a program to see its path.";
    this.root.dataset.plan = source ? "loading" : "none";
    if (!source) return;

    const seq = ++this.planSeq;
    const withMoves = source.lines <= MAX_LINES_WITH_MOVES;
    const [plan, preview] = await Promise.allSettled([this.fetchPlan(source, withMoves), this.fetchPreview(source)]);
    if (seq !== this.planSeq) return;
    if (plan.status === "rejected") {
      this.showPlanError(plan.reason);
      this.previewNote.textContent = "No preview: the program has an error.";
      this.root.dataset.plan = "error";
      return;
    }
    this.plan = plan.value;
    if (this.plan.moves) this.ttlLines = motionLines(this.plan.moves);
    this.showSummary(this.plan);
    if (preview.status === "fulfilled") {
      const ext = previewExtent(this.plan.bounds, PREVIEW_WIDTH_PX);
      this.plot.clearTrail();
      this.plot.setImage("preview", `data:image/svg+xml;charset=utf-8,${enc(preview.value)}`, ext.min, ext.max, "xy-image gcode-preview");
      this.previewNote.textContent = withMoves ? "" : "A large program: the trace is drawn in one colour.";
    } else {
      this.previewNote.textContent = `No preview: ${errorText(preview.reason)}`;
    }
    this.root.dataset.plan = "ready";
    this.dryRunButton.disabled = false;
  }

  fetchPlan(source, withMoves) {
    const query = withMoves ? "" : "?moves=false";
    if (source.kind === "file") return api.request("POST", `/api/v1/gcode/files/${enc(source.id)}/plan${query}`);
    return api.request("POST", `/api/v1/gcode/plan${query}`, undefined, { text: source.text });
  }

  fetchPreview(source) {
    const query = `?width_px=${PREVIEW_WIDTH_PX}`;
    if (source.kind === "file") return api.request("GET", `/api/v1/gcode/files/${enc(source.id)}/preview.svg${query}`);
    return api.request("POST", `/api/v1/gcode/preview.svg${query}`, undefined, { text: source.text });
  }

  showSummary(plan) {
    const [min, max] = [plan.bounds.min, plan.bounds.max];
    const moves = plan.moves ? plan.moves.length : plan.move_count;
    const rows = [
      ["Lines", String(this.source.lines)],
      ["Moves", String(moves)],
      ["Segments", String(plan.segments)],
      ["Estimated", formatDuration(plan.estimated_s)],
      ...["X", "Y", "Z"].map((axis, i) => [`${axis} range`, min[i] === max[i] ? mm(min[i]) : `${mm(min[i])} … ${mm(max[i])}`]),
    ];
    this.summary.replaceChildren(...rows.flatMap(([k, v]) => [el("dt", {}, k), el("dd", { "data-key": k }, v)]));
    this.warnings.replaceChildren(...(plan.warnings || []).map((w) => el("li", {}, w)));
  }

  // An invalid-gcode problem names the line and column; anything else is shown as it is.
  showPlanError(e) {
    const p = e?.problem || {};
    const where = typeof p.line === "number" && p.line > 0 ? `Line ${p.line}${p.column ? `, column ${p.column}` : ""}: ` : "";
    const text = where ? `${where}${p.message || errorText(e)}` : errorText(e);
    const code = where && this.source?.kind === "text" ? this.source.text.split("\n")[p.line - 1] : null;
    fill(this.planError, el("strong", {}, "Error. "), text,
      code !== null && code !== undefined ? el("pre", { class: "error-line" }, `${String(p.line).padStart(4)} | ${code}`) : null);
    this.planError.dataset.line = p.line ?? "";
    this.planError.hidden = false;
  }

  // ---------------------------------------------------------------------------------------------
  // Dry run and run

  fillControllers() {
    const ids = [...store.controllers.keys()].sort();
    const keep = this.controllerSelect.value;
    this.controllerSelect.replaceChildren(...ids.map((id) => el("option", { value: id }, id)));
    if (ids.includes(keep)) this.controllerSelect.value = keep;
  }

  spec() {
    return this.source.kind === "file" ? { file: this.source.id } : { program: this.source.text };
  }

  resetCheck() {
    this.checked = null;
    this.runButton.disabled = true;
    this.runButton.textContent = "Run";
    this.dryRunButton.disabled = !this.plan;
    this.estimate.replaceChildren();
    this.runError.textContent = "";
  }

  async dryRun() {
    this.resetCheck();
    const controller = this.controllerSelect.value;
    if (!controller || !this.source) return;
    const source = this.source;
    this.estimate.textContent = "Planning on the controller…";
    try {
      const { plan } = await api.submitJob({ controller, type: "gcode", spec: this.spec() }, true);
      if (source !== this.source) return;
      this.checked = { controller, source };
      this.runButton.disabled = false;
      this.runButton.textContent = `Run on ${controller}`;
      fill(this.estimate,
        el("div", {}, el("strong", { "data-estimate": plan.estimated_s }, formatDuration(plan.estimated_s)),
           ` on ${controller}: ${plan.steps_total} steps, ${plan.path} path`),
        plan.summary ? el("div", { class: "meta" }, plan.summary) : null,
        ...(plan.warnings || []).map((w) => el("div", { class: "warn" }, w)));
    } catch (e) {
      this.estimate.replaceChildren();
      this.runError.textContent = `Dry run refused: ${errorText(e)}`;
    }
  }

  async run() {
    if (!this.checked || this.checked.source !== this.source) return;
    const { controller } = this.checked;
    this.runButton.disabled = true;
    this.runError.textContent = "";
    try {
      const job = await api.submitJob({ controller, type: "gcode", spec: this.spec() });
      this.startTrace(job);
    } catch (e) {
      this.runError.textContent = `Not started: ${errorText(e)}`;
      this.runButton.disabled = false;
    }
  }

  // ---------------------------------------------------------------------------------------------
  // The trace

  clearTrace() {
    this.stopFollow?.();
    this.stopFollow = null;
    clearInterval(this.clock);
    for (const name of this.traceNames) this.plot.removeOverlay(name);
    this.traceNames = [];
    this.trace = null;
    this.watchCard.hidden = true;
    delete this.root.dataset.jobState;
    delete this.root.dataset.traced;
  }

  startTrace(job) {
    this.clearTrace();
    this.plot.clearTrail();
    this.trace = { id: job.id, controller: job.controller, job, doneLine: 0, ttl: null, name: null,
                   last: null, points: 0, ended: false };
    this.root.dataset.traced = "0";
    this.watchCard.hidden = false;
    const topic = `jobs/${job.id}`;
    this.stopFollow = store.follow(topic, (msg) => this.onJobMessage(msg));
    this.showJob(job);
    clearInterval(this.clock);
    this.clock = setInterval(() => this.tick(), 1000);
    // What happened before the subscription: the steps done so far (their lines) and the state.
    api.jobEvents(job.id).then(({ events }) => {
      for (const ev of events) this.onJobEvent(ev);
    }).catch(() => {}).finally(() => this.resync());
  }

  // Once a second: the times shown move on. While the job still looks queued, REST says where it is:
  // a state change published before the subscription took effect (and not yet in the stored
  // history) reaches the view no other way.
  tick() {
    const t = this.trace;
    if (!t) return;
    this.showJob(t.job);
    if (!t.ended && t.job.state === "queued") this.resync();
  }

  onJobMessage(msg) {
    if (!this.trace) return;
    if (msg.type === "event") this.onJobEvent(msg.data, msg.time);
    else this.resync({ steps: true });  // a gap or a retired topic: ask REST where the job is
  }

  // The job's record from REST; with steps, also the lines its stored step events say are done (the
  // record's current_step is the step under way: its line is not done yet).
  async resync({ steps = false } = {}) {
    const t = this.trace;
    try {
      const [job, history] = await Promise.all([api.job(t.id), steps ? api.jobEvents(t.id) : null]);
      if (this.trace !== t) return;
      for (const ev of history?.events || []) {
        if (ev.type === "step") t.doneLine = Math.max(t.doneLine, ev.line ?? lastLineOf(ev.name));
      }
      this.setJob(job);
    } catch {
      // The next event or the next resync tells.
    }
  }

  // ev: a job event; time: when the gateway published it (live events only).
  onJobEvent(ev, time) {
    const t = this.trace;
    if (!t || !ev) return;
    if (ev.type === "state" && ev.job) {
      this.setJob(ev.job);
    } else if (ev.type === "step") {
      t.doneLine = Math.max(t.doneLine, ev.line ?? lastLineOf(ev.name));
      if (!t.ended) this.switchAt(ev.position, time);
      if ((ev.steps_done ?? 0) < (t.job.progress?.steps_done ?? 0)) return;  // an older step (the backfill)
      // remaining_s is as of now: the countdown starts again from here.
      t.job = { ...t.job, updated: new Date().toISOString(), progress: { ...t.job.progress, ...this.stepProgress(ev) } };
      this.showJob(t.job);
    }
  }

  stepProgress(ev) {
    const out = {};
    for (const k of ["steps_done", "steps_total", "percent", "remaining_s", "elapsed_s", "eta", "waiting_for"]) {
      if (ev[k] !== undefined) out[k] = ev[k];
    }
    if (ev.name) out.current_step = ev.name;
    return out;
  }

  setJob(job) {
    const t = this.trace;
    if (!t || job.id !== t.id) return;
    if (t.ended && !TRACE_ENDS.has(job.state)) return;  // an older record arriving late
    // A state event's record comes without its spec (it never changes): keep the one we have.
    t.job = !job.spec && t.job ? { ...job, spec: t.job.spec } : job;
    if (TRACE_ENDS.has(job.state) && !t.ended) {
      t.ended = true;
      const p = store.controllers.get(t.controller)?.position;
      this.tracePoint(axisUm(p, "X"), axisUm(p, "Y"));  // where it stopped
      clearInterval(this.clock);
      this.stopFollow?.();
      this.stopFollow = null;
    }
    this.showJob(job);
  }

  onController({ id, controller, what }) {
    if (what !== "position") return;
    const x = axisUm(controller.position, "X");
    const y = axisUm(controller.position, "Y");
    const t = this.trace;
    if (t && !t.ended && id === t.controller) {
      const taken = Date.parse(controller.position.time || "");
      if (t.switchedAt && taken < t.switchedAt) return;
      if (["running", "paused"].includes(t.job.state) || t.last) this.tracePoint(x, y);
    } else if (!t || t.ended) {
      // Where the chosen controller's stage is, when that is on the map (the view does not zoom out for it).
      const onMap = this.plot.overlays.has("preview") && typeof x === "number" && this.plot.contains(x, y);
      if (id === this.controllerSelect.value && onMap) this.plot.setPosition(x, y);
    }
  }

  // A step ends where its last line's planned move ends: when the TTL output switches there, the
  // stretch in the old colour ends exactly at that point and the new one starts from it. Positions
  // come rate-limited (latest value wins), so one taken before the switch may arrive after it: those
  // older than the switch are left out (the stage went straight to the switch point anyway).
  switchAt(position, time) {
    const t = this.trace;
    const ttl = this.ttlLines ? ttlAfter(this.ttlLines, t.doneLine) : false;
    if ((t.name && ttl === t.ttl) || typeof position?.X !== "number" || typeof position?.Y !== "number") return;
    if (t.name) this.plot.extendPath(t.name, position.X, position.Y);
    this.startStretch(ttl, [position.X, position.Y]);
    t.last = [position.X, position.Y];
    if (time) t.switchedAt = Date.parse(time);
  }

  startStretch(ttl, from) {
    const t = this.trace;
    t.ttl = ttl;
    t.name = `trace-${this.traceNames.length}`;
    this.traceNames.push(t.name);
    if (from) this.plot.extendPath(t.name, from[0], from[1], ttl ? "xy-traced ttl-on" : "xy-traced");
  }

  tracePoint(x, y) {
    const t = this.trace;
    if (typeof x !== "number" || typeof y !== "number") return;
    if (t.last && t.last[0] === x && t.last[1] === y) return;
    const ttl = this.ttlLines ? ttlAfter(this.ttlLines, t.doneLine) : false;
    // A switch the step events did not mark (a step seen late): the new stretch starts at the last
    // point, so the line stays whole.
    if (ttl !== t.ttl || !t.name) this.startStretch(ttl, t.last);
    this.plot.extendPath(t.name, x, y, ttl ? "xy-traced ttl-on" : "xy-traced");
    this.plot.setPosition(x, y);
    t.last = [x, y];
    t.points += 1;
    this.root.dataset.traced = String(t.points);
  }

  showJob(job) {
    const t = this.trace;
    if (!t) return;
    this.watchCard.hidden = false;
    const p = job.progress || {};
    const percent = Math.max(0, Math.min(100, p.percent ?? 0));
    const lines = this.source?.lines;
    const lineText = t.doneLine ? `line ${t.doneLine}${lines ? ` of ${lines}` : ""}` : "starting";
    const remaining = this.remainingS(job);
    const bar = el("div", { class: "progress", role: "progressbar", "aria-valuenow": percent.toFixed(0),
                            "aria-valuemin": "0", "aria-valuemax": "100" }, el("div", { class: "progress-fill" }));
    bar.firstChild.style.width = `${percent}%`;  // a property set from script: allowed by the CSP
    this.progress.hidden = false;
    this.progress.dataset.state = job.state;
    fill(this.progress,
      el("div", { class: "gcode-row" }, el("span", { class: `job-state ${job.state}`, id: "gcode-job-state" }, job.state),
         el("a", { href: `#/jobs/${enc(job.id)}`, id: "gcode-job-link" }, job.id)),
      bar,
      el("div", { class: "gcode-row" }, el("span", { id: "gcode-line" }, lineText),
         el("span", { class: "meta" }, `${percent.toFixed(0)} % · ${p.steps_done ?? 0} of ${p.steps_total ?? "?"} steps`)),
      el("div", { class: "meta" }, `elapsed ${formatDuration(this.elapsedS(job))}`,
         TRACE_ENDS.has(job.state) ? "" : ` · remaining ${formatDuration(remaining)}`,
         p.waiting_for ? ` · waiting for ${p.waiting_for}` : ""),
      job.reason ? el("div", { class: "meta" }, job.reason) : null,
      TRACE_ENDS.has(job.state) ? null
        : el("button", { type: "button", class: "small danger", id: "gcode-cancel", "data-needs": "operator",
                         onclick: () => api.jobAction(job.id, "cancel", job.controller).catch((e) => {
                           this.runError.textContent = `Cancel failed: ${errorText(e)}`;
                         }) }, "Cancel job"));
    this.root.dataset.jobState = job.state;
  }

  // Counts down between events: from the absolute eta when the gateway sends one, else from the
  // last remaining_s and the time since the record was updated.
  remainingS(job) {
    const p = job.progress || {};
    if (p.eta) return Math.max(0, (Date.parse(p.eta) - Date.now()) / 1000);
    if (typeof p.remaining_s !== "number") return null;
    const since = job.updated ? (Date.now() - Date.parse(job.updated)) / 1000 : 0;
    return job.state === "running" ? Math.max(0, p.remaining_s - Math.max(0, since)) : p.remaining_s;
  }

  elapsedS(job) {
    if (job.started && !job.finished && job.state === "running") return (Date.now() - Date.parse(job.started)) / 1000;
    if (job.started && job.finished) return (Date.parse(job.finished) - Date.parse(job.started)) / 1000;
    return job.progress?.elapsed_s;
  }

  // A G-code job already running (started from another page or before a reload): show its program
  // and trace it from now on.
  async attachToRunningJob() {
    try {
      const { jobs } = await api.listJobs({ type: "gcode", state: "running", limit: 1 });
      const job = jobs?.[0];
      if (!job || this.trace) return;
      const spec = job.spec || {};
      if (spec.file) {
        const f = await api.request("GET", `/api/v1/gcode/files/${enc(spec.file)}`);
        await this.choose({ kind: "file", ...f });
      } else if (typeof spec.program === "string") {
        this.text.value = spec.program;
        await this.choose({ kind: "text", text: spec.program, name: `program of ${job.id}`, lines: lineCount(spec.program) });
      }
      if (!this.trace) {
        this.controllerSelect.value = job.controller;
        this.startTrace(job);
      }
    } catch {
      // Nothing to attach to, or the list is refused: the view works without it.
    }
  }
}

export function mount(container) {
  const view = new GcodeView(container);
  return () => view.destroy();
}
