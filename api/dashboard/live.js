// The WebSocket feed (/api/v1/ws): subscribes to the controllers' state and position topics, reconnects
// with a growing backoff, and resumes every topic from the last sequence number it saw, so nothing is
// missed silently (the gateway replays or sends an explicit `gap`).

import { token } from "./api.js";

const TOPICS = ["controllers/+/state", "controllers/+/position"];
const MAX_RATE_HZ = 10;

export class LiveFeed {
  // onEvent(message) for events and gaps; onStatus(live: bool, detail: string); onRefused() when a
  // connection closed before its subscription was confirmed (a refused token shows over REST).
  constructor({ onEvent, onStatus, onRefused = () => {} }) {
    this.onEvent = onEvent;
    this.onStatus = onStatus;
    this.onRefused = onRefused;
    this.lastSeq = {};  // topic -> last seq seen
    this.backoffMs = 500;
    this.ws = null;
    this.timer = null;
  }

  url() {
    const scheme = location.protocol === "https:" ? "wss" : "ws";
    const t = token();
    return `${scheme}://${location.host}/api/v1/ws${t ? `?access_token=${encodeURIComponent(t)}` : ""}`;
  }

  start() {
    clearTimeout(this.timer);
    if (this.ws) {
      this.ws.onclose = null;
      this.ws.close();
    }
    const ws = new WebSocket(this.url());
    this.ws = ws;
    let subscribed = false;
    ws.onopen = () => {
      ws.send(JSON.stringify({ op: "subscribe", id: 1, topics: TOPICS, max_rate_hz: MAX_RATE_HZ,
                               resume: { ...this.lastSeq } }));
    };
    ws.onmessage = (m) => {
      let msg;
      try {
        msg = JSON.parse(m.data);
      } catch {
        return;
      }
      if (msg.type === "subscribed") {
        subscribed = true;
        this.backoffMs = 500;
        this.onStatus(true, "");
      } else if (msg.type === "event") {
        if (typeof msg.seq === "number") this.lastSeq[msg.topic] = msg.seq;
        this.onEvent(msg);
      } else if (msg.type === "gap") {
        this.onEvent(msg);
      } else if (msg.type === "error" || msg.type === "problem") {
        this.onStatus(false, msg.detail || msg.title || "the gateway refused the subscription");
      }
    };
    ws.onclose = () => {
      this.ws = null;
      const wait = this.backoffMs;
      this.backoffMs = Math.min(this.backoffMs * 2, 10000);
      this.onStatus(false, `live connection lost; reconnecting in ${(wait / 1000).toFixed(1)} s`);
      this.timer = setTimeout(() => this.start(), wait);
      if (!subscribed) this.onRefused();
    };
  }
}
