// One position recording (#/recordings/<id>): its summary (state, reason, frames, losses, rate, start
// and stop, metadata); Stop while it records and Delete once it has ended (operators; Delete asks
// twice); downloads of its rows as CSV, JSON Lines and HDF5 (fetched with the token and saved from a
// Blob: a plain link would go without it); and the chart of the positions over frame index with the
// loss markers (recording_chart.js). The stored rows are streamed in as JSON Lines; while it records,
// the live topic recordings/<id> brings the rows stored since, each event placed by its totals.

import * as api from "./api.js";
import { el, errorText, formatDuration } from "./dom.js";
import { formatTime } from "./job_status.js";
import { RecordingChart } from "./recording_chart.js";
import { rateText, recordingBadge } from "./recordings_view.js";
import { navigate } from "./router.js";
import { store } from "./store.js";

const SETTLE_MS = 1500;  // after the end, how long the last live rows may take before the store is read
const DOWNLOADS = [["csv", "CSV"], ["jsonl", "JSON Lines"], ["hdf5", "HDF5"]];
const EXTENSIONS = { csv: "csv", jsonl: "jsonl", hdf5: "h5" };

export function mount(container, { id }) {
  const view = new RecordingView(id);
  container.append(view.root);
  view.start();
  return () => view.stop();
}

// The file name a Content-Disposition header gives, or null.
const fileNameOf = (header) => /filename="([^"]+)"/.exec(header || "")?.[1] || null;

class RecordingView {
  constructor(id) {
    this.id = id;
    this.record = null;
    this.rows = 0;  // rows (frames and loss markers) the chart holds, in the stored order
    this.rowsReady = false;  // false while the stored rows are read: live events wait in `buffered`
    this.buffered = [];
    this.loadSerial = 0;
    this.unfollow = null;
    this.settleTimer = null;
    this.stopped = false;
    this.chart = new RecordingChart({ height: 340 });
    this.build();
  }

  build() {
    this.title = el("h2", {}, "Recording");
    this.badge = recordingBadge("recording");
    this.meta = el("div", { class: "meta rec-meta" });
    this.figures = {};
    const figure = (key, label) => {
      this.figures[key] = el("dd", { "data-figure": key }, "–");
      return el("div", {}, el("dt", {}, label), this.figures[key]);
    };
    this.reason = el("p", { class: "rec-reason", hidden: true });
    this.metadata = el("dl", { class: "rec-metadata" });
    this.stopButton = el("button", { type: "button", id: "rec-stop", class: "danger", hidden: true }, "Stop");
    this.stopButton.addEventListener("click", () => this.stopRecording());
    this.deleteButton = el("button", { type: "button", id: "rec-delete", class: "danger", hidden: true }, "Delete");
    this.deleteButton.addEventListener("click", () => this.remove());
    this.actionError = el("div", { class: "error", role: "alert", id: "rec-action-error" });
    this.downloadStatus = el("span", { class: "meta", id: "rec-download-status", role: "status" });
    this.loadError = el("div", { class: "error", role: "alert", id: "rec-load-error" });
    this.rowsStatus = el("span", { class: "meta", id: "rec-rows-status" });
    this.root = el("section", { class: "recording-page", "data-recording-view": this.id },
                   el("p", { class: "crumbs" }, el("a", { href: "#/recordings" }, "← Recordings")),
                   this.loadError,
                   el("div", { class: "page-head" }, this.title, this.badge),
                   this.meta,
                   el("section", { class: "card rec-summary" },
                      el("dl", { class: "rec-figures" },
                         figure("frames", "Frames"), figure("losses", "Losses"), figure("rate", "Rate"),
                         figure("started", "Started"), figure("stopped", "Stopped"), figure("duration", "Length"),
                         figure("limits", "Limits")),
                      this.reason,
                      el("div", { class: "rec-metadata-block" }, el("h4", {}, "Metadata"), this.metadata),
                      el("div", { class: "rec-actions" },
                         el("span", { class: "rec-operator-actions", "data-needs": "operator" },
                            this.stopButton, this.deleteButton),
                         el("span", { class: "rec-downloads" }, "Download the rows: ",
                            ...DOWNLOADS.map(([format, label]) => {
                              const b = el("button", { type: "button", class: "link", "data-download": format }, label);
                              b.addEventListener("click", () => this.download(format));
                              return b;
                            }),
                            this.downloadStatus)),
                      this.actionError),
                   el("section", { class: "card rec-chart-card" },
                      el("div", { class: "chart-head" }, el("h3", {}, "Positions by frame"), this.rowsStatus),
                      this.chart.root));
  }

