// The form that starts a position recording (operators; hidden for viewers): on a controller that has
// a report port, a name, the trigger input mode (TTL X=<mode> while it records, 1 by default) and
// optional limits (POST /api/v1/controllers/{id}/recordings). The gateway's refusals land next to the
// field they name; a started recording opens its view.

import * as api from "./api.js";
import { el, errorText } from "./dom.js";
import { FieldError, Fields, put } from "./job_form_fields.js";
import { navigate } from "./router.js";
import { store } from "./store.js";

const hasReportPort = (c) => Boolean(c.state?.report_port && c.state.report_port !== "none");

export class RecordingForm {
  constructor() {
    this.fields = new Fields();
    this.controller = el("select");
    this.submit = el("button", { type: "submit", class: "primary", id: "rec-start" }, "Start recording");
    this.error = el("div", { class: "form-error", role: "alert", id: "rec-start-error" });
    this.form = el("form", { class: "rec-start-form", noValidate: true },
                   el("div", { class: "form-row" },
                      this.fields.add("controller", "Controller", this.controller),
                      this.fields.text("name", "Name", { placeholder: "plate 7" }),
                      this.fields.number("arm.ttl_in_mode", "Trigger input mode", { value: 1, step: 1, hint: "TTL X= while it records" }),
                      this.fields.number("max_frames", "Stop after frames", { step: 1, placeholder: "no limit" }),
                      this.fields.number("max_s", "Stop after seconds", { placeholder: "no limit" }),
                      this.submit));
    this.form.addEventListener("submit", (ev) => {
      ev.preventDefault();
      this.start();
    });
    this.fields.onChange = () => {
      this.fields.clearErrors();
      this.error.textContent = "";
    };
    this.root = el("section", { class: "card rec-start", "data-needs": "operator" },
                   el("h3", {}, "Start a recording ",
                      el("span", { class: "meta" }, "the stage position at every trigger on the report port")),
                   this.error, this.form);
    this.fill();
    this.stops = [store.on("controllers", () => this.fill()),
                  store.on("controller", ({ what }) => what === "state" && this.fill())];
  }

  stop() {
    for (const s of this.stops) s();
  }

  // The controllers with a report port (only those can record); refilled when that changes.
  fill() {
    const ids = [...store.controllers.values()].filter(hasReportPort).map((c) => c.id).sort();
    const key = ids.join(",");
    if (key === this.filled) return;
    this.filled = key;
    const chosen = this.controller.value;
    this.controller.replaceChildren(...ids.map((id) => el("option", { value: id, selected: id === chosen }, id)));
    this.submit.disabled = ids.length === 0;
    this.submit.title = ids.length ? "" : "no controller has a report port";
  }

  // The RecordingRequest, or a FieldError for what the page can tell is wrong.
  body() {
    const f = this.fields;
    const name = f.str("name");
    if (!name) throw new FieldError("name", "needed");
    const body = { name };
    put(body, "arm.ttl_in_mode", f.num("arm.ttl_in_mode", { integer: true }));
    put(body, "max_frames", f.num("max_frames", { integer: true }));
    put(body, "max_s", f.num("max_s"));
    return body;
  }

  async start() {
    this.fields.clearErrors();
    this.error.textContent = "";
    const controller = this.controller.value;
    if (!controller) {
      this.error.textContent = "No controller with a report port to record on.";
      return;
    }
    this.submit.disabled = true;
    try {
      const rec = await api.startRecording(controller, this.body());
      navigate(`/recordings/${encodeURIComponent(rec.id)}`);
    } catch (e) {
      this.showError(e);
    } finally {
      this.submit.disabled = !this.filled;
    }
  }

  // Next to the input the field names ("arm.ttl_in_mode"); above the form when none does.
  showError(e) {
    if (e.field && this.fields.showError(e.field, e.message)) {
      this.error.textContent = "Please check the field marked below.";
      this.fields.input(e.field)?.focus();
      return;
    }
    this.error.textContent = e instanceof FieldError ? `${e.field}: ${e.message}` : `Could not start: ${errorText(e)}`;
  }
}
