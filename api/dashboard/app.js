// The dashboard's overview: loads the controllers over REST, then follows them live over the
// WebSocket. Asks for a token when the gateway answers 401.

import * as api from "./api.js";
import { LiveFeed } from "./live.js";
import { ControllerCard } from "./overview.js";

const LEASE_POLL_MS = 5000;

const cards = new Map();  // id -> ControllerCard
const $ = (id) => document.getElementById(id);
let feed = null;
let started = false;

function card(id) {
  let c = cards.get(id);
  if (!c) {
    c = new ControllerCard(id);
    cards.set(id, c);
    const list = [...cards.keys()].sort();
    const before = cards.get(list[list.indexOf(id) + 1]);
    $("cards").insertBefore(c.root, before ? before.root : null);
  }
  return c;
}

function setLive(live, detail) {
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

function onEvent(msg) {
  const m = /^controllers\/([^/]+)\/(state|position)$/.exec(msg.topic || "");
  if (!m) return;
  const c = card(m[1]);
  if (msg.type === "gap") return c.gap();
  if (m[2] === "state") c.setState(msg.data);
  else c.setPositions(msg.data.axes, msg.data.busy);
}

async function refreshLeases() {
  await Promise.all([...cards.values()].map(async (c) => {
    try {
      c.setLease(await api.lease(c.id));
    } catch (e) {
      c.setLease(null, e.message);
    }
  }));
}

async function start() {
  let list;
  try {
    list = (await api.listControllers()).controllers;
  } catch (e) {
    if (e.status === 401) return askForToken(api.token() ? "that token was refused" : "");
    setLive(false, `the gateway did not answer (${e.message})`);
    setTimeout(start, 2000);
    return;
  }
  $("token-form").hidden = true;
  for (const s of list) card(s.id).setState(s);
  refreshLeases();
  if (!started) {
    started = true;
    setInterval(refreshLeases, LEASE_POLL_MS);
  }
  if (!feed) {
    // A REST call tells a refused token (401: the token form) from a gateway that is down.
    const onRefused = () => api.listControllers().catch(() => {});
    feed = new LiveFeed({ onEvent, onStatus: setLive, onRefused });
  }
  feed.start();
}

async function haltAll() {
  const results = await Promise.allSettled([...cards.keys()].map((id) => api.halt(id)));
  results.forEach((r, i) => {
    if (r.status === "rejected") [...cards.values()][i].opError.textContent = `halt: ${r.reason.message}`;
  });
}

api.whenUnauthorized(() => askForToken(api.token() ? "that token was refused" : ""));
$("halt-all").addEventListener("click", haltAll);
$("token-form").addEventListener("submit", (ev) => {
  ev.preventDefault();
  api.setToken($("token-input").value.trim());
  $("token-input").value = "";
  start();
});
setLive(false, "connecting");
start();