  async start() {
    // Followed first, so that no rows stored between the reads below and the subscription are missed.
    this.unfollow = store.follow(`recordings/${this.id}`, (msg) => this.onMessage(msg));
    try {
      this.setRecord(await api.recording(this.id));
    } catch (e) {
      this.loadError.textContent = e.status === 404 ? `There is no recording ${this.id}.` : `Could not load the recording: ${errorText(e)}`;
      this.endFollowing();
      return;
    }
    if (this.record.state !== "recording") this.endFollowing();
    await this.loadRows();
  }

  stop() {
    this.stopped = true;
    this.loadSerial++;  // a stream still reading stops
    this.endFollowing();
    clearTimeout(this.settleTimer);
    this.chart.destroy();
  }

  endFollowing() {
    this.unfollow?.();
    this.unfollow = null;
    this.buffered = [];
  }

  // Every stored row, streamed as JSON Lines into the chart; then the live events that waited.
  async loadRows() {
    const serial = ++this.loadSerial;
    this.root.dataset.storeReads = String(serial);  // how often the rows were read from the store
    this.rowsReady = false;
    this.rows = 0;
    this.chart.clear();
    this.rowsStatus.textContent = "reading the rows…";
    try {
      const res = await api.fetchResponse(api.recordingFramesPath(this.id, "jsonl"));
      const reader = res.body.pipeThrough(new TextDecoderStream()).getReader();
      let rest = "";
      for (;;) {
        const { value, done } = await reader.read();
        if (serial !== this.loadSerial) {
          reader.cancel();
          return;
        }
        if (done) break;
        const lines = (rest + value).split("\n");
        rest = lines.pop();
        this.addRows(lines.filter((l) => l.trim()).map((l) => JSON.parse(l)));
        this.rowsStatus.textContent = `reading the rows… ${this.rows}`;
      }
      if (rest.trim()) this.addRows([JSON.parse(rest)]);
      this.rowsStatus.textContent = "";
    } catch (e) {
      if (serial !== this.loadSerial) return;
      // A stream cut short (the gateway failed part way) keeps what came.
      this.rowsStatus.textContent = `The rows could not all be read (${this.rows} shown): ${errorText(e)}`;
    }
    this.rowsReady = true;
    for (const msg of this.buffered.splice(0)) this.onMessage(msg);
    this.root.dataset.rows = String(this.rows);
  }

  addRows(rows) {
    this.chart.append(rows);
    this.rows += rows.length;
    this.root.dataset.rows = String(this.rows);
  }

  // Live events: {id, controller, state, reason, frames, losses, axes, rows}, the rows stored since the
  // event before. The totals say where its rows sit among all rows: those already held are skipped; a
  // hole (a gap, or rows stored before the subscription and after the read) reads the store again.
  onMessage(msg) {
    if (!this.rowsReady) {
      this.buffered.push(msg);
      return;
    }
    if (msg.type === "gap") {
      this.loadRows();
      return;
    }
    if (msg.type === "retired") {
      this.refresh();  // it ended while this page was away from the topic: the store has the rest
      return;
    }
    if (msg.type !== "event" || !msg.data) return;
    const d = msg.data;
    const first = d.frames + d.losses - d.rows.length;
    const hole = first > this.rows;
    if (!hole) {
      this.chart.setAxes(d.axes);
      this.addRows(d.rows.slice(this.rows - first));
    }
    // Its totals, unless the record shown is newer (a Stop answered before the last events came).
    const wasRecording = this.record.state === "recording";
    if (wasRecording && d.frames + d.losses >= this.record.frames + this.record.losses) {
      this.setRecord({ ...this.record, state: d.state, reason: d.reason, frames: d.frames, losses: d.losses, axes: d.axes });
    }
    if (d.state !== "recording") {
      this.endFollowing();
      if (wasRecording) this.refresh();  // the stop time and the rate
    }
    if (hole) this.loadRows();
  }

  async refresh() {
    try {
      this.setRecord(await api.recording(this.id));
    } catch (e) {
      if (!this.stopped) this.actionError.textContent = `Could not reload the recording: ${errorText(e)}`;
    }
  }

  setRecord(r) {
    const wasRecording = this.record?.state === "recording";
    this.record = r;
    this.chart.setAxes(r.axes);
    this.render();
    // Ended (stopped here, or as a live event said): the store holds every row. Rows a live event
    // has not brought after a moment are read from it.
    if (wasRecording && r.state !== "recording") {
      clearTimeout(this.settleTimer);
      this.settleTimer = setTimeout(() => {
        if (this.stopped) return;
        this.endFollowing();
        if (this.rowsReady && this.rows < this.record.frames + this.record.losses) this.loadRows();
      }, SETTLE_MS);
    }
  }

