// The fleet (#/fleet): every gateway on a broker, read from MQTT rather than from this gateway's API.
// Each gateway announces itself with a retained birth, so a page that subscribes late still sees the
// whole fleet; the page connects to the broker's WebSocket listener itself (fleet_broker.js) and
// reads only, so a read-only broker account will do. The settings form: fleet_settings.js; the model:
// fleet_model.js; one card per gateway: fleet_card.js.

import { el } from "./dom.js";
import { FleetBroker } from "./fleet_broker.js";
import { fleetCard } from "./fleet_card.js";
import { Fleet, MAX_GATEWAYS } from "./fleet_model.js";
import { checkSettings, FleetSettingsForm, gatewayPage, loadSettings } from "./fleet_settings.js";

// Positions come at up to mqtt.telemetry.position_max_hz per controller from every gateway: the
// cards are rebuilt at most this often, each only when its gateway changed.
const RENDER_MS = 250;

export function mount(container) {
  const view = new FleetView();
  container.append(view.root);
  const saved = loadSettings();
  if (saved.url && !checkSettings(saved)) view.connect(saved);  // as it was left
  return () => view.stop();
}

// The gateway's own word first (its birth's "url": http.public_url), else the pattern typed here. The
// birth comes from the broker, so only an http(s) URL is taken (never a javascript: link).
function pageOf(gw, pattern) {
  const told = gw.birth?.url;
  if (typeof told === "string" && /^https?:\/\/[^\s]+$/.test(told)) return told;
  return gatewayPage(pattern, gw.id);
}

class FleetView {
  constructor() {
    this.fleet = new Fleet();
    this.broker = null;
    this.settings = null;
    this.cards = new Map();  // gateway id -> its card element
    this.dirty = new Set();  // gateway ids changed since the last render
    this.timer = null;
    this.form = new FleetSettingsForm((s) => this.connect(s), () => this.disconnect());
    this.status = el("div", { class: "fleet-status", id: "fleet-status", "data-state": "idle" },
                     "not connected");
    this.summary = el("span", { class: "meta", id: "fleet-summary" });
    this.capped = el("p", { class: "meta", hidden: true },
                     `More gateways than this page keeps (${MAX_GATEWAYS}): the rest are not shown.`);
    this.empty = el("p", { class: "meta empty", id: "fleet-empty" }, "No gateway seen yet.");
    this.list = el("div", { class: "cards fleet-cards", id: "fleet-gateways" });
    this.root = el("section", { class: "fleet-page" },
                   el("div", { class: "page-head" }, el("h2", {}, "Fleet"), this.summary),
                   this.form.root, this.status, this.capped, this.empty, this.list);
  }

  connect(settings) {
    this.disconnect();
    this.settings = settings;
    this.broker = new FleetBroker(settings, (s) => this.showStatus(s), (topic, payload) => {
      const changed = this.fleet.apply(settings.prefix, topic, payload);
      if (changed !== null) this.changed(changed);
    });
    this.form.setConnected(true);
  }

  disconnect() {
    if (this.broker) this.broker.close();
    this.broker = null;
    this.form.setConnected(false);
    // Another broker or prefix is another fleet: nothing of this one stays on the page.
    this.fleet.clear();
    this.cards.clear();
    this.list.replaceChildren();
    this.dirty.clear();
    this.renderSummary();
  }

  stop() {
    clearTimeout(this.timer);
    if (this.broker) this.broker.close();
    this.broker = null;
  }

  showStatus({ state, detail }) {
    this.status.dataset.state = state;
    const words = { connecting: "connecting to", connected: "connected to", lost: "connection lost:",
                    refused: "refused:", closed: "" };
    this.status.textContent = `${words[state] ?? state} ${detail}`.trim();
    this.root.classList.toggle("fleet-stale", state !== "connected");
    if (state === "refused" || state === "closed") this.form.setConnected(state !== "closed");
  }

  changed(id) {
    this.dirty.add(id);
    if (!this.timer) this.timer = setTimeout(() => this.render(), RENDER_MS);
  }

  render() {
    this.timer = null;
    const pages = this.settings?.pages || "";
    let added = false;
    for (const id of this.dirty) {
      const gw = this.fleet.gateways.get(id);
      const old = this.cards.get(id);
      if (!gw) {
        old?.remove();
        this.cards.delete(id);
        continue;
      }
      const card = fleetCard(gw, pageOf(gw, pages));
      if (old) old.replaceWith(card);
      else added = true;
      this.cards.set(id, card);
    }
    this.dirty.clear();
    if (added) this.list.replaceChildren(...this.fleet.sorted().map((gw) => this.cards.get(gw.id)));
    this.renderSummary();
  }

  renderSummary() {
    const all = [...this.fleet.gateways.values()];
    const online = all.filter((g) => g.online === true).length;
    const jobs = all.reduce((n, g) => n + g.jobs.size, 0);
    this.summary.textContent = all.length
      ? `${all.length} gateways: ${online} online, ${all.length - online} offline or unknown; ${jobs} job${jobs === 1 ? "" : "s"} running`
      : "";
    this.empty.hidden = all.length > 0;
    this.capped.hidden = !this.fleet.capped;
  }
}
