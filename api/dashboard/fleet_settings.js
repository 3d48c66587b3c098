// Where the fleet view finds the fleet: the broker's WebSocket URL, an account, the topic prefix, and
// the address pattern of the gateways' own pages. Remembered in localStorage; the password only in
// sessionStorage (gone with the browser session), never with the rest.

import { el } from "./dom.js";

const KEY = "asi-gateway.fleet";
const PASSWORD_KEY = "asi-gateway.fleet.password";
export const DEFAULT_PREFIX = "asi";  // mqtt.topic_prefix's default (gateway/config)

export function loadSettings() {
  let saved = {};
  try {
    saved = JSON.parse(localStorage.getItem(KEY) || "{}") || {};
  } catch {
    saved = {};  // a hand-edited or older entry: start afresh
  }
  return {
    url: String(saved.url || ""),
    username: String(saved.username || ""),
    password: sessionStorage.getItem(PASSWORD_KEY) || "",
    prefix: String(saved.prefix || DEFAULT_PREFIX),
    pages: String(saved.pages || ""),
  };
}

export function saveSettings(s) {
  localStorage.setItem(KEY, JSON.stringify({ url: s.url, username: s.username, prefix: s.prefix, pages: s.pages }));
  if (s.password) sessionStorage.setItem(PASSWORD_KEY, s.password);
  else sessionStorage.removeItem(PASSWORD_KEY);
}

// The link to a gateway's own page: the pattern with {gateway} replaced, or null without a pattern.
// The birth carries no address of the gateway's page, so the person who knows the fleet says how
// they are named (the gateway id defaults to the host name: "http://{gateway}:8080/").
export function gatewayPage(pattern, gateway) {
  if (!pattern) return null;
  const url = pattern.replaceAll("{gateway}", encodeURIComponent(gateway));
  return /^https?:\/\//.test(url) ? url : null;
}

// What is wrong with the settings, or "": a broker URL the page can open (ws:// or wss:// only; MQTT.js
// would also try others it cannot use in a browser), and a prefix of topic levels as mqtt.topic_prefix
// allows them (a wildcard would subscribe to more than the fleet).
export function checkSettings(s) {
  if (!/^wss?:\/\/[^/]+/.test(s.url)) return "the broker's address is a WebSocket URL: ws://host:port or wss://host:port/path";
  if (!/^[A-Za-z0-9_.-]+(\/[A-Za-z0-9_.-]+)*$/.test(s.prefix)) {
    return "the topic prefix is one or more levels of letters, digits, '_', '.' or '-', separated by '/'";
  }
  return "";
}

function field(label, input, hint) {
  return el("label", { class: "fleet-field" }, el("span", {}, label), input,
            hint ? el("small", { class: "meta" }, hint) : null);
}

// The form; onConnect(settings) when submitted with a usable URL, onDisconnect() for the other button.
export class FleetSettingsForm {
  constructor(onConnect, onDisconnect) {
    const s = loadSettings();
    this.url = el("input", { id: "fleet-url", type: "text", value: s.url, required: true, spellcheck: false,
                             placeholder: `ws://${location.hostname || "broker"}:9001` });
    this.username = el("input", { id: "fleet-username", type: "text", value: s.username, autocomplete: "username" });
    this.password = el("input", { id: "fleet-password", type: "password", value: s.password,
                                  autocomplete: "current-password" });
    this.prefix = el("input", { id: "fleet-prefix", type: "text", value: s.prefix, required: true, spellcheck: false });
    this.pages = el("input", { id: "fleet-pages", type: "text", value: s.pages, spellcheck: false,
                               placeholder: "http://{gateway}:8080/" });
    this.error = el("span", { class: "error", id: "fleet-form-error", role: "alert" });
    this.connectButton = el("button", { type: "submit", id: "fleet-connect", class: "primary" }, "Connect");
    this.disconnectButton = el("button", { type: "button", id: "fleet-disconnect", disabled: true }, "Disconnect");
    this.disconnectButton.addEventListener("click", () => onDisconnect());
    this.root = el("form", { class: "fleet-settings", id: "fleet-settings" },
                   field("Broker WebSocket URL", this.url, "mosquitto's websockets listener"),
                   field("Username", this.username),
                   field("Password", this.password, "kept for this browser session only"),
                   field("Topic prefix", this.prefix),
                   field("Gateway pages", this.pages, "{gateway} is replaced by the gateway's id"),
                   el("div", { class: "fleet-buttons" }, this.connectButton, this.disconnectButton, this.error));
    this.root.addEventListener("submit", (ev) => {
      ev.preventDefault();
      const settings = this.read();
      this.error.textContent = checkSettings(settings);
      if (this.error.textContent) return;
      saveSettings(settings);
      onConnect(settings);
    });
  }

  read() {
    return { url: this.url.value.trim(), username: this.username.value.trim(), password: this.password.value,
             prefix: this.prefix.value.trim().replace(/^\/+|\/+$/g, "") || DEFAULT_PREFIX,
             pages: this.pages.value.trim() };
  }

  setConnected(on) {
    this.disconnectButton.disabled = !on;
  }
}
