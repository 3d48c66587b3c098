// REST calls of the dashboard: the public API only. A token (when the gateway has tokens) lives in
// sessionStorage and goes out as `Authorization: Bearer`; a 401 asks the page for one.

const TOKEN_KEY = "asi-gateway.token";

export function token() {
  return sessionStorage.getItem(TOKEN_KEY) || "";
}

export function setToken(value) {
  if (value) sessionStorage.setItem(TOKEN_KEY, value);
  else sessionStorage.removeItem(TOKEN_KEY);
}

export class ApiError extends Error {
  constructor(status, problem) {
    super(problem?.detail || problem?.title || `HTTP ${status}`);
    this.status = status;
    this.problem = problem;
  }
}

let onUnauthorized = () => {};
export function whenUnauthorized(callback) {
  onUnauthorized = callback;
}

// fetch + JSON; a problem+json answer is thrown as ApiError.
export async function request(method, path, body) {
  const headers = {};
  if (token()) headers.Authorization = `Bearer ${token()}`;
  if (body !== undefined) headers["Content-Type"] = "application/json";
  const res = await fetch(path, { method, headers, body: body === undefined ? undefined : JSON.stringify(body) });
  const text = await res.text();
  let value = null;
  if (text) {
    try {
      value = JSON.parse(text);
    } catch {
      value = { detail: text };
    }
  }
  if (res.status === 401) onUnauthorized();
  if (!res.ok) throw new ApiError(res.status, value);
  return value;
}

export const listControllers = () => request("GET", "/api/v1/controllers");
export const halt = (id) => request("POST", `/api/v1/controllers/${encodeURIComponent(id)}/halt`, {});
export const moveRelative = (id, axes) =>
  request("POST", `/api/v1/controllers/${encodeURIComponent(id)}/move`, { axes, mode: "relative" });

// The lease on a controller, or null when it is free (404).
export async function lease(id) {
  try {
    return await request("GET", `/api/v1/controllers/${encodeURIComponent(id)}/lease`);
  } catch (e) {
    if (e.status === 404) return null;
    throw e;
  }
}
