// The WebSocket feed (/api/v1/ws): keeps the page's subscriptions (topic patterns, each with its
// max_rate_hz), reconnects with a growing backoff, and resumes every topic from the last sequence
// number it saw, so nothing is missed silently (the gateway replays or sends an explicit `gap`).

import { token } from "./api.js";
import { topicMatches } from "./topics.js";

export class LiveFeed {
  // onEvent(message) for events, gaps and retired notices; onStatus(live: bool, detail: string);
  // onRefused() when a connection closed before its first subscription was confirmed.
  constructor({ onEvent, onStatus, onRefused = () => {} }) {
    this.onEvent = onEvent;
    this.onStatus = onStatus;
    this.onRefused = onRefused;
    this.patterns = new Map();  // topic pattern -> max_rate_hz (0: no limit)
    this.lastSeq = {};  // concrete topic -> last seq seen
    this.backoffMs = 500;
    this.ws = null;
    this.open = false;
    this.timer = null;
    this.nextId = 1;
  }

  url() {
    const scheme = location.protocol === "https:" ? "wss" : "ws";
    const t = token();
    return `${scheme}://${location.host}/api/v1/ws${t ? `?access_token=${encodeURIComponent(t)}` : ""}`;
  }

  // Adds topic patterns; sent at once when connected, and again (with resume) after each reconnect.
  subscribe(topics, { maxRateHz = 0 } = {}) {
    const fresh = topics.filter((t) => !this.patterns.has(t));
    for (const t of fresh) this.patterns.set(t, maxRateHz);
    if (this.open && fresh.length) this.sendSubscribe(fresh, maxRateHz);
  }

  unsubscribe(topics) {
    for (const t of topics) this.patterns.delete(t);
    for (const topic of Object.keys(this.lastSeq)) {
      if (![...this.patterns.keys()].some((p) => topicMatches(p, topic))) delete this.lastSeq[topic];
    }
    if (this.open) this.send({ op: "unsubscribe", id: this.nextId++, topics });
  }

  send(msg) {
    this.ws.send(JSON.stringify(msg));
  }

  sendSubscribe(topics, maxRateHz) {
    const resume = {};
    for (const [topic, seq] of Object.entries(this.lastSeq)) {
      if (topics.some((p) => topicMatches(p, topic))) resume[topic] = seq;
    }
    const msg = { op: "subscribe", id: this.nextId++, topics, resume };
    if (maxRateHz) msg.max_rate_hz = maxRateHz;
    this.send(msg);
  }

  start() {
    clearTimeout(this.timer);
    if (this.ws) {
      this.ws.onclose = null;
      this.ws.close();
    }
    const ws = new WebSocket(this.url());
    this.ws = ws;
    this.open = false;
    let subscribed = false;
    ws.onopen = () => {
      this.open = true;
      const byRate = new Map();  // one subscribe per rate
      for (const [topic, hz] of this.patterns) byRate.set(hz, [...(byRate.get(hz) || []), topic]);
      for (const [hz, topics] of byRate) this.sendSubscribe(topics, hz);
    };
    ws.onmessage = (m) => {
      let msg;
      try {
        msg = JSON.parse(m.data);
      } catch {
        return;
      }
      if (msg.type === "subscribed") {
        if (!subscribed) {
          subscribed = true;
          this.backoffMs = 500;
          this.onStatus(true, "");
        }
      } else if (msg.type === "event") {
        if (typeof msg.seq === "number") this.lastSeq[msg.topic] = msg.seq;
        this.onEvent(msg);
      } else if (msg.type === "gap" || msg.type === "retired") {
        this.onEvent(msg);
      } else if (msg.type === "error" || msg.type === "problem") {
        if (!subscribed) this.onStatus(false, msg.detail || msg.title || "the gateway refused the subscription");
      }
    };
    ws.onclose = () => {
      this.ws = null;
      this.open = false;
      const wait = this.backoffMs;
      this.backoffMs = Math.min(this.backoffMs * 2, 10000);
      this.onStatus(false, `live connection lost; reconnecting in ${(wait / 1000).toFixed(1)} s`);
      this.timer = setTimeout(() => this.start(), wait);
      if (!subscribed) this.onRefused();
    };
  }
}
