// A new job (#/jobs/new): a form per job type (job_form_types.js), a dry run shown before submitting
// (POST /api/v1/jobs?dry_run=true: the estimate, the firmware or host path, the warnings, and the
// bounding box and planned path on the XY map with the controller's soft limits and position), the
// gateway's validation errors next to the field they name, then Submit (201) opens the job. Any type
// may record its run (spec.record).

import * as api from "./api.js";
import { el, errorText, formatDuration } from "./dom.js";
import { Fields, FieldError } from "./job_form_fields.js";
import { JOB_FORMS } from "./job_form_types.js";
import { navigate } from "./router.js";
import { store } from "./store.js";
import { XYPlot } from "./xy_plot.js";

export function mount(container) {
  const view = new NewJob();
  container.append(view.root);
  view.start();
  return () => view.stop();
}

// {X, Y} of a controller's position as the store has it, or null.
function positionOf(id) {
  const axes = store.controllers.get(id)?.position?.axes || [];
  const at = (axis) => axes.find((a) => a.axis === axis)?.position_um;
  return typeof at("X") === "number" && typeof at("Y") === "number" ? { X: at("X"), Y: at("Y") } : null;
}

class NewJob {
  constructor() {
    this.fields = new Fields();
    this.fields.onChange = () => this.invalidate();
    this.form = null;  // the chosen type's {root, spec()}
    this.type = JOB_FORMS[0];
    this.planned = null;  // the request body of the last successful dry run
    this.gcodeFiles = [];
    this.build();
  }

  build() {
    this.tabs = el("div", { class: "tabs", role: "tablist" }, ...JOB_FORMS.map((t) => {
      const b = el("button", { type: "button", role: "tab", "data-type": t.type }, t.label);
      b.addEventListener("click", () => this.choose(t));
      return b;
    }));
    const ids = [...store.controllers.keys()].sort();
    this.controllerWrap = this.fields.select("controller", "Controller", ids.map((id) => [id, id]), { value: ids[0] });
    this.fields.input("controller").addEventListener("change", () => this.showController());
    this.modules = el("div", { class: "hint modules" });
    this.typeHost = el("div", { class: "type-form" });
    this.topError = el("div", { class: "error form-error", role: "alert" });
    this.dryRunButton = el("button", { type: "submit", id: "dry-run" }, "Dry run");
    this.submitButton = el("button", { type: "button", id: "submit-job", class: "primary", disabled: true }, "Submit job");
    this.submitButton.addEventListener("click", () => this.submit());
    this.status = el("span", { class: "meta form-status" });
    this.formEl = el("form", { class: "card job-form", id: "job-form", noValidate: true },
                     this.tabs, this.topError, this.controllerWrap, this.modules, this.typeHost,
                     el("div", { class: "form-actions" }, this.dryRunButton, this.submitButton, this.status));
    this.formEl.addEventListener("submit", (ev) => {
      ev.preventDefault();
      this.dryRun();
    });
    this.plot = new XYPlot({ title: "Dry run" });
    this.planView = el("div", { class: "plan", id: "plan" });
    this.planHint = el("p", { class: "meta" }, "A dry run shows the plan here before anything moves.");
    this.zoom = el("button", { type: "button", class: "small", hidden: true }, "zoom to the job");
    this.zoom.addEventListener("click", () => this.toggleZoom());
    this.root = el("section", { class: "job-new", "data-needs": "operator" },
                   el("p", { class: "crumbs" }, el("a", { href: "#/jobs" }, "← Jobs")),
                   el("div", { class: "page-head" }, el("h2", {}, "New job")),
                   el("div", { class: "new-job-grid" }, this.formEl,
                      el("aside", { class: "card dry-run" }, el("h3", {}, "Dry run"), this.planHint, this.planView,
                         this.plot.root, this.zoom)));
  }

  async start() {
    this.choose(this.type);
    this.showController();
    this.stopStore = store.on("controller", ({ id, what }) => {
      if (id !== this.controllerId()) return;
      if (what === "position" || what === "state") this.showPosition();
      if (what === "state") this.showLimits();
    });
    try {
      this.gcodeFiles = (await api.request("GET", "/api/v1/gcode/files")).files || [];
      if (this.type.type === "gcode") this.choose(this.type);
    } catch (e) {
      this.gcodeError = errorText(e);
    }
  }

  stop() {
    this.stopStore?.();
  }

  controllerId() {
    return this.fields.raw("controller");
  }

  choose(type) {
    this.type = type;
    for (const b of this.tabs.children) b.setAttribute("aria-selected", String(b.dataset.type === type.type));
    for (const field of [...this.fields.inputs.keys()]) if (field.startsWith("spec.")) this.fields.inputs.delete(field);
    this.form = type.create(this.fields, {
      position: () => positionOf(this.controllerId()),
      gcodeFiles: () => this.gcodeFiles,
    });
    // Every type of this form can record its run (spec.record): the frames of the report port.
    const record = this.fields.checkbox("spec.record", "Record each trigger's stage position (needs a report port)");
    this.typeHost.replaceChildren(this.form.root, record);
    this.formEl.dataset.type = type.type;
    this.invalidate();
    this.clearPlan();
  }

  // Another job type: the plan shown belongs to the previous one.
  clearPlan() {
    this.planView.replaceChildren();
    this.planHint.hidden = false;
    this.plot.removeOverlay("plan");
    this.plot.removeOverlay("bbox");
    this.zoom.hidden = true;
    this.status.textContent = "";
    if (this.zoomed) this.toggleZoom();
  }

