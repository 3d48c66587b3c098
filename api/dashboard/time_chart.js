// A live time-series chart over uPlot (the global `uPlot`, loaded by index.html): the last `windowS`
// seconds of one or more tracks (a track is a source of samples with one value per series, e.g. the
// positions of X, Y, Z; or the encoder report frames), plus vertical marks (TTL events). Samples
// arrive at any rate; a track keeps at most one per `minIntervalS` (decimation for drawing only) and
// the chart redraws at most `fps` times a second, so a 500 frames/s stream costs a few hundred points.
// Times are the gateway's (seconds); the chart scrolls with the gateway clock as the events tell it.

import { el } from "./dom.js";

const AXIS_COLOURS = { X: "#1570ef", Y: "#dc6803", Z: "#079455", F: "#7a5af8" };
const OTHER_COLOURS = ["#c11574", "#0e9384", "#475467"];
const MAX_MARKS = 2000;

export function axisColour(axis, i = 0) {
  return AXIS_COLOURS[axis] || OTHER_COLOURS[i % OTHER_COLOURS.length];
}

// A sorted ring of samples [t, values] trimmed to the window.
class Track {
  constructor({ name, series, minIntervalS = 0, holdLast = false }) {
    this.name = name;
    this.series = series;
    this.minIntervalS = minIntervalS;
    this.holdLast = holdLast;
    this.samples = [];
    this.beforeWindow = null;  // the last sample trimmed away: where a held line enters the window
  }

  push(t, values) {
    const last = this.samples[this.samples.length - 1];
    if (last && t < last[0]) return false;  // out of order (a replay): drawing needs sorted times
    if (last && t - last[0] < this.minIntervalS) return false;
    this.samples.push([t, values]);
    return true;
  }

  trim(minT) {
    let n = 0;
    while (n < this.samples.length && this.samples[n][0] < minT) n++;
    if (n) this.beforeWindow = this.samples[n - 1];
    this.samples.splice(0, n);
  }

  // The samples to draw: a held track runs from the window's left edge to now.
  visible(minT, now) {
    if (!this.holdLast) return this.samples;
    const out = [];
    const first = this.beforeWindow || null;
    if (first) out.push([minT, first[1]]);
    out.push(...this.samples);
    const last = out[out.length - 1];
    if (last && last[0] < now) out.push([now, last[1]]);
    return out;
  }
}

export class TimeChart {
  constructor({ windowS = 30, height = 260, fps = 10, yLabel = "µm" } = {}) {
    this.windowS = windowS;
    this.height = height;
    this.fps = fps;
    this.yLabel = yLabel;
    this.tracks = [];
    this.marks = [];
    this.clockOffsetS = null;  // gateway time - local time, from the events
    this.plot = null;
    this.range = [0, windowS];
    this.root = el("div", { class: "time-chart" });
    this.timer = setInterval(() => this.draw(), 1000 / fps);
    // Resized on the next frame and only when the width changed: no resize loop.
    this.resize = new ResizeObserver(() => requestAnimationFrame(() => {
      if (this.plot && this.plot.width !== this.width()) this.plot.setSize({ width: this.width(), height: this.height });
    }));
    this.resize.observe(this.root);
  }

  // tracks: [{name, series: [{label, colour, points: bool}], minIntervalS, holdLast}]; replaces the
  // chart's tracks (and their samples) and rebuilds the plot.
  setTracks(tracks) {
    this.tracks = tracks.map((t) => new Track(t));
    this.plot?.destroy();
    this.plot = null;
  }

  push(trackName, t, values) {
    this.seeTime(t);
    const track = this.tracks.find((tr) => tr.name === trackName);
    return track ? track.push(t, values) : false;
  }

  mark(t) {
    this.seeTime(t);
    this.marks.push(t);
    if (this.marks.length > MAX_MARKS) this.marks.splice(0, this.marks.length - MAX_MARKS);
  }

  // The gateway's clock, learnt from event times (the newest event is at most a little behind it).
  seeTime(t) {
    const offset = t - Date.now() / 1000;
    if (this.clockOffsetS === null || offset > this.clockOffsetS || offset < this.clockOffsetS - 2) this.clockOffsetS = offset;
  }

  now() {
    return Date.now() / 1000 + (this.clockOffsetS ?? 0);
  }

  width() {
    return Math.max(300, this.root.clientWidth);
  }

  options() {
    const series = [{}];
    for (const track of this.tracks) {
      for (const s of track.series) {
        series.push(s.points
          ? { label: s.label, stroke: s.colour, fill: s.colour, paths: () => null, points: { show: true, size: 3, width: 0, fill: s.colour } }
          : { label: s.label, stroke: s.colour, width: 1.5, spanGaps: true, points: { show: false } });
      }
    }
    return {
      width: this.width(),
      height: this.height,
      series,
      scales: { x: { time: true, range: () => this.range } },
      axes: [{ stroke: "#475467", grid: { stroke: "#eaecf0" } },
             { label: this.yLabel, size: 70, stroke: "#475467", grid: { stroke: "#eaecf0" } }],
      cursor: { drag: { x: false, y: false } },
      legend: { live: false },
      hooks: { draw: [(u) => this.drawMarks(u)] },
    };
  }

  // uPlot's aligned data: one x array of every sample time, one array per series (null where that
  // series has no sample at that time).
  data(minT, now) {
    const rows = [];
    let column = 0;
    for (const track of this.tracks) {
      for (const [t, values] of track.visible(minT, now)) rows.push([t, column, values, track.series.length]);
      column += track.series.length;
    }
    rows.sort((a, b) => a[0] - b[0]);
    const xs = new Array(rows.length);
    const ys = Array.from({ length: column }, () => new Array(rows.length).fill(null));
    rows.forEach(([t, first, values, n], i) => {
      xs[i] = t;
      for (let k = 0; k < n; k++) ys[first + k][i] = values[k] ?? null;
    });
    return [xs, ...ys];
  }

  draw() {
    if (document.hidden || !this.tracks.length || !this.root.isConnected || this.root.clientWidth === 0) return;
    const now = this.now();
    const minT = now - this.windowS;
    for (const track of this.tracks) track.trim(minT);
    let drop = 0;
    while (drop < this.marks.length && this.marks[drop] < minT) drop++;
    this.marks.splice(0, drop);
    this.range = [minT, now];
    const data = this.data(minT, now);
    if (!this.plot) this.plot = new uPlot(this.options(), data, this.root);
    else this.plot.setData(data);
    this.root.dataset.samples = this.tracks.map((t) => `${t.name}:${t.samples.length}`).join(" ");
    this.root.dataset.marks = String(this.marks.length);
  }

  drawMarks(u) {
    if (!this.marks.length) return;
    const { top, height } = u.bbox;
    const ctx = u.ctx;
    ctx.save();
    ctx.strokeStyle = "rgba(217, 45, 32, 0.55)";
    ctx.lineWidth = Math.max(1, devicePixelRatio);
    ctx.beginPath();
    for (const t of this.marks) {
      const x = Math.round(u.valToPos(t, "x", true));
      ctx.moveTo(x, top);
      ctx.lineTo(x, top + height);
    }
    ctx.stroke();
    ctx.restore();
  }

  destroy() {
    clearInterval(this.timer);
    this.resize.disconnect();
    this.plot?.destroy();
    this.plot = null;
  }
}
