// The four job forms (array, scan, ring buffer, G-code): each builds its inputs with Fields, named by
// the spec fields of openapi.yaml (ArraySpec, ScanSpec, RingBufferSpec, GcodeJobSpec), and reads them
// back as a spec. create(fields, context) -> {root, spec()}; context: {position(), gcodeFiles()}.

import { el, formatUm } from "./dom.js";
import { FieldError, put, radios } from "./job_form_fields.js";

const MODES = [["auto", "auto (firmware module when it fits)"], ["firmware", "firmware module"], ["host", "host (step by step)"]];
const PLATES = ["6", "12", "24", "48", "96", "384"];

const section = (title, ...children) => el("div", { class: "form-section" }, el("h4", {}, title), ...children);
const row = (...children) => el("div", { class: "form-row" }, ...children);

export const arrayForm = {
  type: "array",
  label: "Array (plate)",
  create(f, context) {
    const layout = radios("layout", [["plate", "plate preset"], ["grid", "grid"]], "plate");
    const a1 = radios("a1", [["given", "given position"], ["current", "current position at start"]], "given");
    const plate = row(f.select("spec.plate", "Plate", PLATES.map((p) => [p, `${p} wells`]), { value: "96" }));
    const grid = row(f.number("spec.grid.columns", "Columns", { value: 3, step: 1, min: 1 }),
                     f.number("spec.grid.rows", "Rows", { value: 2, step: 1, min: 1 }),
                     f.number("spec.grid.column_step_mm", "Column step (mm)", { value: 0.5 }),
                     f.number("spec.grid.row_step_mm", "Row step (mm)", { value: -0.5, hint: "negative: rows go to −Y" }));
    const here = el("button", { type: "button", class: "small" }, "use the stage position");
    here.addEventListener("click", () => {
      const p = context.position();
      if (!p) return;
      f.input("spec.a1.X").value = formatUm(p.X);
      f.input("spec.a1.Y").value = formatUm(p.Y);
      f.onChange();
    });
    const a1Given = row(f.number("spec.a1.X", "A1 X (µm)", { value: 0 }), f.number("spec.a1.Y", "A1 Y (µm)", { value: 0 }), here);
    const sync = () => {
      plate.hidden = layout.value() !== "plate";
      grid.hidden = layout.value() !== "grid";
      a1Given.hidden = a1.value() !== "given";
    };
    layout.onChange(sync);
    a1.onChange(sync);
    sync();
    const root = el("div", {},
                    section("Wells", f.group("spec.layout", "Layout", layout.root), plate, grid,
                            row(f.text("spec.wells", "Only these wells", { placeholder: "every well (or A1, B2, C3)" }),
                                f.number("spec.rotation_deg", "Rotation (°)", { placeholder: "0", hint: "host path only" }))),
                    section("A1", f.group("spec.a1", "Where A1 is", a1.root), a1Given),
                    section("Run",
                            row(f.select("spec.order", "Order", [["serpentine", "serpentine"], ["raster", "raster (host path)"]], { value: "serpentine" }),
                                f.select("spec.advance", "Advance", [["timer", "after the dwell"], ["ttl", "on a TTL input"], ["next", "on Next"]], { value: "timer" }),
                                f.number("spec.dwell_ms", "Dwell (ms)", { value: 100, step: 1, min: 0 })),
                            row(f.checkbox("spec.ttl_pulse", "TTL pulse on arrival"),
                                f.select("spec.mode", "Mode", MODES, { value: "auto" }))));
    return {
      root,
      spec() {
        const spec = {};
        if (layout.value() === "plate") spec.plate = f.raw("spec.plate");
        else {
          spec.grid = {};
          put(spec, "grid.columns", f.num("spec.grid.columns", { integer: true, required: true }));
          put(spec, "grid.rows", f.num("spec.grid.rows", { integer: true, required: true }));
          put(spec, "grid.column_step_mm", f.num("spec.grid.column_step_mm", { required: true }));
          put(spec, "grid.row_step_mm", f.num("spec.grid.row_step_mm", { required: true }));
        }
        if (a1.value() === "current") spec.a1 = "current";
        else spec.a1 = { X: f.num("spec.a1.X", { required: true }), Y: f.num("spec.a1.Y", { required: true }) };
        const wells = f.str("spec.wells");
        if (wells) spec.wells = wells.split(/[\s,;]+/).filter(Boolean).map((w) => w.toUpperCase());
        put(spec, "rotation_deg", f.num("spec.rotation_deg"));
        spec.order = f.raw("spec.order");
        spec.advance = f.raw("spec.advance");
        put(spec, "dwell_ms", f.num("spec.dwell_ms", { integer: true }));
        if (f.raw("spec.ttl_pulse")) spec.ttl_pulse = true;
        spec.mode = f.raw("spec.mode");
        return spec;
      },
    };
  },
};

