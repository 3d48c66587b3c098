// The controls a controller's firmware allows: TTL IN0/OUT0 modes and the OUT0 level (every MS-2000
// has the TTL port), the DAC output in volts (dac_out module) and an LED channel's brightness in
// percent (led_dimmer module), CRISP and AUTOFOCUS (focus_controls.js). Nothing is shown for a module
// the build lacks. Ranges are the OpenAPI's (TtlRequest, DacRequest, LedRequest, CrispRequest).

import * as api from "./api.js";
import { actionButton, controlGroup, labelled, numberInput, numberValue } from "./controls.js";
import { el } from "./dom.js";
import { autofocusGroup, CrispControls } from "./focus_controls.js";

// IN0 modes the gateway accepts, with the names ASI's manual gives the ones we know the meaning of.
const IN0_MODES = [[0, "0 off"], [1, "1 next position (ring buffer)"], [2, "2 repeat relative move"],
                   [3, "3 autofocus"], [4, "4 Z-stack"], [5, "5 position report"], [6, "6 scan start"],
                   [7, "7 array next"], [8, "8"], [9, "9"], [10, "10"], [11, "11"], [12, "12"], [30, "30"]];
const OUT0_MODES = [[0, "0 low"], [1, "1 high"], [2, "2"], [9, "9"]];
const LED_CHANNELS = ["X", "Y", "Z", "F"];

function modeSelect(name, modes, current) {
  return el("select", { name, "data-input": name },
            ...modes.map(([v, label]) => el("option", { value: String(v), selected: v === current }, label)));
}

function needNumber(input, what) {
  const v = numberValue(input);
  if (v === null) throw new Error(`enter ${what}`);
  return v;
}

export class ModuleControls {
  constructor(id) {
    this.id = id;
    this.key = null;
    this.root = el("div", { class: "module-controls" });
  }

  // A ControllerState: rebuilt when the modules change; the TTL selects follow the state's modes.
  setState(s) {
    const modules = s.identity?.modules ?? null;
    const key = modules ? modules.join(",") : "";
    if (key !== this.key) {
      this.key = key;
      this.root.replaceChildren();
      if (modules) {
        this.root.append(this.ttl());
        if (modules.includes("dac_out")) this.root.append(this.dac());
        if (modules.includes("led_dimmer")) this.root.append(this.led());
        this.crisp = modules.includes("crisp") ? new CrispControls(this.id) : null;
        if (this.crisp) this.root.append(this.crisp.root);
        if (modules.includes("autofocus")) this.root.append(autofocusGroup(this.id));
      }
    }
    this.showTtl(s.ttl);
    this.crisp?.setState(s.crisp);
  }

  showTtl(ttl) {
    if (!this.ttlState) return;
    const modes = (v) => (v === null || v === undefined ? "unknown" : String(v));
    this.ttlState.textContent = `now: IN0 mode ${modes(ttl?.in0_mode)}, OUT0 mode ${modes(ttl?.out0_mode)}`;
    // Follow the controller, except a select the person changed and has not set yet.
    for (const [select, v] of [[this.in0Select, ttl?.in0_mode], [this.out0Select, ttl?.out0_mode]]) {
      if (typeof v === "number" && !select.dataset.edited) select.value = String(v);
    }
  }

  ttl() {
    const g = controlGroup("TTL", { name: "ttl" });
    this.in0Select = modeSelect("in0_mode", IN0_MODES, null);
    this.out0Select = modeSelect("out0_mode", OUT0_MODES, null);
    this.ttlState = el("div", { class: "meta live-value" });
    for (const select of [this.in0Select, this.out0Select]) {
      select.addEventListener("change", () => { select.dataset.edited = "yes"; });
    }
    const setModes = actionButton("Set modes", g.error, () => api.operation(this.id, "ttl", {
      in0_mode: Number(this.in0Select.value), out0_mode: Number(this.out0Select.value) }), {
      name: "ttl",
      onDone: () => {
        delete this.in0Select.dataset.edited;
        delete this.out0Select.dataset.edited;
      },
    });
    const level = (high) => actionButton(`OUT0 ${high ? "high" : "low"}`, g.error,
                                         () => api.operation(this.id, "ttl", { output_high: high }),
                                         { name: `ttl-${high ? "high" : "low"}` });
    g.body.append(el("div", { class: "row" }, labelled("IN0", this.in0Select), labelled("OUT0", this.out0Select), setModes),
                  el("div", { class: "row" }, level(true), level(false)), this.ttlState);
    return g.root;
  }

  dac() {
    const g = controlGroup("DAC output", { name: "dac" });
    const volts = numberInput({ name: "dac-volts", min: 0, max: 10, step: 0.01, placeholder: "0 – 10" });
    const done = el("span", { class: "meta", "data-last": "dac" });
    const set = actionButton("Set", g.error, () => api.operation(this.id, "dac", { volts: needNumber(volts, "volts (0 to 10)") }),
                             { name: "dac", onDone: () => { done.textContent = `set to ${volts.value} V`; } });
    g.body.append(el("div", { class: "row" }, labelled("volts", volts), set, done));
    return g.root;
  }

  led() {
    const g = controlGroup("LED", { name: "led" });
    const channel = el("select", { name: "led-channel", "data-input": "led-channel" },
                       ...LED_CHANNELS.map((c) => el("option", { value: c }, c)));
    const percent = numberInput({ name: "led-percent", min: 0, max: 99, step: 1, placeholder: "0 – 99" });
    const done = el("span", { class: "meta", "data-last": "led" });
    const set = actionButton("Set", g.error, () => api.operation(this.id, "led", {
      percent: needNumber(percent, "a percentage (0 to 99)"), channel: channel.value }),
    { name: "led", onDone: () => { done.textContent = `channel ${channel.value} set to ${percent.value} %`; } });
    g.body.append(el("div", { class: "row" }, labelled("channel", channel), labelled("percent", percent), set, done));
    return g.root;
  }
}
