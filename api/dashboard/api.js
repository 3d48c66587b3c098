// REST calls of the dashboard: the public API only. A token (when the gateway has tokens) lives in
// sessionStorage and goes out as `Authorization: Bearer`; a 401 asks the page for one. Leases this
// page holds live in sessionStorage too, and every call about a leased controller sends its Lease-Id.

const TOKEN_KEY = "asi-gateway.token";
const LEASES_KEY = "asi-gateway.leases";

export function token() {
  return sessionStorage.getItem(TOKEN_KEY) || "";
}

export function setToken(value) {
  if (value) sessionStorage.setItem(TOKEN_KEY, value);
  else sessionStorage.removeItem(TOKEN_KEY);
}

// controller id -> {lease_id, expires, ...} of the leases this page took.
export function heldLeases() {
  try {
    return JSON.parse(sessionStorage.getItem(LEASES_KEY) || "{}");
  } catch {
    return {};
  }
}

function keepLease(controller, lease) {
  const all = heldLeases();
  if (lease) all[controller] = lease;
  else delete all[controller];
  sessionStorage.setItem(LEASES_KEY, JSON.stringify(all));
}

export class ApiError extends Error {
  constructor(status, problem) {
    super(problem?.detail || problem?.title || `HTTP ${status}`);
    this.status = status;
    this.problem = problem;
    this.field = problem?.field;  // the request field a 422 names ("spec.a1.X")
  }
}

let onUnauthorized = () => {};
export function whenUnauthorized(callback) {
  onUnauthorized = callback;
}

const enc = encodeURIComponent;
const controllerOf = (path) => /^\/api\/v1\/controllers\/([^/?]+)/.exec(path)?.[1];

// fetch + JSON; a problem+json answer is thrown as ApiError. options.controller names the controller
// whose lease to send (taken from the path when it is a controller's); options.text sends a text body.
export async function request(method, path, body, options = {}) {
  const headers = {};
  if (token()) headers.Authorization = `Bearer ${token()}`;
  const controller = options.controller ?? (controllerOf(path) && decodeURIComponent(controllerOf(path)));
  const lease = controller ? heldLeases()[controller] : null;
  if (lease) headers["Lease-Id"] = lease.lease_id;
  let payload;
  if (options.text !== undefined) {
    headers["Content-Type"] = "text/plain";
    payload = options.text;
  } else if (body !== undefined) {
    headers["Content-Type"] = "application/json";
    payload = JSON.stringify(body);
  }
  const res = await fetch(path, { method, headers, body: payload });
  const text = await res.text();
  let value = null;
  if (text) {
    const type = res.headers.get("Content-Type") || "";
    if (!type.includes("json")) value = text;
    else {
      try {
        value = JSON.parse(text);
      } catch {
        value = { detail: text };
      }
    }
  }
  if (res.status === 401) onUnauthorized();
  if (!res.ok) throw new ApiError(res.status, typeof value === "string" ? { detail: value } : value);
  return value;
}

// A GET whose body the caller reads itself (a download as a Blob, rows streamed line by line): the
// Response once it is 2xx, sent with the token as request() sends it (a plain link would not be).
export async function fetchResponse(path) {
  const res = await fetch(path, { headers: token() ? { Authorization: `Bearer ${token()}` } : {} });
  if (res.status === 401) onUnauthorized();
  if (res.ok) return res;
  const text = await res.text();
  let problem;
  try {
    problem = JSON.parse(text);
  } catch {
    problem = { detail: text };
  }
  throw new ApiError(res.status, problem);
}

export const whoami = () => request("GET", "/api/v1/whoami");
export const listControllers = () => request("GET", "/api/v1/controllers");
export const controller = (id) => request("GET", `/api/v1/controllers/${enc(id)}`);
export const operation = (id, name, args = {}) => request("POST", `/api/v1/controllers/${enc(id)}/${name}`, args);
export const halt = (id) => operation(id, "halt");
// HALT ALL: every controller at once; the answer lists each ({id, halted, problem}).
export const haltAll = () => request("POST", "/api/v1/halt");
export const moveRelative = (id, axes) => operation(id, "move", { axes, mode: "relative" });
export const moveAbsolute = (id, axes) => operation(id, "move", { axes, mode: "absolute" });

// Every current lease (without ids): one request for all controllers.
export const listLeases = () => request("GET", "/api/v1/leases");

export async function takeLease(id, ttlS, holder) {
  const body = { ttl_s: ttlS };
  if (holder) body.holder = holder;
  const lease = await request("POST", `/api/v1/controllers/${enc(id)}/lease`, body);
  keepLease(id, lease);
  return lease;
}

export async function renewLease(id, ttlS) {
  const lease = await request("POST", `/api/v1/controllers/${enc(id)}/lease/renew`, { ttl_s: ttlS });
  keepLease(id, { ...heldLeases()[id], ...lease });
  return lease;
}

export async function releaseLease(id) {
  try {
    await request("DELETE", `/api/v1/controllers/${enc(id)}/lease`);
  } finally {
    keepLease(id, null);  // gone either way: released, expired or taken over
  }
}

// Forgets a lease the gateway no longer has (expired, or ended by a restart or an admin).
export const forgetLease = (id) => keepLease(id, null);

// Jobs. query: {controller, state, limit, cursor...} as GET /api/v1/jobs takes them.
export function listJobs(query = {}) {
  const q = new URLSearchParams(Object.entries(query).filter(([, v]) => v !== undefined && v !== ""));
  return request("GET", `/api/v1/jobs${q.size ? `?${q}` : ""}`);
}
export const job = (id) => request("GET", `/api/v1/jobs/${enc(id)}`);
export const jobEvents = (id) => request("GET", `/api/v1/jobs/${enc(id)}/events`);
// body: {controller, type, spec}; dryRun asks for the plan only.
export const submitJob = (body, dryRun = false) =>
  request("POST", `/api/v1/jobs${dryRun ? "?dry_run=true" : ""}`, body, { controller: body.controller });
// action: cancel, pause, resume, next; controller: the job's (for its lease).
export const jobAction = (id, action, controller) =>
  request("POST", `/api/v1/jobs/${enc(id)}/${action}`, {}, { controller });

// Position recordings. query: {controller, state, until, limit} as GET /api/v1/recordings takes them.
export function listRecordings(query = {}) {
  const q = new URLSearchParams(Object.entries(query).filter(([, v]) => v !== undefined && v !== ""));
  return request("GET", `/api/v1/recordings${q.size ? `?${q}` : ""}`);
}
export const recording = (id) => request("GET", `/api/v1/recordings/${enc(id)}`);
// body: RecordingRequest ({name, arm: {ttl_in_mode}, max_frames, max_s, metadata}).
export const startRecording = (controllerId, body) =>
  request("POST", `/api/v1/controllers/${enc(controllerId)}/recordings`, body);
export const stopRecording = (id) => request("POST", `/api/v1/recordings/${enc(id)}/stop`);
export const deleteRecording = (id) => request("DELETE", `/api/v1/recordings/${enc(id)}`);
// format: csv, jsonl or hdf5 (read with fetchResponse: the body is a stream, not JSON).
export const recordingFramesPath = (id, format) => `/api/v1/recordings/${enc(id)}/frames?format=${format}`;
