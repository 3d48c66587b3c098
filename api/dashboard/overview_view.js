// The overview: one card per controller (overview.js), in id order, live from the store. Also the
// running job of each controller (one GET /api/v1/jobs?state=running every few seconds for all of
// them: cheaper than following every job's topic) and, when some controller has a report port, the
// rate and gaps of its encoder reports (controllers/+/reports: counted, never drawn).

import * as api from "./api.js";
import { store } from "./store.js";
import { ControllerCard } from "./overview.js";
import { ReportStats } from "./report_stats.js";
import { el } from "./dom.js";

const JOB_POLL_MS = 3000;
const hasReportPort = (s) => Boolean(s?.report_port && s.report_port !== "none");

export function mount(container) {
  const grid = el("div", { class: "cards", id: "cards" });
  container.append(grid);
  const cards = new Map();

  const cardOf = (id) => {
    let c = cards.get(id);
    if (!c) {
      c = new ControllerCard(id);
      cards.set(id, c);
      const ids = [...cards.keys()].sort();
      const next = cards.get(ids[ids.indexOf(id) + 1]);
      grid.insertBefore(c.root, next ? next.root : null);
    }
    return c;
  };

  // Encoder reports: followed only while some controller has a report port.
  const reportStats = new Map();  // controller id -> ReportStats
  let stopReports = null;
  const countReport = (msg) => {
    const id = /^controllers\/([^/]+)\/reports$/.exec(msg.topic || "")?.[1];
    if (!id) return;
    if (!reportStats.has(id)) reportStats.set(id, new ReportStats());
    reportStats.get(id).count(msg);
  };
  const updateReportFollow = () => {
    const wanted = [...store.controllers.values()].some((c) => hasReportPort(c.state));
    if (wanted && !stopReports) stopReports = store.follow("controllers/+/reports", countReport);
    else if (!wanted && stopReports) {
      stopReports();
      stopReports = null;
    }
  };
  const showReports = () => {
    for (const [id, c] of cards) {
      const port = hasReportPort(store.controllers.get(id)?.state);
      if (port && !reportStats.has(id)) reportStats.set(id, new ReportStats());
      const stats = port ? reportStats.get(id) : null;
      stats?.updateRate();
      c.setReports(stats);
    }
  };

  const render = ({ id, controller, what }) => {
    const c = cardOf(id);
    if (what === "gap") c.gap();
    else if (what === "state") {
      c.setState(controller.state);
      updateReportFollow();
      showReports();
    } else if (controller.position) c.setPositions(controller.position.axes, controller.position.busy);
  };
  for (const [id, controller] of store.controllers) {
    if (controller.state) render({ id, controller, what: "state" });
  }
  const showLease = ({ id, lease, error }) => cardOf(id).setLease(lease, error);
  for (const [id, entry] of store.leases) showLease({ id, ...entry });

  // Running jobs: one request for every controller; a failed poll leaves the cards as they were.
  let jobTimer = null;
  let stopped = false;
  const pollJobs = async () => {
    try {
      const page = await api.listJobs({ state: "running" });
      const running = new Map(page.jobs.map((j) => [j.controller, j]));
      for (const [id, c] of cards) c.setJob(running.get(id) || null);
    } catch {
      // the live banner already says when the gateway is away
    }
    if (!stopped) jobTimer = setTimeout(pollJobs, JOB_POLL_MS);
  };
  pollJobs();
  const reportTimer = setInterval(showReports, 1000);

  const stops = [store.on("controller", render), store.on("lease", showLease)];
  return () => {
    stopped = true;
    clearTimeout(jobTimer);
    clearInterval(reportTimer);
    stopReports?.();
    for (const stop of stops) stop();
    for (const c of cards.values()) c.destroy?.();
  };
}
