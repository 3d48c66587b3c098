#!/usr/bin/python3
"""storage.retention (issue 34) end to end: the real asi-gateway keeps the newest 2 ended jobs and the
newest 6 audit entries, sweeping every second, with one simulated controller.

Checks: of five jobs run to their end, the three oldest disappear (GET 404, also their events), the
newest two stay; a job still queued behind a lease is never deleted; the audit trail is cut back to
its newest entries after a sweep; the log says what was deleted; after a restart the bound still holds.

Run by ctest with Debian's /usr/bin/python3. Exit code 0 when every check passed.
"""

import argparse
import json
import os
import sys

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gateway_fixture import Fixture, check, free_port, http_request, run_main, wait_until  # noqa: E402

ARRAY = {"controller": "sim1", "type": "array",
         "spec": {"grid": {"columns": 1, "rows": 1, "column_step_mm": 1, "row_step_mm": -1},
                  "a1": {"X": 0, "Y": 0}, "mode": "host"}}


def rest(port, method, path, body=None):
    status, text = http_request(port, method, path, body, token=None)
    return status, (json.loads(text) if text else None)


def ended_jobs(port):
    """The ended jobs the gateway lists (at most 100)."""
    return [j for j in rest(port, "GET", "/api/v1/jobs?limit=100")[1]["jobs"]
            if j["state"] in ("succeeded", "failed", "cancelled")]


def run_job(port):
    status, job = rest(port, "POST", "/api/v1/jobs", ARRAY)
    check(status == 201, f"submit: {status} {job}")
    wait_until(f"job {job['id']} ended", lambda: rest(port, "GET", f"/api/v1/jobs/{job['id']}")[1]["state"]
               in ("succeeded", "failed", "cancelled"))
    return job["id"]


def test_ended_jobs_beyond_the_newest_two_go(port, ids):
    ids.extend(run_job(port) for _ in range(5))
    wait_until("the three oldest jobs deleted",
               lambda: all(rest(port, "GET", f"/api/v1/jobs/{i}")[0] == 404 for i in ids[:3]))
    for i in ids[3:]:
        status, job = rest(port, "GET", f"/api/v1/jobs/{i}")
        check(status == 200 and job["state"] == "succeeded", f"a newest job {i}: {status} {job}")
    status, _ = rest(port, "GET", f"/api/v1/jobs/{ids[0]}/events")
    check(status == 404, f"the events of a deleted job: {status}")


def test_active_jobs_stay(port):
    """A job that waits for `next` (running) and one queued behind it outlive many sweeps and more
    ended jobs than the bound."""
    waiting = {**ARRAY, "spec": {**ARRAY["spec"], "advance": "next",
                                 "grid": {"columns": 3, "rows": 1, "column_step_mm": 0.2, "row_step_mm": -0.2}}}
    status, running = rest(port, "POST", "/api/v1/jobs", waiting)
    check(status == 201, f"submit: {status} {running}")
    wait_until("the job waiting for next", lambda: rest(port, "GET", f"/api/v1/jobs/{running['id']}")[1]
               ["progress"]["waiting_for"] == "next")
    status, queued = rest(port, "POST", "/api/v1/jobs", ARRAY)
    check(status == 201, f"submit behind it: {status} {queued}")
    for _ in range(3):
        status, other = rest(port, "POST", "/api/v1/jobs", {**ARRAY, "controller": "sim2"})
        check(status == 201, f"submit on sim2: {status} {other}")
    wait_until("at most two ended jobs, sim2's done", lambda: (lambda jobs: len(
        [j for j in jobs if j["state"] in ("succeeded", "failed", "cancelled")]) <= 2 and not [
        j for j in jobs if j["controller"] == "sim2" and j["state"] in ("queued", "running")])(
        rest(port, "GET", "/api/v1/jobs?limit=100")[1]["jobs"]))
    for job, state in ((running, "running"), (queued, "queued")):
        status, now = rest(port, "GET", f"/api/v1/jobs/{job['id']}")
        check(status == 200 and now["state"] == state, f"the {state} job: {status} {now}")
    rest(port, "POST", f"/api/v1/jobs/{queued['id']}/cancel")
    rest(port, "POST", f"/api/v1/jobs/{running['id']}/cancel")


def audit_count(port):
    status, page = rest(port, "GET", "/api/v1/audit?limit=500")
    check(status == 200, f"audit: {status}")
    return len(page["entries"])


def test_audit_cut_back(port):
    for x in range(12):
        check(rest(port, "POST", "/api/v1/controllers/sim2/move", {"axes": {"X": x}})[0] == 200, "move")
    wait_until("the audit trail cut back to 6", lambda: audit_count(port) <= 6)
    status, page = rest(port, "GET", "/api/v1/audit?limit=1")
    check(page["entries"][0]["detail"]["axes"]["X"] == 11, f"the newest entry was not kept: {page['entries'][0]}")


def test_log_says_so(fx):
    with open(fx.log_path) as f:
        text = f.read()
    check("storage.retention: deleted" in text and "ended job(s)" in text, "no retention line for jobs in the log")
    check("audit entries" in text, "no retention line for the audit trail in the log")


def test_bound_holds_after_restart(fx, gateway, config, port):
    fx.gateway.terminate()
    fx.gateway.wait(timeout=60)
    fx.start_gateway(gateway, config)
    run_job(port)
    wait_until("at most two ended jobs after the restart", lambda: len(ended_jobs(port)) <= 2)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    args = ap.parse_args()
    fx = Fixture("gw-retention-test-")
    try:
        port = free_port()
        config = {"http": {"listen_address": "127.0.0.1", "port": port},
                  "simulate": {"count": 2, "time_scale": 20, "directory": os.path.join(fx.tmp, "sims")},
                  "storage": {"path": os.path.join(fx.tmp, "store"),
                              "retention": {"max_ended_jobs": 2, "max_audit_entries": 6, "sweep_interval_s": 1}},
                  "logging": {"level": "info"}}
        fx.start_gateway(args.gateway, config)
        ids = []
        fx.run("ended jobs beyond the newest two are deleted with their events",
               test_ended_jobs_beyond_the_newest_two_go, port, ids)
        fx.run("running and queued jobs are never deleted", test_active_jobs_stay, port)
        fx.run("the audit trail is cut back to its newest entries", test_audit_cut_back, port)
        fx.run("the log says what was deleted", test_log_says_so, fx)
        fx.run("the bound holds after a restart", test_bound_holds_after_restart, fx, args.gateway, config, port)
        return fx.stop_and_report()
    finally:
        fx.cleanup()


if __name__ == "__main__":
    run_main(main)
