// The XY map of a stage, in SVG: the soft limits as a frame, a trail of recent positions, the stage's
// current position, and overlays (a job's bounding box, a planned path, a traced path). Coordinates
// are the controller's um with Y pointing up; the view fits the limits (or, without limits, what is
// drawn) with a margin.

import { el, svg } from "./dom.js";

const TRAIL_POINTS = 600;  // at 10 Hz a minute of trail

export class XYPlot {
  constructor({ title = "XY", width = 420, height = 420 } = {}) {
    this.width = width;
    this.height = height;
    this.limits = null;  // {min: {X, Y}, max: {X, Y}}
    this.trail = [];
    this.overlays = new Map();  // name -> SVG element
    this.extent = null;  // what the view fits: {minX, minY, maxX, maxY}
    this.frame = svg("rect", { class: "xy-limits" });
    this.trailLine = svg("polyline", { class: "xy-trail", fill: "none" });
    this.marker = svg("circle", { class: "xy-position", r: 5, visibility: "hidden" });
    this.overlayGroup = svg("g", { class: "xy-overlays" });
    this.plot = svg("g", {}, this.frame, this.overlayGroup, this.trailLine, this.marker);
    this.svg = svg("svg", { class: "xy-plot", viewBox: `0 0 ${width} ${height}`, role: "img",
                            "aria-label": `${title} position map` }, this.plot);
    this.readout = el("div", { class: "xy-readout live-value" });
    this.root = el("figure", { class: "xy" }, this.svg, this.readout);
  }

  // Soft limits in um per axis ({X: {lower, upper}, Y: {...}}); null bounds leave the frame open.
  setLimits(limits) {
    const x = limits?.X;
    const y = limits?.Y;
    if (x && y && [x.lower, x.upper, y.lower, y.upper].every((v) => typeof v === "number")) {
      this.limits = { minX: x.lower, maxX: x.upper, minY: y.lower, maxY: y.upper };
    } else {
      this.limits = null;
    }
    this.fit();
  }

  setPosition(x, y) {
    if (typeof x !== "number" || typeof y !== "number") return;
    const last = this.trail[this.trail.length - 1];
    if (!last || last[0] !== x || last[1] !== y) {
      this.trail.push([x, y]);
      if (this.trail.length > TRAIL_POINTS) this.trail.splice(0, this.trail.length - TRAIL_POINTS);
    }
    this.position = [x, y];
    this.readout.textContent = `X ${x.toFixed(1)} µm · Y ${y.toFixed(1)} µm`;
    if (!this.limits && !this.contains(x, y)) this.fit();
    else this.draw();
  }

  clearTrail() {
    this.trail = this.position ? [this.position] : [];
    this.draw();
  }

  // A rectangle overlay (a job's bounding box): min/max in um, {X, Y}.
  setBox(name, min, max, className = "xy-box") {
    if (!min || !max) return this.removeOverlay(name);
    this.setOverlay(name, { kind: "box", points: [[min.X, min.Y], [max.X, max.Y]], className });
  }

  // A picture under the paths (the gateway's G-code preview) stretched over min..max in um, {X, Y}.
  // Its element is kept across redraws so that the image is not decoded again at every position.
  setImage(name, href, min, max, className = "xy-image") {
    if (!href || !min || !max) return this.removeOverlay(name);
    const node = svg("image", { class: className, "data-overlay": name, href, preserveAspectRatio: "none" });
    this.setOverlay(name, { kind: "image", points: [[min.X, min.Y], [max.X, max.Y]], className, node });
  }

  // A path overlay: points [[x, y], ...] in um; segments with ttl true get the class "ttl-on".
  setPath(name, points, className = "xy-path") {
    this.setOverlay(name, { kind: "path", points, className });
  }

  // Adds one point to a path overlay (a traced path drawn as it happens).
  extendPath(name, x, y, className = "xy-traced") {
    const o = this.overlays.get(name) || { kind: "path", points: [], className };
    o.points.push([x, y]);
    this.setOverlay(name, o);
  }

  removeOverlay(name) {
    this.overlays.delete(name);
    this.draw();
  }

