// The page's live model: every controller's latest state and position, and the topics the views
// follow. One WebSocket (live.js) serves every view: a view asks for a topic with follow() and stops
// with the function it returns; the feed subscribes once per topic however many views follow it.

import * as api from "./api.js";
import { LiveFeed } from "./live.js";
import { topicMatches } from "./topics.js";

const BASE_TOPICS = ["controllers/+/state", "controllers/+/position"];
const POSITION_RATE_HZ = 10;
const LEASE_POLL_MS = 5000;

class Store extends EventTarget {
  constructor() {
    super();
    this.controllers = new Map();  // id -> {state, position, updated}
    this.live = false;
    this.liveDetail = "connecting";
    this.followers = new Map();  // topic pattern -> Set of callbacks
    this.leases = new Map();  // controller id -> {lease, error} (lease null when free)
    this.leaseTimer = null;
    this.onRefused = () => {};
    this.feed = new LiveFeed({
      onEvent: (msg) => this.dispatch(msg),
      onStatus: (live, detail) => {
        this.live = live;
        this.liveDetail = detail;
        this.emit("live", { live, detail });
      },
      onRefused: () => this.onRefused(),
    });
    this.feed.subscribe(BASE_TOPICS, { maxRateHz: POSITION_RATE_HZ });
  }

  // Connects (or reconnects now); onRefused runs when the WebSocket closed before its subscription
  // was confirmed (the page then tells a refused token from a gateway that is down over REST).
  start(onRefused) {
    if (onRefused) this.onRefused = onRefused;
    this.feed.start();
  }

  // Leases have no events: polled every 5 s (and at once after this page changes one).
  async refreshLeases() {
    clearTimeout(this.leaseTimer);
    let byController = null;
    let error = null;
    try {
      byController = new Map((await api.listLeases()).leases.map((l) => [l.controller, l]));
    } catch (e) {
      error = e.message;
    }
    for (const id of this.controllers.keys()) {
      const entry = { lease: byController?.get(id) ?? null, error };
      const mine = api.heldLeases()[id];
      // Gone or not ours any more (expired, ended by a restart or an admin): stop sending it.
      if (mine && !error && (!entry.lease || entry.lease.acquired !== mine.acquired)) api.forgetLease(id);
      this.leases.set(id, entry);
      this.emit("lease", { id, ...entry, mine: Boolean(api.heldLeases()[id]) });
    }
    this.leaseTimer = setTimeout(() => this.refreshLeases(), LEASE_POLL_MS);
  }

  emit(type, detail) {
    this.dispatchEvent(new CustomEvent(type, { detail }));
  }

  // on("controller", ({id, controller}) => ...), on("live", ...): returns the function that stops it.
  on(type, callback) {
    const listener = (ev) => callback(ev.detail);
    this.addEventListener(type, listener);
    return () => this.removeEventListener(type, listener);
  }

  controller(id) {
    let c = this.controllers.get(id);
    if (!c) {
      c = { id, state: null, position: null, gaps: 0 };
      this.controllers.set(id, c);
      this.emit("controllers", { ids: [...this.controllers.keys()].sort() });
    }
    return c;
  }

  // A ControllerState from REST or from a state event.
  setState(s) {
    const c = this.controller(s.id);
    c.state = s;
    if (s.axes?.length) c.position = { axes: s.axes, busy: s.busy };
    this.emit("controller", { id: s.id, controller: c, what: "state" });
  }

  dispatch(msg) {
    const m = /^controllers\/([^/]+)\/(state|position)$/.exec(msg.topic || "");
    if (m) {
      const c = this.controller(m[1]);
      if (msg.type === "gap") {
        c.gaps += 1;
        this.emit("controller", { id: m[1], controller: c, what: "gap" });
      } else if (m[2] === "state") {
        this.setState(msg.data);
      } else {
        c.position = { axes: msg.data.axes, busy: msg.data.busy, time: msg.time };
        this.emit("controller", { id: m[1], controller: c, what: "position" });
      }
    }
    for (const [pattern, callbacks] of this.followers) {
      if (!topicMatches(pattern, msg.topic || "")) continue;
      for (const cb of callbacks) cb(msg);
    }
  }

  // follow("controllers/sim1/reports", msg => ..., {maxRateHz}) -> stop(). Events, gaps and retired
  // notices of that topic reach the callback; the last follower's stop unsubscribes.
  follow(topic, callback, options = {}) {
    let callbacks = this.followers.get(topic);
    if (!callbacks) {
      callbacks = new Set();
      this.followers.set(topic, callbacks);
      this.feed.subscribe([topic], options);
    }
    callbacks.add(callback);
    return () => {
      callbacks.delete(callback);
      if (callbacks.size === 0 && this.followers.get(topic) === callbacks) {
        this.followers.delete(topic);
        this.feed.unsubscribe([topic]);
      }
    };
  }
}

export const store = new Store();
