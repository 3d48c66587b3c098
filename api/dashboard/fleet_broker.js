// The fleet view's one connection to the broker (MQTT.js over the broker's WebSocket listener): it
// subscribes to the fleet's topics and hands every message on. It never publishes, so a read-only
// account is enough; a refused account stops the retries instead of knocking every 2 s.

import mqtt from "./vendor/mqtt.esm.js";
import { fleetFilters } from "./fleet_model.js";

const RECONNECT_MS = 2000;
// CONNACK reason codes that another try will not change: bad user name or password, not authorised
// (MQTT 3.1.1: 4, 5; MQTT 5: 134, 135), banned (138).
const REFUSED = new Set([4, 5, 134, 135, 138]);

export class FleetBroker {
  // onStatus({state: "connecting"|"connected"|"lost"|"refused"|"closed", detail}), onMessage(topic, payload)
  constructor(settings, onStatus, onMessage) {
    this.settings = settings;
    this.onStatus = onStatus;
    this.client = mqtt.connect(settings.url, {
      username: settings.username || undefined,
      password: settings.password || undefined,
      clientId: `fleet-view-${Math.random().toString(16).slice(2, 10)}`,
      protocolVersion: 5,
      clean: true,
      keepalive: 30,
      reconnectPeriod: RECONNECT_MS,
      connectTimeout: 10000,
      // Native timers and WebSocket: MQTT.js would otherwise start a Worker from a blob: URL, which
      // the page's Content-Security-Policy (script-src 'self') forbids.
      timerVariant: "native",
      forceNativeWebSocket: true,
    });
    this.status("connecting", settings.url);
    this.client.on("connect", () => this.subscribe());
    this.client.on("reconnect", () => this.status("connecting", settings.url));
    this.client.on("close", () => {
      if (this.state === "connected") this.status("lost", "the broker closed the connection; retrying");
    });
    this.client.on("error", (e) => {
      if (REFUSED.has(e?.code)) {
        this.status("refused", `the broker refused the account: ${e.message}`);
        this.client.end(true);
      } else {
        this.status("lost", `${e?.message || e}; retrying`);
      }
    });
    this.client.on("message", (topic, payload) => onMessage(topic, payload));
  }

  subscribe() {
    const filters = fleetFilters(this.settings.prefix);
    this.client.subscribe(filters, { qos: 1 }, (err, granted) => {
      if (err) return this.status("lost", `subscribe: ${err.message}`);
      const refused = (granted || []).filter((g) => g.qos >= 128).map((g) => g.topic);
      if (refused.length) return this.status("refused", `the broker refused the subscription to ${refused.join(", ")}`);
      const who = this.settings.username ? ` as ${this.settings.username}` : "";
      this.status("connected", `${this.settings.url}${who}, topics under ${this.settings.prefix}/`);
    });
  }

  status(state, detail) {
    this.state = state;
    this.onStatus({ state, detail });
  }

  close() {
    this.client.end(true);
    this.status("closed", "disconnected");
  }
}
