// The fleet as the broker tells it (no DOM): one entry per gateway from its retained birth or offline
// message on `<prefix>/<gateway>/status`, its controllers from the birth, their retained
// `controllers/<id>/state` and live `position`, and its jobs from the retained `jobs/<job>/state`.
// Bounded: a broker may carry more than a page can hold, so what lies beyond the caps is not kept, only
// flagged (the view says some are not shown).

export const MAX_GATEWAYS = 500;
export const MAX_CONTROLLERS = 64;  // per gateway
export const MAX_JOBS = 32;  // active jobs per gateway; an ended job is dropped
const MAX_PAYLOAD = 256 * 1024;  // a state is a few kB; anything larger is not one of ours

export const ACTIVE_JOB_STATES = new Set(["queued", "running", "paused"]);

// The topic filters the view subscribes to under `prefix`.
export function fleetFilters(prefix) {
  return [`${prefix}/+/status`, `${prefix}/+/controllers/+/state`, `${prefix}/+/controllers/+/position`,
          `${prefix}/+/jobs/+/state`];
}

// "asi/lab3/controllers/sim1/state" under "asi": {gateway: "lab3", kind: "state", id: "sim1"}, or
// null for a topic the view does not read. The prefix may have several levels.
export function parseFleetTopic(prefix, topic) {
  if (!topic.startsWith(`${prefix}/`)) return null;
  const levels = topic.slice(prefix.length + 1).split("/");
  const [gateway, a, id, b] = levels;
  if (!gateway) return null;
  if (levels.length === 2 && a === "status") return { gateway, kind: "status" };
  if (levels.length !== 4) return null;
  if (a === "controllers" && (b === "state" || b === "position")) return { gateway, kind: b, id };
  if (a === "jobs" && b === "state") return { gateway, kind: "job", id };
  return null;
}

function newGateway(id) {
  // online: true (birth), false (offline message), null (only states seen so far, no status yet)
  return { id, online: null, birth: null, offline: null, controllers: new Map(), jobs: new Map(),
           controllersCapped: false, jobsCapped: false };
}

function newController(id) {
  return { id, state: null, build: null, busy: false, axes: [], positionTime: null, halted: null };
}

export class Fleet {
  constructor() {
    this.gateways = new Map();
    this.capped = false;  // a gateway beyond MAX_GATEWAYS was seen (and not kept)
  }

  // Applies one message; returns the id of the gateway it changed, or null.
  apply(prefix, topic, payload) {
    const t = parseFleetTopic(prefix, topic);
    if (!t) return null;
    if (payload.length > MAX_PAYLOAD) return null;
    let body = null;
    if (payload.length) {
      try {
        body = JSON.parse(new TextDecoder().decode(payload));
      } catch {
        return null;  // not ours: ignored rather than shown half-read
      }
      if (typeof body !== "object" || body === null) return null;
    }
    // An empty retained message clears: a gateway's status gone means the gateway is gone.
    if (t.kind === "status" && !body) return this.gateways.delete(t.gateway) ? t.gateway : null;
    const gw = this.gateway(t.gateway);
    if (!gw) return null;
    if (t.kind === "status") this.setStatus(gw, body);
    else if (t.kind === "state") this.setState(gw, t.id, body);
    else if (t.kind === "position") this.setPosition(gw, t.id, body?.data, body?.time);
    else if (t.kind === "job") this.setJob(gw, t.id, body);
    return gw.id;
  }

  gateway(id) {
    let gw = this.gateways.get(id);
    if (gw) return gw;
    if (this.gateways.size >= MAX_GATEWAYS) {
      this.capped = true;
      return null;
    }
    gw = newGateway(id);
    this.gateways.set(id, gw);
    return gw;
  }

  controller(gw, id, create = true) {
    let c = gw.controllers.get(id);
    if (c || !create) return c || null;
    if (gw.controllers.size >= MAX_CONTROLLERS) {
      gw.controllersCapped = true;
      return null;
    }
    c = newController(id);
    gw.controllers.set(id, c);
    return c;
  }

  setStatus(gw, body) {
    if (body.state === "online") {
      gw.online = true;
      gw.birth = body;
      gw.offline = null;
      // The birth lists the controllers: the ones it no longer has go.
      const listed = Array.isArray(body.controllers) ? body.controllers : [];
      const ids = new Set(listed.map((c) => String(c.id)));
      for (const id of [...gw.controllers.keys()]) if (!ids.has(id)) gw.controllers.delete(id);
      for (const b of listed) {
        const c = this.controller(gw, String(b.id));
        if (!c) continue;
        if (!c.state) c.state = b.state;
        c.build = b.build ?? c.build;
      }
    } else if (body.state === "offline") {
      gw.online = false;
      gw.offline = { reason: body.reason || "offline", time: body.time || null };
    }
  }

  // body: the hub's event (its data the controller's state), or null when the retained state was cleared.
  setState(gw, id, body) {
    if (!body) {
      gw.controllers.delete(id);
      return;
    }
    const s = body.data;
    if (typeof s !== "object" || s === null) return;
    const c = this.controller(gw, id);
    if (!c) return;
    c.state = s.state;
    c.busy = !!s.busy;
    c.build = s.identity?.build ?? c.build;
    c.halted = s.halted || null;
    if (Array.isArray(s.axes)) c.axes = s.axes.map((a) => ({ axis: a.axis, um: a.position_um, busy: !!a.busy }));
  }

  setPosition(gw, id, p, time) {
    const c = this.controller(gw, id, false);  // positions alone do not make a controller
    if (!c || !p || !Array.isArray(p.axes)) return;
    c.busy = !!p.busy;
    c.axes = p.axes.map((a) => ({ axis: a.axis, um: a.position_um, busy: !!a.busy }));
    c.positionTime = time || null;
  }

  // body: {type: "job", job: {...}}, or null when the retained state was cleared.
  setJob(gw, id, body) {
    const job = body?.job;
    if (body && (typeof job !== "object" || job === null)) return;
    if (!job || !ACTIVE_JOB_STATES.has(job.state)) {  // cleared or ended: not running any more
      gw.jobs.delete(id);
      return;
    }
    if (!gw.jobs.has(id) && gw.jobs.size >= MAX_JOBS) {
      gw.jobsCapped = true;
      return;
    }
    gw.jobs.set(id, { id, controller: job.controller, type: job.type, state: job.state,
                      percent: job.progress?.percent ?? null, step: job.progress?.current_step || "",
                      waitingFor: job.progress?.waiting_for || null });
  }

  // Gateways by id: a fleet is read by name, and the order does not jump when one goes offline.
  sorted() {
    return [...this.gateways.values()].sort((a, b) => a.id.localeCompare(b.id));
  }

  clear() {
    this.gateways.clear();
    this.capped = false;
  }
}
