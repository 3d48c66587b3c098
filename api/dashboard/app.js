// The dashboard: asks who it is (its role hides what it may not do), loads the controllers over REST,
// follows them live over the WebSocket (store.js), and shows the view the address names (router.js).
// Asks for a token when the gateway answers 401.

import * as api from "./api.js";
import { $ } from "./dom.js";
import { route, show } from "./router.js";
import { store } from "./store.js";

route("/", () => import("./overview_view.js"));
route("/controller/:id", () => import("./controller_view.js"));
route("/jobs", () => import("./jobs_view.js"));
route("/jobs/new", () => import("./job_forms.js"));  // before /jobs/:id, which would take "new"
route("/jobs/:id", () => import("./job_view.js"));
route("/gcode", () => import("./gcode_view.js"));
route("/audit", () => import("./audit_view.js"));
route("/recordings", () => import("./recordings_view.js"));
route("/recordings/:id", () => import("./recording_view.js"));
route("/fleet", () => import("./fleet_view.js"));

let started = false;

function setLive({ live, detail }) {
  document.body.classList.toggle("stale", !live);
  document.body.dataset.live = live ? "yes" : "no";
  const status = $("live-status");
  status.textContent = live ? "live" : "not live";
  status.className = `live-status ${live ? "live" : "down"}`;
  const banner = $("banner");
  banner.hidden = live;
  banner.textContent = live ? "" : `Live updates stopped: ${detail}. Values shown are not live.`;
}

function askForToken(message) {
  $("token-form").hidden = false;
  $("token-error").textContent = message || "";
  $("token-input").focus();
}

// The role decides what is shown: body[data-role] and [data-needs=operator|admin] in style.css.
async function learnRole() {
  try {
    const me = await api.whoami();
    document.body.dataset.role = me.role;
    $("whoami").textContent = me.auth === "none" ? "" : `${me.client} (${me.role})`;
  } catch (e) {
    if (e.status === 401) throw e;
    document.body.dataset.role = "unknown";  // an older gateway: show everything, it refuses what it must
  }
}

async function start() {
  let list;
  try {
    await learnRole();
    list = (await api.listControllers()).controllers;
  } catch (e) {
    if (e.status === 401) return askForToken(api.token() ? "that token was refused" : "");
    setLive({ live: false, detail: `the gateway did not answer (${e.message})` });
    setTimeout(start, 2000);
    return;
  }
  $("token-form").hidden = true;
  for (const s of list) store.setState(s);
  store.refreshLeases();
  // A REST call tells a refused token (401: the token form) from a gateway that is down.
  store.start(() => api.listControllers().catch(() => {}));
  if (!started) {
    started = true;
    show($("view"));
  }
}

// One request halts every controller at once (POST /api/v1/halt); the answer says which it reached.
async function haltAll() {
  $("halt-all-error").textContent = "";
  try {
    const answer = await api.haltAll();
    const failed = answer.controllers.filter((c) => !c.halted)
      .map((c) => `${c.id}: ${c.problem?.detail || "not reached"}`);
    $("halt-all-error").textContent = failed.length ? `halt failed for ${failed.join("; ")}` : "";
  } catch (e) {
    $("halt-all-error").textContent = `HALT ALL: ${e.message}`;
  }
}

api.whenUnauthorized(() => askForToken(api.token() ? "that token was refused" : ""));
store.on("live", setLive);
window.addEventListener("hashchange", () => show($("view")));
$("halt-all").addEventListener("click", haltAll);
$("token-form").addEventListener("submit", (ev) => {
  ev.preventDefault();
  api.setToken($("token-input").value.trim());
  $("token-input").value = "";
  start();
});
setLive({ live: false, detail: "connecting" });
start();
