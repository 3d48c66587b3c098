// The positions of a position recording over frame index, in µm, one series per axis (uPlot, the global
// `uPlot` that index.html loads), with the loss markers as red vertical lines at their index. Every
// row is kept (typed arrays); what is drawn is decimated to at most BUCKETS buckets per series, each
// drawn as its minimum and maximum, so that a recording of a million frames costs a few thousand points
// and still shows every excursion. Rows may arrive in many pieces (a stream, live events): the chart
// redraws at most every REDRAW_MS.

import { el } from "./dom.js";
import { axisColour } from "./time_chart.js";

const BUCKETS = 2000;
const REDRAW_MS = 250;

// A growing Float64Array.
class Column {
  constructor() {
    this.data = new Float64Array(1024);
    this.length = 0;
  }

  push(v) {
    if (this.length === this.data.length) {
      const bigger = new Float64Array(this.data.length * 2);
      bigger.set(this.data);
      this.data = bigger;
    }
    this.data[this.length++] = v;
  }
}

// The axes of a row from its keys ("X_um", "Y_um" -> "XY"), for rows that come before the record says.
const axesOfRow = (row) => Object.keys(row).filter((k) => /^[A-Z]_um$/.test(k)).map((k) => k[0]).join("");

export class RecordingChart {
  constructor({ height = 320 } = {}) {
    this.height = height;
    this.axes = "";
    this.timer = null;
    this.plot = null;
    this.plotKey = "";
    this.holder = el("div", { class: "recording-plot" });
    this.caption = el("p", { class: "meta recording-chart-caption" }, "No frames yet.");
    this.root = el("div", { class: "recording-chart" }, this.holder, this.caption);
    this.clear();
    // Resized on the next frame and only when the width changed: no resize loop.
    this.resize = new ResizeObserver(() => requestAnimationFrame(() => {
      if (this.plot && this.plot.width !== this.width()) this.plot.setSize({ width: this.width(), height: this.height });
      else if (!this.plot) this.schedule();
    }));
    this.resize.observe(this.holder);
  }

  // Forgets every row (before the rows are read again).
  clear() {
    this.index = new Column();  // the index of each frame
    this.values = [...this.axes].map(() => new Column());  // per axis: µm of each frame (NaN: unknown)
    this.losses = [];  // the index of each loss marker
    this.schedule();
  }

  // "XYZ": one series per letter. Rows already held get NaN for an axis that is new.
  setAxes(axes) {
    if (!axes || axes === this.axes) return;
    const old = new Map([...this.axes].map((a, i) => [a, this.values[i]]));
    this.axes = axes;
    this.values = [...axes].map((a) => {
      if (old.has(a)) return old.get(a);
      const c = new Column();
      for (let i = 0; i < this.index.length; i++) c.push(NaN);
      return c;
    });
    this.schedule();
  }

  // Rows as GET .../frames?format=jsonl and the live topic give them: {index, time_us, loss, X_um, ...}.
  append(rows) {
    for (const row of rows) {
      if (row.loss) {
        this.losses.push(row.index);
        continue;
      }
      if (!this.axes) this.setAxes(axesOfRow(row));
      this.index.push(row.index);
      for (let a = 0; a < this.axes.length; a++) {
        const v = row[`${this.axes[a]}_um`];
        this.values[a].push(typeof v === "number" ? v : NaN);
      }
    }
    if (rows.length) this.schedule();
  }

  get frames() {
    return this.index.length;
  }

  schedule() {
    if (this.timer) return;
    this.timer = setTimeout(() => {
      this.timer = null;
      this.draw();
    }, this.plot ? REDRAW_MS : 0);
  }

  width() {
    return Math.max(300, this.holder.clientWidth);
  }

  // uPlot's data: the frame indexes drawn and, per axis, the µm at them (null where unknown). Up to
  // 2 * BUCKETS frames everything; beyond, per bucket of frames its first and last index carry the
  // bucket's extremes in the order they occur.
  data() {
    const n = this.index.length;
    const idx = this.index.data;
    if (n <= 2 * BUCKETS) {
      const ys = this.values.map((c) => Array.from(c.data.subarray(0, n), (v) => (Number.isNaN(v) ? null : v)));
      return [Array.from(idx.subarray(0, n)), ...ys];
    }
    const size = Math.ceil(n / BUCKETS);
    const xs = [];
    const ys = this.values.map(() => []);
    for (let b = 0; b < n; b += size) {
      const end = Math.min(b + size, n);
      xs.push(idx[b], idx[end - 1]);
      this.values.forEach((c, s) => {
        let lo = -1;
        let hi = -1;
        for (let i = b; i < end; i++) {
          const v = c.data[i];
          if (Number.isNaN(v)) continue;
          if (lo < 0 || v < c.data[lo]) lo = i;
          if (hi < 0 || v > c.data[hi]) hi = i;
        }
        const first = Math.min(lo, hi);
        const second = Math.max(lo, hi);
        ys[s].push(first < 0 ? null : c.data[first], second < 0 ? null : c.data[second]);
      });
    }
    return [xs, ...ys];
  }

