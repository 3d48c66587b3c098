// Small building blocks of the controller view's controls: a group with its own error line, a button
// that runs one API call (disabled while it runs, its error shown next to it), number inputs.

import { el, errorText } from "./dom.js";

// A titled group of controls with the line where their errors go. needs: the role it needs
// ("operator"); CSS hides it from lower roles.
export function controlGroup(title, { needs = "operator", name } = {}) {
  const error = el("div", { class: "op-error", role: "alert" });
  const body = el("div", { class: "control-body" });
  const root = el("section", { class: "control-group", "data-needs": needs, "data-control": name },
                  el("h3", {}, title), body, error);
  return { root, body, error };
}

// A button that runs action() and shows what went wrong in errorLine (the ApiError's detail: a 409
// 'leased' says who holds the controller). onDone(result) runs after a success.
export function actionButton(label, errorLine, action, { name, className, onDone, title } = {}) {
  const button = el("button", { type: "button", class: className, "data-action": name, title }, label);
  button.addEventListener("click", () => runAction(button, errorLine, action, onDone));
  return button;
}

export async function runAction(button, errorLine, action, onDone) {
  errorLine.textContent = "";
  button.disabled = true;
  try {
    const result = await action();
    onDone?.(result);
  } catch (e) {
    errorLine.textContent = problemText(e);
  } finally {
    button.disabled = false;
  }
}

// An error for the line next to a control: a 422 names the field it is about ("volts: must be ...").
export function problemText(e) {
  const text = errorText(e);
  return e?.field && !text.includes(e.field) ? `${e.field}: ${text}` : text;
}

// A number input; value() is the number typed, or null when it is empty.
export function numberInput({ name, min, max, step = "any", placeholder, value, title, size = "" } = {}) {
  const input = el("input", { type: "number", name, min, max, step, placeholder, title, value: value ?? "",
                              class: `num ${size}`.trim(), "data-input": name });
  return input;
}

export function numberValue(input) {
  if (input.value.trim() === "") return null;
  const v = Number(input.value);
  return Number.isFinite(v) ? v : null;
}

// {X: 12.5, ...} from a map axis -> input, leaving out the empty ones; null when all are empty.
export function axisValues(inputs) {
  const out = {};
  for (const [axis, input] of inputs) {
    const v = numberValue(input);
    if (v !== null) out[axis] = v;
  }
  return Object.keys(out).length ? out : null;
}

export const labelled = (text, control) => el("label", { class: "field" }, el("span", {}, text), control);