export const scanForm = {
  type: "scan",
  label: "Scan",
  create(f) {
    const axes = [["X", "X"], ["Y", "Y"], ["Z", "Z"]];
    const root = el("div", {},
                    section("Axes", row(f.select("spec.fast_axis", "Fast axis", axes, { value: "X" }),
                                        f.select("spec.slow_axis", "Slow axis", axes, { value: "Y" }),
                                        f.select("spec.pattern", "Pattern", [["raster", "raster"], ["serpentine", "serpentine"]], { value: "raster" }))),
                    section("Fast axis (a line)",
                            row(f.number("spec.fast.start_mm", "Start (mm)", { value: 0 }),
                                f.number("spec.fast.stop_mm", "Stop (mm)", { value: 1, hint: "or give pixels" }),
                                f.number("spec.fast.pixels", "Pixels", { step: 1, min: 1 }),
                                f.number("spec.fast.encoder_divide", "Encoder divide", { value: 24, step: 1, min: 1 }))),
                    section("Slow axis (lines)",
                            row(f.number("spec.slow.start_mm", "Start (mm)", { value: 0 }),
                                f.number("spec.slow.stop_mm", "Stop (mm)", { value: 0.04 }),
                                f.number("spec.slow.lines", "Lines", { value: 5, step: 1, min: 1 }))),
                    section("Run", row(f.number("spec.speed_mm_s", "Speed (mm/s)", { value: 0.5 }),
                                       f.select("spec.mode", "Mode", MODES, { value: "auto" }))));
    return {
      root,
      spec() {
        const spec = { fast_axis: f.raw("spec.fast_axis"), slow_axis: f.raw("spec.slow_axis"), fast: {}, slow: {} };
        for (const k of ["start_mm", "stop_mm"]) put(spec, `fast.${k}`, f.num(`spec.fast.${k}`));
        for (const k of ["pixels", "encoder_divide"]) put(spec, `fast.${k}`, f.num(`spec.fast.${k}`, { integer: true }));
        for (const k of ["start_mm", "stop_mm"]) put(spec, `slow.${k}`, f.num(`spec.slow.${k}`));
        put(spec, "slow.lines", f.num("spec.slow.lines", { integer: true, required: true }));
        spec.pattern = f.raw("spec.pattern");
        put(spec, "speed_mm_s", f.num("spec.speed_mm_s"));
        spec.mode = f.raw("spec.mode");
        return spec;
      },
    };
  },
};

// "X=0 Y=0" per line (or "0, 0": X and Y) -> [{X: 0, Y: 0}, ...]
export function parsePositions(text, field = "spec.positions") {
  const lines = text.split("\n").map((l) => l.trim()).filter(Boolean);
  if (!lines.length) throw new FieldError(field, "one position per line, such as X=0 Y=0");
  return lines.map((line, i) => {
    const named = [...line.matchAll(/([A-Za-z])\s*[=:]\s*(-?[\d.]+(?:e-?\d+)?)/g)];
    const p = {};
    if (named.length) for (const [, axis, v] of named) p[axis.toUpperCase()] = Number(v);
    else line.split(/[\s,;]+/).forEach((v, k) => { p["XYZ"[k] ?? `?${k}`] = Number(v); });
    if (!Object.keys(p).length || Object.entries(p).some(([a, v]) => !/^[A-Z]$/.test(a) || !Number.isFinite(v))) {
      throw new FieldError(field, `line ${i + 1}: "${line}" is not a position (X=0 Y=0)`);
    }
    return p;
  });
}

export const ringBufferForm = {
  type: "ring_buffer",
  label: "Ring buffer",
  create(f) {
    const root = el("div", {},
                    section("Positions (µm)", f.textarea("spec.positions", "One per line", {
                      value: "X=0 Y=0\nX=1000 Y=500\nX=2000 Y=0", rows: 6, hint: "X=1000 Y=500, or 1000, 500" }),
                            row(f.text("spec.axes", "Axes", { placeholder: "those named" }))),
                    section("Tour", row(f.select("spec.trigger", "Trigger", [["autoplay", "autoplay"], ["ttl", "TTL input"], ["next", "Next"]], { value: "autoplay" }),
                                        f.number("spec.delay_ms", "Delay (ms)", { value: 100, step: 1, min: 0 }),
                                        f.checkbox("spec.repeat", "Repeat"),
                                        f.number("spec.cycles", "Cycles", { step: 1, min: 0, placeholder: "1", hint: "with repeat; 0: until cancelled" }),
                                        f.select("spec.mode", "Mode", MODES, { value: "auto" }))));
    return {
      root,
      spec() {
        const spec = { positions: parsePositions(f.raw("spec.positions")) };
        const axes = f.str("spec.axes");
        if (axes) spec.axes = axes.toUpperCase();
        spec.trigger = f.raw("spec.trigger");
        put(spec, "delay_ms", f.num("spec.delay_ms", { integer: true }));
        if (f.raw("spec.repeat")) spec.repeat = true;
        put(spec, "cycles", f.num("spec.cycles", { integer: true }));
        spec.mode = f.raw("spec.mode");
        return spec;
      },
    };
  },
};

export const gcodeForm = {
  type: "gcode",
  label: "G-code",
  create(f, context) {
    const files = context.gcodeFiles();
    const options = files.map((g) => [g.id, `${g.name} (${g.lines} lines, ${g.id})`]);
    const root = el("div", {},
                    section("Program", options.length
                      ? f.select("spec.file", "Uploaded file", options, { value: options[0][0] })
                      : f.select("spec.file", "Uploaded file", [["", "no file uploaded yet"]]),
                            el("p", { class: "hint" }, "Upload or paste a program in the ", el("a", { href: "#/gcode" }, "G-code view"), "."),
                            row(f.number("spec.options.arc_tolerance_mm", "Arc tolerance (mm)", { placeholder: "default" }))));
    return {
      root,
      spec() {
        const file = f.str("spec.file");
        if (!file) throw new FieldError("spec.file", "choose an uploaded program");
        const spec = { file };
        put(spec, "options.arc_tolerance_mm", f.num("spec.options.arc_tolerance_mm"));
        return spec;
      },
    };
  },
};

export const JOB_FORMS = [arrayForm, scanForm, ringBufferForm, gcodeForm];