  render() {
    const r = this.record;
    this.root.dataset.state = r.state;
    this.title.replaceChildren("Recording ", el("span", { class: "rec-name" }, r.name));
    this.badge.replaceWith(this.badge = recordingBadge(r.state, r.reason));
    this.badge.id = "rec-state";
    this.meta.replaceChildren(el("span", { class: "mono" }, r.id), " · on ",
                              el("a", { href: `#/controller/${encodeURIComponent(r.controller)}` }, r.controller),
                              ...(r.job ? [" · by job ", el("a", { href: `#/jobs/${encodeURIComponent(r.job)}`, id: "rec-job" }, r.job)] : []),
                              ` · axes ${r.axes || "(none yet)"} · trigger input mode ${r.ttl_in_mode}`);
    const f = this.figures;
    f.frames.textContent = String(r.frames);
    f.losses.textContent = String(r.losses);
    f.losses.classList.toggle("lossy", r.losses > 0);
    f.rate.textContent = r.state === "recording" ? "recording…" : rateText(r.rate_hz);
    f.started.textContent = formatTime(r.started);
    f.started.title = r.started;
    f.stopped.textContent = r.stopped ? formatTime(r.stopped) : "–";
    f.stopped.title = r.stopped || "";
    f.duration.textContent = r.stopped ? formatDuration((Date.parse(r.stopped) - Date.parse(r.started)) / 1000) : "–";
    const limits = [r.max_frames ? `${r.max_frames} frames` : "", r.max_s ? `${r.max_s} s` : ""].filter(Boolean);
    f.limits.textContent = limits.length ? limits.join(", ") : "none";
    // "stopped" says nothing the badge does not; "max_frames (50) reached" does.
    const reason = r.reason && r.reason !== r.state ? r.reason : "";
    this.reason.hidden = !reason;
    this.reason.textContent = reason ? `${r.state === "failed" ? "Failed" : "Ended"}: ${reason}` : "";
    this.reason.classList.toggle("failed", r.state === "failed");
    const entries = Object.entries(r.metadata || {});
    this.metadata.replaceChildren(...(entries.length
      ? entries.flatMap(([k, v]) => [el("dt", {}, k), el("dd", {}, typeof v === "string" ? v : JSON.stringify(v))])
      : [el("dd", { class: "meta" }, "none")]));
    this.stopButton.hidden = r.state !== "recording";
    this.deleteButton.hidden = r.state === "recording";
  }

  async stopRecording() {
    this.actionError.textContent = "";
    this.stopButton.disabled = true;
    try {
      this.setRecord(await api.stopRecording(this.id));
    } catch (e) {
      this.actionError.textContent = `Stop: ${errorText(e)}`;
    } finally {
      this.stopButton.disabled = false;
    }
  }

  // The first click arms the button ("Really delete?"), a second one within 4 s deletes.
  async remove() {
    const b = this.deleteButton;
    if (!b.classList.contains("armed")) {
      b.classList.add("armed");
      b.textContent = "Really delete?";
      setTimeout(() => {
        b.classList.remove("armed");
        b.textContent = "Delete";
      }, 4000);
      return;
    }
    this.actionError.textContent = "";
    try {
      await api.deleteRecording(this.id);
      navigate("/recordings");
    } catch (e) {
      this.actionError.textContent = `Delete: ${errorText(e)}`;
    }
  }

  // The rows in `format`, read with the token, then saved from a Blob through a temporary link.
  async download(format) {
    this.downloadStatus.textContent = `preparing ${format}…`;
    try {
      const res = await api.fetchResponse(api.recordingFramesPath(this.id, format));
      const blob = await res.blob();
      const url = URL.createObjectURL(blob);
      const name = fileNameOf(res.headers.get("Content-Disposition")) || `${this.id}.${EXTENSIONS[format]}`;
      const a = el("a", { href: url, download: name, hidden: true });
      document.body.append(a);
      a.click();
      a.remove();
      setTimeout(() => URL.revokeObjectURL(url), 60000);
      this.downloadStatus.textContent = `${name}: ${blob.size} bytes`;
      this.downloadStatus.dataset.bytes = String(blob.size);
    } catch (e) {
      this.downloadStatus.textContent = `${format}: ${errorText(e)}`;
    }
  }
}