  options() {
    return {
      width: this.width(),
      height: this.height,
      series: [{ label: "frame" },
               ...[...this.axes].map((a, i) => ({ label: `${a} (µm)`, stroke: axisColour(a, i), width: 1.5 }))],
      // Frame indexes; wide enough for a loss marker after the last frame too.
      scales: { x: { time: false, range: (u, min, max) => this.xRange(min, max) } },
      axes: [{ label: "frame index", stroke: "#475467", grid: { stroke: "#eaecf0" } },
             { label: "µm", size: 80, stroke: "#475467", grid: { stroke: "#eaecf0" } }],
      cursor: { drag: { x: false, y: false } },
      legend: { live: false },
      hooks: { draw: [(u) => this.drawLosses(u)] },
    };
  }

  // A marker beyond the frames (frames lost after the last one) widens the range, with a margin so
  // that its line does not sit on the plot's edge.
  xRange(min, max) {
    const first = this.losses[0] ?? min;
    const last = this.losses[this.losses.length - 1] ?? max;
    const lo = Math.min(min, first);
    const hi = Math.max(max, last);
    if (lo === hi) return [lo - 1, hi + 1];
    const pad = (hi - lo) * 0.02;
    return [first < min ? lo - pad : lo, last > max ? hi + pad : hi];
  }

  draw() {
    const n = this.index.length;
    this.root.dataset.frames = String(n);
    this.root.dataset.losses = String(this.losses.length);
    this.root.dataset.series = [...this.axes].join(",");
    const lossText = this.losses.length
      ? ` · ${this.losses.length} loss marker${this.losses.length === 1 ? "" : "s"} (red lines: frames lost before that index)`
      : " · no frames lost";
    if (!n || !this.axes) {
      this.caption.textContent = `No frames yet${this.losses.length ? lossText : ""}.`;
      return;
    }
    if (!this.holder.isConnected || this.holder.clientWidth === 0) return;  // drawn when it has a size
    const data = this.data();
    const key = this.axes;
    if (!this.plot || this.plotKey !== key) {
      this.plot?.destroy();
      this.plot = new uPlot(this.options(), data, this.holder);
      this.plotKey = key;
    } else {
      this.plot.setData(data);
    }
    this.root.dataset.points = String(data[0].length);
    const drawn = data[0].length < n ? `, drawn as ${data[0].length} points per axis (minimum and maximum per bucket)` : "";
    this.caption.textContent = `${n} frame${n === 1 ? "" : "s"}${drawn}${lossText}`;
  }

  // One line per marker; markers closer than a pixel share one, labelled with how many they are
  // (the controller's overruns are counted after the frame they follow: many at one index).
  drawLosses(u) {
    if (!this.losses.length) return;
    const groups = [];  // [x, count]
    for (const index of this.losses) {
      const x = Math.round(u.valToPos(index, "x", true));
      const g = groups[groups.length - 1];
      if (g && g[0] === x) g[1]++;
      else groups.push([x, 1]);
    }
    const { top, height } = u.bbox;
    const ctx = u.ctx;
    ctx.save();
    ctx.strokeStyle = "rgba(217, 45, 32, 0.8)";
    ctx.lineWidth = 2 * devicePixelRatio;
    ctx.beginPath();
    for (const [x] of groups) {
      ctx.moveTo(x, top);
      ctx.lineTo(x, top + height);
    }
    ctx.stroke();
    if (groups.length <= 50) {
      ctx.fillStyle = "#b42318";
      ctx.font = `${Math.round(12 * devicePixelRatio)}px system-ui, sans-serif`;
      ctx.textBaseline = "top";
      const gap = 4 * devicePixelRatio;
      for (const [x, count] of groups) {
        if (count < 2) continue;
        const left = x - u.bbox.left > 100 * devicePixelRatio;  // beside the line, inside the plot
        ctx.textAlign = left ? "right" : "left";
        ctx.fillText(`${count} markers`, left ? x - gap : x + gap, top + gap);
      }
    }
    ctx.restore();
  }

  destroy() {
    clearTimeout(this.timer);
    this.resize.disconnect();
    this.plot?.destroy();
    this.plot = null;
  }
}