  setOverlay(name, overlay) {
    this.overlays.set(name, overlay);
    const [x, y] = overlay.points[overlay.points.length - 1] || [];
    if (!this.limits && (overlay.kind !== "path" || !this.contains(x, y))) this.fit();
    else this.draw();
  }

  contains(x, y) {
    const e = this.extent;
    return !e || typeof x !== "number" || (x >= e.minX && x <= e.maxX && y >= e.minY && y <= e.maxY);
  }

  // The extent: the soft limits, or everything drawn (at least 1 mm), with a 5 % margin.
  fit() {
    let e = this.limits;
    if (!e) {
      const pts = [...this.trail];
      for (const o of this.overlays.values()) pts.push(...o.points);
      if (!pts.length) pts.push([0, 0]);
      const xs = pts.map((p) => p[0]);
      const ys = pts.map((p) => p[1]);
      e = { minX: Math.min(...xs), maxX: Math.max(...xs), minY: Math.min(...ys), maxY: Math.max(...ys) };
      const pad = (lo, hi) => Math.max(1000 - (hi - lo), 0) / 2;
      const px = pad(e.minX, e.maxX);
      const py = pad(e.minY, e.maxY);
      e = { minX: e.minX - px, maxX: e.maxX + px, minY: e.minY - py, maxY: e.maxY + py };
    }
    const mx = (e.maxX - e.minX) * 0.05;
    const my = (e.maxY - e.minY) * 0.05;
    this.extent = { minX: e.minX - mx, maxX: e.maxX + mx, minY: e.minY - my, maxY: e.maxY + my };
    this.draw();
  }

  // um -> SVG pixels, one scale for both axes so that a circle stays a circle.
  project([x, y]) {
    const e = this.extent;
    const scale = Math.min(this.width / (e.maxX - e.minX), this.height / (e.maxY - e.minY));
    const ox = (this.width - (e.maxX - e.minX) * scale) / 2;
    const oy = (this.height - (e.maxY - e.minY) * scale) / 2;
    return [ox + (x - e.minX) * scale, this.height - oy - (y - e.minY) * scale];
  }

  draw() {
    if (!this.extent) this.fit();
    const pts = (list) => list.map((p) => this.project(p).map((v) => v.toFixed(1)).join(",")).join(" ");
    if (this.limits) {
      const [x0, y0] = this.project([this.limits.minX, this.limits.maxY]);
      const [x1, y1] = this.project([this.limits.maxX, this.limits.minY]);
      for (const [k, v] of Object.entries({ x: x0, y: y0, width: x1 - x0, height: y1 - y0 })) this.frame.setAttribute(k, v);
      this.frame.setAttribute("visibility", "visible");
    } else {
      this.frame.setAttribute("visibility", "hidden");
    }
    this.trailLine.setAttribute("points", pts(this.trail));
    if (this.position) {
      const [cx, cy] = this.project(this.position);
      this.marker.setAttribute("cx", cx);
      this.marker.setAttribute("cy", cy);
      this.marker.setAttribute("visibility", "visible");
    }
    this.overlayGroup.replaceChildren();
    for (const [name, o] of this.overlays) {
      if (o.kind === "box" || o.kind === "image") {
        const [x0, y0] = this.project([Math.min(o.points[0][0], o.points[1][0]), Math.max(o.points[0][1], o.points[1][1])]);
        const [x1, y1] = this.project([Math.max(o.points[0][0], o.points[1][0]), Math.min(o.points[0][1], o.points[1][1])]);
        if (o.kind === "image") {
          for (const [k, v] of Object.entries({ x: x0, y: y0, width: Math.max(1, x1 - x0), height: Math.max(1, y1 - y0) })) {
            o.node.setAttribute(k, v);
          }
          this.overlayGroup.append(o.node);
          continue;
        }
        this.overlayGroup.append(svg("rect", { class: o.className, "data-overlay": name, x: x0, y: y0,
                                               width: Math.max(1, x1 - x0), height: Math.max(1, y1 - y0) }));
      } else {
        this.overlayGroup.append(svg("polyline", { class: o.className, "data-overlay": name, fill: "none",
                                                   points: pts(o.points) }));
      }
    }
  }
}
