// The motion controls of the controller view, for the axes the controller has: a jog pad (step sizes
// 1 um to 10 mm; X/Y as a cross, other axes as +/- pairs), go-to (absolute um), home, zero, here (set
// the current position) and speed (mm/s). Every control needs the operator role; errors show next to
// the control that caused them.

import * as api from "./api.js";
import { actionButton, axisValues, controlGroup, labelled, numberInput } from "./controls.js";
import { el } from "./dom.js";

const STEPS_UM = [1, 10, 100, 1000, 10000];
const DEFAULT_STEP_UM = 100;

const stepLabel = (um) => (um >= 1000 ? `${um / 1000} mm` : `${um} µm`);

function needAxes(values, what) {
  if (!values) throw new Error(`enter a value for at least one axis to ${what}`);
  return values;
}

export class MotionControls {
  constructor(id) {
    this.id = id;
    this.axesKey = null;
    this.stepUm = DEFAULT_STEP_UM;
    this.root = el("div", { class: "motion-controls" });
  }

  // Rebuilt only when the controller's axes change (a state event repeats them).
  setAxes(axes) {
    const letters = axes.map((a) => a.axis);
    const key = letters.join("");
    if (key === this.axesKey) return;
    this.axesKey = key;
    this.root.replaceChildren(this.jogPad(letters), this.goTo(letters), this.homeZeroHere(letters),
                              this.speed(letters));
  }

  // The go-to fields show the current position as their placeholder.
  setPositions(axes) {
    for (const a of axes) {
      const input = this.gotoInputs?.get(a.axis);
      if (input && typeof a.position_um === "number") input.placeholder = a.position_um.toFixed(1);
    }
  }

  jogPad(letters) {
    const g = controlGroup("Jog", { name: "jog" });
    const steps = el("div", { class: "steps", role: "radiogroup", "aria-label": "jog step" });
    for (const um of STEPS_UM) {
      const b = el("button", { type: "button", class: "step", "data-step": String(um), "aria-pressed": String(um === this.stepUm) },
                   stepLabel(um));
      b.addEventListener("click", () => {
        this.stepUm = um;
        for (const s of steps.children) s.setAttribute("aria-pressed", String(s === b));
      });
      steps.append(b);
    }
    const jog = (axis, sign) => actionButton(`${axis}${sign < 0 ? "−" : "+"}`, g.error,
                                             () => api.moveRelative(this.id, { [axis]: sign * this.stepUm }),
                                             { name: `jog-${axis}${sign < 0 ? "-" : "+"}`, className: "jog-button" });
    const pad = el("div", { class: "jog-pad" });
    const rest = [...letters];
    if (letters.includes("X") && letters.includes("Y")) {
      rest.splice(rest.indexOf("X"), 1);
      rest.splice(rest.indexOf("Y"), 1);
      const cross = el("div", { class: "jog-cross" },
                       el("span"), jog("Y", 1), el("span"),
                       jog("X", -1), el("span", { class: "jog-centre" }, "XY"), jog("X", 1),
                       el("span"), jog("Y", -1), el("span"));
      pad.append(cross);
    }
    for (const axis of rest) pad.append(el("div", { class: "jog-column" }, jog(axis, 1), el("span", { class: "jog-centre" }, axis), jog(axis, -1)));
    for (const b of pad.querySelectorAll("button")) b.dataset.jog = b.dataset.action.slice(4);
    g.body.append(steps, pad);
    return g.root;
  }

  goTo(letters) {
    const g = controlGroup("Go to (µm)", { name: "goto" });
    this.gotoInputs = new Map(letters.map((a) => [a, numberInput({ name: `goto-${a}`, size: "wide" })]));
    const go = actionButton("Go", g.error, () => api.moveAbsolute(this.id, needAxes(axisValues(this.gotoInputs), "move")),
                            { name: "goto", className: "primary" });
    g.body.append(el("div", { class: "axis-fields" }, ...[...this.gotoInputs].map(([a, input]) => labelled(a, input)), go));
    return g.root;
  }

  homeZeroHere(letters) {
    const g = controlGroup("Home, zero, here", { name: "origin" });
    const home = actionButton("Home all", g.error, () => api.operation(this.id, "home"),
                              { name: "home", title: "drive every axis to its home position (! X Y ...)" });
    const zero = actionButton("Zero all", g.error, () => api.operation(this.id, "zero"),
                              { name: "zero", title: "the current position of every axis becomes 0 (Z)" });
    const hereInputs = new Map(letters.map((a) => [a, numberInput({ name: `here-${a}`, size: "wide" })]));
    const here = actionButton("Set here", g.error,
                              () => api.operation(this.id, "here", { axes: needAxes(axisValues(hereInputs), "set") }),
                              { name: "here", title: "call the current position of these axes this value (H X=..)" });
    g.body.append(el("div", { class: "row" }, home, zero),
                  el("div", { class: "axis-fields" }, ...[...hereInputs].map(([a, input]) => labelled(a, input)), here));
    return g.root;
  }

  speed(letters) {
    const g = controlGroup("Speed (mm/s)", { name: "speed" });
    const inputs = new Map(letters.map((a) => [a, numberInput({ name: `speed-${a}`, min: 0.001, max: 50, placeholder: "mm/s" })]));
    const set = actionButton("Set speed", g.error, () => api.operation(this.id, "speed", { axes: needAxes(axisValues(inputs), "set") }),
                             { name: "speed" });
    g.body.append(el("div", { class: "axis-fields" }, ...[...inputs].map(([a, input]) => labelled(a, input)), set));
    return g.root;
  }
}