  showController() {
    const s = store.controllers.get(this.controllerId())?.state;
    const modules = s?.identity?.modules;
    this.modules.textContent = s
      ? `${s.state}${s.identity ? ` · build ${s.identity.build} · modules: ${modules.length ? modules.join(", ") : "none (host path only)"}` : ""}`
      : "";
    this.plot.clearTrail();
    this.showLimits();
    this.showPosition();
    this.invalidate();
  }

  showLimits() {
    const axes = store.controllers.get(this.controllerId())?.state?.axes || [];
    const limits = Object.fromEntries(axes.map((a) => [a.axis, a.soft_limits_um]));
    this.limits = limits;
    if (!this.zoomed) this.plot.setLimits(limits);
  }

  showPosition() {
    const p = positionOf(this.controllerId());
    if (p) this.plot.setPosition(p.X, p.Y);
  }

  // The bounding box is under 3 % of the soft limits' span on both axes.
  tiny(bounds) {
    const span = (axis) => {
      const l = this.limits?.[axis];
      return l && typeof l.lower === "number" && typeof l.upper === "number" ? l.upper - l.lower : null;
    };
    return ["X", "Y"].every((a) => span(a) && bounds.max[a] - bounds.min[a] < 0.03 * span(a));
  }

  toggleZoom() {
    this.zoomed = !this.zoomed;
    this.plot.setLimits(this.zoomed ? null : this.limits);
    this.zoom.textContent = this.zoomed ? "show the whole stage" : "zoom to the job";
  }

  // The form changed: the plan shown no longer describes it.
  invalidate() {
    this.fields.clearErrors();
    this.topError.textContent = "";
    this.submitButton.disabled = true;
    if (this.planned) {
      this.planned = null;
      this.planView.classList.add("stale");
      this.status.textContent = "The form changed: dry run again before submitting.";
    }
  }

  // The request body, or null (with the errors shown) when the page can tell it is wrong.
  body() {
    this.fields.clearErrors();
    this.topError.textContent = "";
    try {
      const spec = this.form.spec();
      if (this.fields.raw("spec.record")) spec.record = true;
      return { controller: this.controllerId(), type: this.type.type, spec };
    } catch (e) {
      if (!(e instanceof FieldError)) throw e;
      this.showError(e.field, e.message);
      return null;
    }
  }

  // Next to the input the field names; at the top of the form when none does.
  showError(field, message) {
    if (field && this.fields.showError(field, message)) {
      this.topError.textContent = "Please check the field marked below.";
      this.fields.inputs.get(field)?.input?.focus?.();
      return;
    }
    this.topError.textContent = field ? `${field}: ${message}` : message;
  }

  showProblem(what, e) {
    this.status.textContent = "";
    if (e.status === 422 || e.field) return this.showError(e.field, e.message);
    this.topError.textContent = `${what}: ${errorText(e)}`;
  }

  async dryRun() {
    const body = this.body();
    if (!body) return;
    this.status.textContent = "planning…";
    this.dryRunButton.disabled = true;
    try {
      const answer = await api.submitJob(body, true);
      this.planned = JSON.stringify(body);
      this.showPlan(answer.plan);
      this.submitButton.disabled = false;
      this.status.textContent = "Planned: check the plan, then submit.";
    } catch (e) {
      this.showProblem("Dry run", e);
    } finally {
      this.dryRunButton.disabled = false;
    }
  }

  showPlan(plan) {
    this.planHint.hidden = true;
    this.planView.classList.remove("stale");
    const fact = (label, value, cls) => el("div", { class: cls }, el("dt", {}, label), el("dd", {}, ...[value].flat()));
    const bounds = plan.bounds;
    const range = (axis) => `${axis} ${bounds.min[axis].toFixed(0)} … ${bounds.max[axis].toFixed(0)} µm`;
    const box = bounds && typeof bounds.min.X === "number" && typeof bounds.min.Y === "number"
      ? [range("X"), el("br"), range("Y")] : "–";
    this.planView.replaceChildren(
      el("p", { class: "plan-summary" }, plan.summary),
      el("dl", { class: "plan-facts" },
         fact("Estimated time", formatDuration(plan.estimated_s), "plan-estimate"),
         fact("Path", el("span", { class: `path-badge ${plan.path}` }, plan.path), "plan-path"),
         fact("Steps", String(plan.steps_total)),
         fact("Bounding box", box, "plan-bounds")),
      plan.warnings.length
        ? el("ul", { class: "warnings" }, ...plan.warnings.map((w) => el("li", {}, w)))
        : el("p", { class: "meta" }, "No warnings."),
      el("details", { class: "commands" },
         el("summary", {}, `Serial commands (${plan.commands.length}${plan.commands_omitted ? ` of ${plan.commands.length + plan.commands_omitted}` : ""})`),
         el("pre", {}, plan.commands.join("\n"))));
    const targets = plan.steps.map((s) => s.target).filter((t) => t && typeof t.X === "number" && typeof t.Y === "number");
    if (targets.length) this.plot.setPath("plan", targets.map((t) => [t.X, t.Y]));
    else this.plot.removeOverlay("plan");
    if (box !== "–") this.plot.setBox("bbox", bounds.min, bounds.max);
    else this.plot.removeOverlay("bbox");
    this.zoom.hidden = false;
    // A job a few pixels wide on the whole stage's map: show the job (a click shows the stage again).
    if (box !== "–" && this.tiny(bounds) !== Boolean(this.zoomed)) this.toggleZoom();
  }

  async submit() {
    const body = this.body();
    if (!body) return;
    if (JSON.stringify(body) !== this.planned) {
      this.invalidate();
      return;
    }
    this.submitButton.disabled = true;
    this.status.textContent = "submitting…";
    try {
      const job = await api.submitJob(body);
      navigate(`/jobs/${encodeURIComponent(job.id)}`);
    } catch (e) {
      this.showProblem("Submit", e);
      this.submitButton.disabled = false;
    }
  }
}
