// Small DOM helpers shared by every view: no framework, just elements.

// el("button", {class: "halt", type: "button", "data-halt": id}, "HALT"): attributes named data-*,
// aria-* and for are set as attributes, "class" as the class name, the rest as properties; children
// are nodes or strings (text, never HTML).
export function el(tag, attrs = {}, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (v === undefined || v === null) continue;
    if (k === "class") e.className = v;
    else if (k.startsWith("data-") || k.startsWith("aria-") || k === "for") e.setAttribute(k, v);
    else e[k] = v;
  }
  for (const c of children) if (c !== null && c !== undefined && c !== false) e.append(c);
  return e;
}

// The same for SVG elements (every attribute set as an attribute).
export function svg(tag, attrs = {}, ...children) {
  const e = document.createElementNS("http://www.w3.org/2000/svg", tag);
  for (const [k, v] of Object.entries(attrs)) if (v !== undefined && v !== null) e.setAttribute(k, v);
  for (const c of children) if (c) e.append(c);
  return e;
}

export const $ = (id) => document.getElementById(id);

// A controller's connection state on its card or view: the badge, data-state, and greyed when offline.
export function showConnectionState(root, badge, state) {
  badge.textContent = state;
  badge.className = `state ${state}`;
  root.dataset.state = state;
  root.classList.toggle("offline", state !== "connected");
}

export const formatUm = (v) => (typeof v === "number" ? v.toFixed(1) : "–");

// "1 h 02 min", "3 min 05 s", "12.3 s": durations for people.
// A filter's <select> of controller ids: "every controller" first, the choice kept (even when its
// controller is gone from the list).
export function fillControllerFilter(select, controllerIds) {
  const chosen = select.value;
  const ids = [...controllerIds].sort();
  if (chosen && !ids.includes(chosen)) ids.push(chosen);
  select.replaceChildren(el("option", { value: "" }, "every controller"),
                         ...ids.map((id) => el("option", { value: id, selected: id === chosen }, id)));
}

export function formatDuration(seconds) {
  if (typeof seconds !== "number" || !Number.isFinite(seconds)) return "–";
  const s = Math.max(0, seconds);
  if (s < 60) return `${s.toFixed(1)} s`;
  const m = Math.floor(s / 60);
  if (m < 60) return `${m} min ${String(Math.floor(s % 60)).padStart(2, "0")} s`;
  return `${Math.floor(m / 60)} h ${String(m % 60).padStart(2, "0")} min`;
}

// The text of an error for a person: an ApiError's detail, or the message.
export const errorText = (e) => e?.message || String(e);

// "halted by ada at 14:02:11": a controller's halt latch (ControllerState.halted), or "" when none.
export function haltedText(halted) {
  if (!halted) return "";
  const at = new Date(halted.at);
  const time = Number.isNaN(at.getTime()) ? halted.at : at.toLocaleTimeString();
  return `HALTED by ${halted.by} at ${time}: its jobs wait until someone resumes or submits one`;
}
