// The audit view (#/audit, admin): the gateway's audit trail (GET /api/v1/audit), newest first: who
// changed what, when, over which transport and from where, and how it ended. Filters by controller
// and by principal; "Older" pages back; "Refresh" reads the newest again.

import * as api from "./api.js";
import { el, errorText } from "./dom.js";

const PAGE = 50;

function row(e) {
  const target = [e.controller, e.target].filter(Boolean).join(" ");
  return el("tr", { class: e.status >= 400 ? "refused" : "", "data-id": String(e.id) },
    el("td", {}, e.time.replace("T", " ").replace("Z", "")),
    el("td", {}, `${e.principal} (${e.role})`),
    el("td", {}, e.address ? `${e.transport} ${e.address}` : e.transport),
    el("td", { class: "action" }, e.action),
    el("td", {}, target || "–"),
    el("td", { class: "outcome" }, e.status >= 400 ? `${e.status} ${e.outcome}` : e.outcome),
    el("td", { class: "detail" }, JSON.stringify(e.detail)));
}

export function mount(container) {
  const controller = el("input", { id: "audit-controller", placeholder: "controller", size: 10 });
  const principal = el("input", { id: "audit-principal", placeholder: "who", size: 10 });
  const body = el("tbody", { id: "audit-rows" });
  const status = el("p", { id: "audit-status", class: "muted" });
  const older = el("button", { id: "audit-older", type: "button", hidden: true }, "Older");
  let before = null;

  async function load(append) {
    const q = new URLSearchParams({ limit: String(PAGE) });
    if (controller.value.trim()) q.set("controller", controller.value.trim());
    if (principal.value.trim()) q.set("principal", principal.value.trim());
    if (append && before !== null) q.set("before", String(before));
    try {
      const page = await api.request("GET", `/api/v1/audit?${q}`);
      if (!append) body.replaceChildren();
      for (const e of page.entries) body.append(row(e));
      before = page.next_before;
      older.hidden = before === null;
      status.textContent = body.children.length ? "" : "No entries.";
    } catch (e) {
      status.textContent = e.status === 403 ? "The audit trail is for admins." : `Audit trail: ${errorText(e)}`;
    }
  }

  const refresh = el("button", { id: "audit-refresh", type: "button" }, "Refresh");
  refresh.addEventListener("click", () => load(false));
  older.addEventListener("click", () => load(true));
  for (const input of [controller, principal]) input.addEventListener("change", () => load(false));

  container.append(
    el("h2", {}, "Audit trail"),
    el("div", { class: "toolbar" }, controller, principal, refresh),
    el("table", { class: "audit" },
      el("thead", {}, el("tr", {}, ...["time (UTC)", "who", "via", "action", "on", "outcome", "arguments"]
        .map((h) => el("th", {}, h)))),
      body),
    status, older);
  load(false);
  return () => {};
}
