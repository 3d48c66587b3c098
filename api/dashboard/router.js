// Hash routes (#/jobs/j-01...): the page never reloads, and a link or the back button lands on the
// same view. A view module exports mount(container, params) and returns the function that unmounts it
// (stops its timers and live topics).

import { el } from "./dom.js";

const routes = [];  // {pattern: RegExp, names: [..], load: () => import(...)}
let current = null;  // the unmount function of the view shown

// route("/jobs/:id", () => import("./job_view.js"))
export function route(path, load) {
  const names = [];
  const pattern = new RegExp(`^${path.replace(/:([a-z_]+)/g, (_, n) => {
    names.push(n);
    return "([^/]+)";
  })}$`);
  routes.push({ pattern, names, load });
}

export function navigate(path) {
  location.hash = `#${path}`;
}

export async function show(container) {
  const path = location.hash.replace(/^#/, "") || "/";
  for (const r of routes) {
    const m = r.pattern.exec(path);
    if (!m) continue;
    const params = Object.fromEntries(r.names.map((n, i) => [n, decodeURIComponent(m[i + 1])]));
    const view = await r.load();
    if (current) current();
    container.replaceChildren();
    current = view.mount(container, params) || null;
    document.body.dataset.view = path.split("/")[1] || "overview";
    for (const a of document.querySelectorAll("nav a[data-nav]")) {
      a.classList.toggle("active", (path.split("/")[1] || "") === a.dataset.nav);
    }
    return;
  }
  if (current) current();
  current = null;
  container.replaceChildren(el("p", { class: "not-found" }, `Nothing at ${path}. `,
                                el("a", { href: "#/" }, "Back to the controllers")));
}
