// The plate map of an array job, in SVG: rows A.. top to bottom, columns 1.. left to right, one circle
// per well, coloured by what the job did there: pending, current, done, or not part of the job (a
// subset, or wells before resume_from). A click on a well selects it (onSelect(name)).

import { svg } from "./dom.js";

const PRESETS = { 6: [3, 2], 12: [4, 3], 24: [6, 4], 48: [8, 6], 96: [12, 8], 384: [24, 16] };
export const MAX_WELLS_DRAWN = 6144;

// "A", ..., "Z", "AA", ... as the gateway names rows (gateway/jobs/plate.cpp).
export function rowName(row) {
  let name = "";
  for (let n = row + 1; n > 0; n = Math.floor((n - 1) / 26)) name = String.fromCharCode(65 + ((n - 1) % 26)) + name;
  return name;
}

export const wellName = (row, column) => `${rowName(row)}${column + 1}`;

// {columns, rows} of an ArraySpec (a plate preset or a grid), or null.
export function plateGeometry(spec) {
  if (spec?.plate !== undefined) {
    const p = PRESETS[Number(spec.plate)];
    return p ? { columns: p[0], rows: p[1] } : null;
  }
  const g = spec?.grid;
  return g && g.columns > 0 && g.rows > 0 ? { columns: g.columns, rows: g.rows } : null;
}

// The wells in the order the job visits them (raster, or serpentine: odd rows right to left).
export function visitOrder(geometry, order = "serpentine") {
  const out = [];
  for (let r = 0; r < geometry.rows; r++) {
    for (let k = 0; k < geometry.columns; k++) {
      const c = order === "serpentine" && r % 2 === 1 ? geometry.columns - 1 - k : k;
      out.push(wellName(r, c));
    }
  }
  return out;
}

// The wells this job visits, in order: the subset (spec.wells) or all, from resume_from on.
export function jobWells(spec, geometry) {
  const inOrder = visitOrder(geometry, spec.order || "serpentine");
  let wells = spec.wells ? inOrder.filter((w) => spec.wells.includes(w)) : inOrder;
  const from = spec.resume_from ? wells.indexOf(spec.resume_from) : -1;
  if (from > 0) wells = wells.slice(from);
  return wells;
}

export class PlateMap {
  // spec: the job's ArraySpec; onSelect(name) on a click.
  constructor(spec, { onSelect = () => {} } = {}) {
    this.geometry = plateGeometry(spec);
    this.wells = new Map();  // name -> circle
    this.current = null;
    this.selected = null;
    this.onSelect = onSelect;
    const g = this.geometry;
    if (!g || g.columns * g.rows > MAX_WELLS_DRAWN) {
      this.root = null;
      return;
    }
    this.visits = jobWells(spec, g);
    this.inJob = new Set(this.visits);
    this.build();
  }

  build() {
    const { columns, rows } = this.geometry;
    const cell = Math.max(12, Math.min(56, Math.floor(480 / Math.max(columns, rows * 1.5))));
    const margin = 26;
    const r = cell * 0.4;
    const width = margin + columns * cell + 4;
    const height = margin + rows * cell + 4;
    const labels = [];
    const circles = [];
    const label = (x, y, text) => {
      const t = svg("text", { x, y, class: "plate-label", "text-anchor": "middle", "dominant-baseline": "central" });
      t.textContent = text;
      return t;
    };
    const every = columns > 24 ? Math.ceil(columns / 24) : 1;
    for (let c = 0; c < columns; c++) {
      if (c % every === 0 || c === columns - 1) labels.push(label(margin + (c + 0.5) * cell, margin / 2, String(c + 1)));
    }
    const everyRow = rows > 32 ? Math.ceil(rows / 32) : 1;
    for (let row = 0; row < rows; row++) {
      if (row % everyRow === 0) labels.push(label(margin / 2, margin + (row + 0.5) * cell, rowName(row)));
      for (let c = 0; c < columns; c++) {
        const name = wellName(row, c);
        const circle = svg("circle", { cx: margin + (c + 0.5) * cell, cy: margin + (row + 0.5) * cell, r,
                                       class: `well ${this.inJob.has(name) ? "pending" : "outside"}`, "data-well": name });
        const title = svg("title");
        title.textContent = name;
        circle.append(title);
        circles.push(circle);
        this.wells.set(name, circle);
      }
    }
    const plate = svg("rect", { x: margin - 4, y: margin - 4, width: columns * cell + 8, height: rows * cell + 8,
                                rx: 8, class: "plate-outline" });
    this.svg = svg("svg", { class: "plate-map", viewBox: `0 0 ${width + 4} ${height + 4}`, role: "img",
                            width: width + 4, height: height + 4,
                            "aria-label": `plate map, ${columns} x ${rows} wells` }, plate, ...labels, ...circles);
    this.svg.addEventListener("click", (ev) => {
      const name = ev.target?.dataset?.well;
      if (name) this.select(name);
    });
    this.root = this.svg;
  }

  setDone(name) {
    const c = this.wells.get(name);
    if (!c) return;
    c.classList.remove("pending", "current", "outside");
    c.classList.add("done");
    if (this.current === name) this.current = null;
  }

  // The well in progress (null: none).
  setCurrent(name) {
    if (this.current && this.current !== name) this.wells.get(this.current)?.classList.remove("current");
    this.current = null;
    const c = name && this.wells.get(name);
    if (!c || c.classList.contains("done")) return;
    c.classList.add("current");
    this.current = name;
  }

  // The first well of the visiting order not done yet (where the stage is going), or null.
  nextWell() {
    return this.visits.find((w) => !this.wells.get(w)?.classList.contains("done")) ?? null;
  }

  select(name) {
    if (this.selected) this.wells.get(this.selected)?.classList.remove("selected");
    this.selected = name;
    this.wells.get(name)?.classList.add("selected");
    this.onSelect(name);
  }

  counts() {
    let done = 0;
    for (const c of this.wells.values()) if (c.classList.contains("done")) done += 1;
    return { done, total: this.inJob.size };
  }
}
