// Labelled inputs for the job forms, each named by the request field it fills ("spec.a1.X"), so that
// a 422 problem+json's `field` lands next to the input it names. Values are read back as the spec
// wants them: an empty input is left out (the gateway's default applies).

import { el } from "./dom.js";

// A value the page itself refuses before sending (named like the gateway's field).
export class FieldError extends Error {
  constructor(field, message) {
    super(message);
    this.field = field;
  }
}

export class Fields {
  constructor() {
    this.inputs = new Map();  // field -> {input, wrap, error}
    this.onChange = () => {};
  }

  // The labelled wrapper of an input, registered under its field.
  add(field, label, input, hint) {
    input.name = field;
    input.id = `f-${field.replace(/[^a-zA-Z0-9]+/g, "-")}`;
    const error = el("div", { class: "field-error", role: "alert" });
    const wrap = el("div", { class: "field", "data-field": field },
                    el("label", { for: input.id }, label), input,
                    hint ? el("div", { class: "hint" }, hint) : "", error);
    input.addEventListener("input", () => this.onChange());
    input.addEventListener("change", () => this.onChange());
    this.inputs.set(field, { input, wrap, error });
    return wrap;
  }

  number(field, label, { value, step = "any", min, max, placeholder, hint } = {}) {
    const input = el("input", { type: "number", step, value: value ?? "", min, max, placeholder });
    return this.add(field, label, input, hint);
  }

  text(field, label, { value = "", placeholder, hint } = {}) {
    return this.add(field, label, el("input", { type: "text", value, placeholder, spellcheck: false }), hint);
  }

  textarea(field, label, { value = "", rows = 4, placeholder, hint } = {}) {
    return this.add(field, label, el("textarea", { rows, placeholder, spellcheck: false, value }), hint);
  }

  // options: [[value, text], ...]
  select(field, label, options, { value, hint } = {}) {
    const input = el("select", {}, ...options.map(([v, t]) => el("option", { value: v, selected: v === value }, t)));
    return this.add(field, label, input, hint);
  }

  checkbox(field, label, { checked = false, hint } = {}) {
    const input = el("input", { type: "checkbox", checked });
    const wrap = this.add(field, label, input, hint);
    wrap.classList.add("checkbox");
    return wrap;
  }

  // A group of controls under one field (radio buttons): errors for the field land under it.
  group(field, label, content, hint) {
    const error = el("div", { class: "field-error", role: "alert" });
    const wrap = el("fieldset", { class: "field group", "data-field": field }, el("legend", {}, label), content,
                    hint ? el("div", { class: "hint" }, hint) : "", error);
    content.addEventListener("change", () => this.onChange());
    this.inputs.set(field, { input: content, wrap, error });
    return wrap;
  }

  input(field) {
    return this.inputs.get(field)?.input;
  }

  raw(field) {
    const i = this.input(field);
    if (!i || !("value" in i)) return "";
    return i.type === "checkbox" ? i.checked : i.value.trim();
  }

  // A number, or undefined when empty; refused when it is not a number (or not whole, integer: true).
  num(field, { integer = false, required = false } = {}) {
    const v = this.raw(field);
    if (v === "") {
      if (required) throw new FieldError(field, "needed");
      return undefined;
    }
    const n = Number(v);
    if (!Number.isFinite(n)) throw new FieldError(field, "not a number");
    if (integer && !Number.isInteger(n)) throw new FieldError(field, "a whole number, please");
    return n;
  }

  str(field) {
    const v = this.raw(field);
    return v === "" ? undefined : v;
  }

  clearErrors() {
    for (const { wrap, error, input } of this.inputs.values()) {
      error.textContent = "";
      wrap.classList.remove("invalid");
      input.removeAttribute("aria-invalid");
    }
  }

  // Shows the message next to the input the field names, or the nearest enclosing one
  // ("spec.positions[2].X" -> "spec.positions"); false when no input matches.
  showError(field, message) {
    for (let f = field; f; f = parentField(f)) {
      const entry = this.inputs.get(f);
      if (!entry || entry.wrap.closest("[hidden]")) continue;
      entry.error.textContent = message;
      entry.wrap.classList.add("invalid");
      entry.input.setAttribute("aria-invalid", "true");
      return true;
    }
    return false;
  }
}

// "spec.a1.X" -> "spec.a1"; "spec.positions[2]" -> "spec.positions"; "spec" -> "".
export function parentField(field) {
  const m = /^(.*?)(\[\d+\]|\.[^.[\]]+)$/.exec(field);
  return m ? m[1] : "";
}

// Sets path "a.b.c" of obj to value, unless value is undefined.
export function put(obj, path, value) {
  if (value === undefined) return obj;
  const keys = path.split(".");
  let o = obj;
  for (const k of keys.slice(0, -1)) o = o[k] ??= {};
  o[keys[keys.length - 1]] = value;
  return obj;
}

// A group of radio buttons: {root, value(), onChange(cb)}.
export function radios(name, options, value) {
  const inputs = [];
  const root = el("div", { class: "radios", role: "radiogroup" }, ...options.map(([v, text]) => {
    const input = el("input", { type: "radio", name, value: v, checked: v === value, id: `r-${name}-${v}` });
    inputs.push(input);
    return el("label", { for: input.id, class: "radio" }, input, text);
  }));
  return {
    root,
    inputs,
    value: () => inputs.find((i) => i.checked)?.value,
    onChange: (cb) => inputs.forEach((i) => i.addEventListener("change", cb)),
  };
}
