// One gateway of the fleet view: online (its birth: version, broker, since when) or offline (why:
// "shutdown" or "connection lost", the Last Will), its controllers with their state and positions, the
// jobs it runs, and links to its own page when the page's address is known. Rebuilt from the model
// (fleet_model.js) whenever that gateway changed; the view batches the rebuilds.

import { el, formatUm } from "./dom.js";
import { formatTime } from "./job_status.js";
import { MAX_CONTROLLERS, MAX_JOBS } from "./fleet_model.js";

function onlineBadge(gw) {
  const state = gw.online === true ? "online" : gw.online === false ? "offline" : "no status";
  return el("span", { class: `fleet-online ${state.replace(" ", "-")}`, "data-online-badge": state }, state);
}

function statusLine(gw) {
  if (gw.online === false) {
    const when = gw.offline.time ? ` at ${formatTime(gw.offline.time)}` : "";
    return el("div", {}, el("div", { class: "fleet-offline-reason", role: "status" }, `offline: ${gw.offline.reason}${when}`),
              el("div", { class: "meta" }, "its controllers and jobs as it last published them"));
  }
  if (gw.online === true) {
    const b = gw.birth;
    return el("div", { class: "meta" }, `version ${b.version || "?"} · MQTT ${b.protocol || "?"} · `,
              `on ${b.broker || "?"} · since ${formatTime(b.time)}`);
  }
  return el("div", { class: "meta" }, "no birth seen yet (only retained states)");
}

function positions(c) {
  if (!c.axes.length) return el("span", { class: "meta" }, "–");
  return el("span", { class: "fleet-axes" },
            ...c.axes.map((a) => el("span", { class: `fleet-axis${a.busy ? " busy" : ""}` },
                                    el("b", {}, a.axis), " ",
                                    el("span", { class: "fleet-pos", "data-axis": a.axis }, formatUm(a.um)))));
}

function controllerRow(c, page) {
  const name = page ? el("a", { href: `${page}#/controller/${encodeURIComponent(c.id)}` }, c.id) : c.id;
  const state = c.state || "unknown";
  return el("tr", { "data-controller": c.id, "data-state": state },
            el("td", { class: "fleet-controller" }, name, c.build ? el("div", { class: "meta" }, c.build) : null),
            el("td", {}, el("span", { class: `state ${state}` }, state),
               c.halted ? el("div", { class: "fleet-halted" }, `halted by ${c.halted.by}`) : null),
            el("td", { class: "fleet-positions" }, positions(c)),
            el("td", { class: "fleet-busy" }, c.busy ? "busy" : ""));
}

function jobRow(j, page) {
  const id = page ? el("a", { href: `${page}#/jobs/${encodeURIComponent(j.id)}` }, j.id) : j.id;
  const progress = typeof j.percent === "number" ? `${j.percent.toFixed(0)} %` : "";
  const waiting = j.waitingFor ? `waits for ${j.waitingFor}` : j.step;
  return el("tr", { "data-job": j.id, "data-state": j.state },
            el("td", { class: "job-id" }, id),
            el("td", {}, j.controller || ""),
            el("td", {}, j.type || ""),
            el("td", {}, el("span", { class: `job-state ${j.state}` }, j.state)),
            el("td", { class: "num" }, progress),
            el("td", { class: "meta" }, waiting || ""));
}

export function fleetCard(gw, page) {
  const controllers = [...gw.controllers.values()].sort((a, b) => a.id.localeCompare(b.id));
  const jobs = [...gw.jobs.values()].sort((a, b) => a.id.localeCompare(b.id));
  const title = page ? el("a", { href: page, class: "fleet-gateway-link", target: "_blank", rel: "noopener" }, gw.id)
    : gw.id;
  const online = gw.online === true ? "yes" : gw.online === false ? "no" : "unknown";
  return el("section", { class: `card fleet-gateway${gw.online === false ? " fleet-offline" : ""}`,
                         "data-gateway": gw.id, "data-online": online },
            el("div", { class: "card-head" }, el("h2", {}, title), onlineBadge(gw)),
            statusLine(gw),
            el("table", { class: "fleet-controllers" },
               el("tbody", {}, ...controllers.map((c) => controllerRow(c, page)))),
            controllers.length ? null : el("p", { class: "meta" }, "no controllers"),
            gw.controllersCapped ? el("p", { class: "meta" }, `only the first ${MAX_CONTROLLERS} controllers shown`) : null,
            el("h3", {}, "Jobs running ", el("span", { class: "meta", "data-job-count": jobs.length }, `(${jobs.length})`)),
            jobs.length ? el("table", { class: "fleet-jobs" }, el("tbody", {}, ...jobs.map((j) => jobRow(j, page))))
              : el("p", { class: "meta" }, "none"),
            gw.jobsCapped ? el("p", { class: "meta" }, `only ${MAX_JOBS} jobs kept`) : null,
            page ? el("a", { class: "card-open", href: page, target: "_blank", rel: "noopener" }, "Open its dashboard →")
              : el("p", { class: "meta fleet-no-page" }, "its page's address is not known (set http.public_url on it, or “Gateway pages” here)"));
}
