// Placeholder until the view is written (issue 14): says so instead of failing to load.
import { el } from "./dom.js";

export function mount(container) {
  container.append(el("p", { class: "not-found" }, "This view is not written yet."));
}
