#!/usr/bin/python3
"""End-to-end test of the jobs and leases API: the real asi-gateway with three simulated controllers
in-process (--simulate 3: sim1 = full build with ARRAY/RING BUFFER/SCAN, sim2 = plain, sim3 = planar
correction) sped up with --time-scale, a temporary job store (config storage.path), real HTTP and
WebSocket clients.

It posts every example of the POST /api/v1/jobs requestBody in openapi/openapi.yaml (dry run, then a
real run to a final state) and validates every response body against the schema the document gives
for its path, method and status (the Contract of http_api_test.py). Then: submit/get/list/filter/
paginate, dry run moves nothing, idempotency, leases (409 for others, holder allowed, expiry, renew,
release, force by admin), cancel/pause/resume/next, WebSocket job commands and events on jobs/<id>
in order (and the topic retired events.ended_job_topic_ttl_s after the job ended: its subscriber and a
late resume get a "retired" event, the history stays stored), bad inputs, and a gateway restart mid-job with kill -9 (history intact, the job
interrupted with its steps_done, nothing resent; resume completes it).

Run by ctest with Debian's /usr/bin/python3 (python3-yaml, python3-jsonschema).
Exit code 0 when every check passed; the failures are listed otherwise.
"""

import argparse
import datetime
import os
import sqlite3
import sys
import time

import yaml

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gateway_fixture import TOKENS, WAIT, Failure, Fixture, auth_tokens, check, free_port, wait_until  # noqa: E402
from http_api_test import Client, Contract  # noqa: E402
from ws_api_test import WsClient  # noqa: E402

OP = TOKENS["operator"]
VIEW = TOKENS["viewer"]
ADMIN = TOKENS["admin"]
TERMINAL = {"succeeded", "failed", "cancelled"}
TIME_SCALE = 20
JOB_WAIT = 180.0  # a whole job on a loaded 2-core machine


def job_body(controller, type_, spec):
    return {"controller": controller, "type": type_, "spec": spec}


def small_next_array(controller="sim2", columns=3):
    """A host-driven grid that waits for a `next` call at every well: deterministic mid-job states."""
    return job_body(controller, "array", {"grid": {"columns": columns, "rows": 1, "column_step_mm": 0.2,
                                                   "row_step_mm": -0.2},
                                          "a1": {"X": 0, "Y": 0}, "advance": "next", "mode": "host"})


def submit(c, body, status=201, token=OP, headers=None, query=""):
    r = c.request("POST", "/api/v1/jobs" + query, body, token=token, headers=headers)
    check(r.status == status, f"submit {body['type']} on {body['controller']}: expected {status}, "
                              f"got {r.status}: {r.body[:400]}")
    return r


def get_job(c, job_id, token=VIEW):
    r = c.request("GET", f"/api/v1/jobs/{job_id}", token=token)
    check(r.status == 200, f"GET job {job_id}: {r.status} {r.body[:300]}")
    return r.json()


def control(c, job_id, action, status=200, token=OP, headers=None):
    r = c.request("POST", f"/api/v1/jobs/{job_id}/{action}", token=token, headers=headers)
    check(r.status == status, f"{action} {job_id}: expected {status}, got {r.status}: {r.body[:300]}")
    return r


def wait_state(c, job_id, states, timeout=JOB_WAIT):
    states = {states} if isinstance(states, str) else set(states)
    return wait_until(f"job {job_id} in {sorted(states)}",
                      lambda: (lambda j: j if j["state"] in states else None)(get_job(c, job_id)), timeout)


def waiting_for_next(job):
    return job["state"] == "running" and job["progress"]["waiting_for"] == "next"


def epoch_s(timestamp):
    """Seconds since the epoch of a gateway timestamp ("2026-11-22T05:30:00.123Z")."""
    t = datetime.datetime.strptime(timestamp, "%Y-%m-%dT%H:%M:%S.%fZ")
    return t.replace(tzinfo=datetime.timezone.utc).timestamp()


def run_to_end(c, job_id, cancel_after_steps=None, timeout=JOB_WAIT):
    """Polls the job to a final state, answering `next` waits; cancels once steps_done reaches
    cancel_after_steps (long plans). Returns the final job."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        j = get_job(c, job_id)
        if j["state"] in TERMINAL:
            return j
        if j["state"] in ("paused", "interrupted"):
            raise Failure(f"job {job_id} stopped in {j['state']}: {j['reason']}")
        if cancel_after_steps is not None and j["progress"]["steps_done"] >= cancel_after_steps:
            control(c, job_id, "cancel")
            return wait_state(c, job_id, TERMINAL)
        if waiting_for_next(j):
            r = c.request("POST", f"/api/v1/jobs/{job_id}/next", token=OP)
            check(r.status in (200, 409), f"next {job_id}: {r.status} {r.body[:300]}")
        time.sleep(0.1)
    raise Failure(f"job {job_id} did not finish in {timeout} s: {get_job(c, job_id)}")


def position(c, controller):
    r = c.request("GET", f"/api/v1/controllers/{controller}", token=VIEW)
    return {a["axis"]: a["position_um"] for a in r.json()["axes"]}, r.json()["busy"]


def wait_idle(c, controller):
    return wait_until(f"{controller} idle", lambda: (lambda p: p if not p[1] else None)(position(c, controller)))


# --------------------------------------------------------------------------------------------
# The tests


def expected_path(c, body):
    """The path an example must run on: the one its spec's mode names, else what the controller's
    build and the spec allow (the planners' rules: sim1/sim3 have ARRAY and RING BUFFER, sim1 SCAN,
    sim2 none), so that an example that silently falls back to the host path fails."""
    spec = body["spec"]
    if spec.get("mode", "auto") in ("firmware", "host"):
        return spec["mode"]
    if body["type"] == "planar_correction":
        return "firmware"  # no host path
    if body["type"] == "gcode":
        return "host"  # always traced by the gateway
    r = c.request("GET", f"/api/v1/controllers/{body['controller']}", token=VIEW)
    modules = set((r.json().get("identity") or {}).get("modules", []))
    if body["type"] == "array":  # the ARRAY module: no rotation, no subset, serpentine only
        fits = spec.get("rotation_deg", 0) == 0 and "wells" not in spec and spec.get("order") != "raster"
        return "firmware" if "array" in modules and fits else "host"
    if body["type"] == "scan":
        return "firmware" if "scan" in modules else "host"
    if body["type"] == "ring_buffer":  # IN0 only latches reports on TTL_REPORT builds
        trigger = spec.get("trigger", "autoplay")
        fits = (trigger == "autoplay" or "ttl_report" not in modules) and not (
            trigger == "ttl" and len(spec["positions"]) < 2)
        return "firmware" if "ring_buffer" in modules and fits else "host"
    raise Failure(f"no expected path for an example of type {body['type']}")


def test_examples(c, contract, results, skip=()):
    """Every named example of POST /api/v1/jobs: a dry run (200, a plan), then a real run to a final
    state (succeeded; plans over 20 steps are cancelled after their first steps). Records per
    example what happened in `results`; fails listing every example that did not work."""
    examples = contract.doc["paths"]["/api/v1/jobs"]["post"]["requestBody"]["content"]["application/json"]["examples"]
    check(len(examples) >= 8, f"only {len(examples)} examples")
    types = {contract.deref(e)["value"]["type"] for e in examples.values()}
    check(types == {"array", "scan", "ring_buffer", "planar_correction", "gcode"}, f"example types {types}")
    problems = []
    for name, ex in examples.items():
        if name in skip:
            results[name] = "skipped (--skip-examples)"
            problems.append(name)
            continue
        body = contract.deref(ex)["value"]
        path = expected_path(c, body)
        r = c.request("POST", "/api/v1/jobs?dry_run=true", body, token=OP)
        if r.status != 200:
            results[name] = f"dry run {r.status}: {r.json().get('detail', '')[:160]}"
            problems.append(name)
            continue
        plan = r.json()["plan"]
        if plan["steps_total"] < 1 or plan["estimated_s"] < 0:
            problems.append(name)
            results[name] = f"dry run plan without steps: {plan['summary']}"
            continue
        if plan["path"] != path:
            problems.append(name)
            results[name] = f"dry run planned the {plan['path']} path, not {path}: {plan.get('warnings')}"
            continue
        r = c.request("POST", "/api/v1/jobs", body, token=OP)
        if r.status != 201:
            results[name] = f"dry run ok ({plan['path']}), submit {r.status}: {r.json().get('detail', '')[:160]}"
            problems.append(name)
            continue
        job = r.json()
        try:
            final = run_to_end(c, job["id"], cancel_after_steps=2 if plan["steps_total"] > 20 else None)
        except Failure as e:
            results[name] = f"run: {e}"
            problems.append(name)
            continue
        ok = final["state"] == ("cancelled" if plan["steps_total"] > 20 else "succeeded") and final["path"] == path
        results[name] = (f"{final['state']} ({final['path']}, expected {path}, {final['progress']['steps_done']}/"
                         f"{final['progress']['steps_total']} steps) {final['reason']}").strip()
        if not ok:
            problems.append(name)
        wait_idle(c, body["controller"])
    check(not problems, "examples that did not work: " + "; ".join(f"{n}: {results[n]}" for n in problems))


def test_submit_get_list(c):
    a = submit(c, small_next_array("sim2", 2))
    check(a.header("Location") == "/api/v1/jobs/" + a.json()["id"], f"Location {a.header('Location')}")
    ja = a.json()
    check(ja["state"] in ("queued", "running") and ja["controller"] == "sim2" and ja["type"] == "array",
          f"new job {ja}")
    check(ja["submitted_by"] == "operator1" and ja["request_id"] == a.header("X-Request-Id"), f"who/request id {ja}")
    b = submit(c, small_next_array("sim3", 2)).json()
    got = get_job(c, ja["id"])
    check(got["id"] == ja["id"] and got["spec"] == ja["spec"], f"GET differs: {got}")
    # Lists: newest first, filters, pagination.
    r = c.request("GET", "/api/v1/jobs?limit=500", token=VIEW)
    ids = [j["id"] for j in r.json()["jobs"]]
    check(ids.index(b["id"]) < ids.index(ja["id"]), "newest first")
    r = c.request("GET", "/api/v1/jobs?controller=sim3&type=array", token=VIEW)
    check(r.status == 200 and all(j["controller"] == "sim3" and j["type"] == "array" for j in r.json()["jobs"]),
          f"filter: {r.body[:300]}")
    check(b["id"] in [j["id"] for j in r.json()["jobs"]], "filtered list has the sim3 job")
    r = c.request("GET", "/api/v1/jobs?state=succeeded&controller=sim3", token=VIEW)
    check(b["id"] not in [j["id"] for j in r.json()["jobs"]], "state filter")
    seen = []
    before = None
    for _ in range(200):
        r = c.request("GET", "/api/v1/jobs?limit=1" + (f"&before={before}" if before else ""), token=VIEW)
        page = r.json()
        check(len(page["jobs"]) <= 1, "limit=1 gives at most one job")
        seen += [j["id"] for j in page["jobs"]]
        before = page["next"]
        if before is None:
            break
    check(seen == ids, f"pages of one give the same jobs in the same order ({len(seen)} vs {len(ids)})")
    for q, field in [("limit=0", "limit"), ("limit=x", "limit"), ("state=done", "state"), ("type=tour", "type"),
                     ("page=2", "page"), ("limit=501", "limit")]:
        p = c.problem("GET", "/api/v1/jobs?" + q, 422, "invalid-value", token=VIEW)
        check(p.get("field") == field, f"?{q} names {p.get('field')}")
    for j in (ja, b):
        control(c, j["id"], "cancel")
        wait_state(c, j["id"], "cancelled")


def test_dry_run_moves_nothing(c):
    wait_idle(c, "sim2")
    before, _ = position(c, "sim2")
    listed = len(c.request("GET", "/api/v1/jobs?controller=sim2&limit=500", token=VIEW).json()["jobs"])
    body = job_body("sim2", "array", {"plate": "24", "a1": {"X": 5000, "Y": 5000}, "mode": "host"})
    r = submit(c, body, status=200, query="?dry_run=true")
    d = r.json()
    check(d["dry_run"] is True and d["plan"]["steps_total"] == 24 and d["plan"]["commands"], f"dry run {d}")
    check(d["plan"]["bounds"]["min"]["X"] <= 5000 <= d["plan"]["bounds"]["max"]["X"], f"bounds {d['plan']['bounds']}")
    time.sleep(0.3)  # a job launched by mistake would be moving by now
    after, busy = position(c, "sim2")
    check(not busy and after == before, f"sim2 moved: {before} -> {after}")
    listed_after = len(c.request("GET", "/api/v1/jobs?controller=sim2&limit=500", token=VIEW).json()["jobs"])
    check(listed_after == listed, "a dry run stored a job")
    # Out of the soft limits: 422 naming the step.
    far = job_body("sim2", "array", {"plate": "96", "a1": {"X": 100000, "Y": 0}, "mode": "host"})
    p = c.problem("POST", "/api/v1/jobs?dry_run=true", 422, "invalid-value", body=far, token=OP)
    check(p.get("field", "").startswith("spec"), f"soft limit problem names {p.get('field')}: {p['detail']}")


def test_idempotency(c):
    body = small_next_array("sim2", 2)
    first = submit(c, body, headers={"Idempotency-Key": "e2e-key-1"})
    again = submit(c, body, status=200, headers={"Idempotency-Key": "e2e-key-1"})
    check(again.header("Idempotency-Replayed") == "true", f"replay header {again.header('Idempotency-Replayed')}")
    check(again.json()["id"] == first.json()["id"], "a replay returns the first job")
    check(first.json()["idempotency_key"] == "e2e-key-1", "the key is on the job")
    other = submit(c, body, headers={"Idempotency-Key": "e2e-key-2"})
    check(other.json()["id"] != first.json()["id"], "another key, another job")
    c.problem("POST", "/api/v1/jobs", 422, "invalid-value", body=body, token=OP,
              headers={"Idempotency-Key": "has space"})
    # The key reused for another request, or by another client: refused, not answered with the first job.
    p = c.problem("POST", "/api/v1/jobs", 422, "invalid-value", body=small_next_array("sim2", 3), token=OP,
                  headers={"Idempotency-Key": "e2e-key-1"})
    check(p.get("field") == "Idempotency-Key" and first.json()["id"] in p["detail"], f"reused key: {p}")
    p = c.problem("POST", "/api/v1/jobs", 422, "invalid-value", body=body, token=ADMIN,
                  headers={"Idempotency-Key": "e2e-key-1"})
    check(first.json()["id"] not in p["detail"], f"another client's job is named: {p['detail']}")
    for j in (first.json(), other.json()):
        control(c, j["id"], "cancel")


def test_leases(c):
    base = "/api/v1/controllers/sim2"
    wait_idle(c, "sim2")
    r = c.request("POST", base + "/lease", {"ttl_s": 60, "holder": "notebook-3"}, token=OP)
    check(r.status == 201, f"acquire: {r.status} {r.body}")
    lease = r.json()
    lid = lease["lease_id"]
    check(lease["holder"] == "operator1/notebook-3" and lease["controller"] == "sim2", f"lease {lease}")
    r = c.request("GET", base + "/lease", token=VIEW)
    check(r.status == 200 and "lease_id" not in r.json() and r.json()["holder"] == "operator1/notebook-3",
          f"GET lease {r.body}")
    # The list: this lease, without its id, as GET .../lease shows it.
    r = c.request("GET", "/api/v1/leases", token=VIEW)
    listed = [x for x in r.json()["leases"] if x["controller"] == "sim2"]
    check(r.status == 200 and len(listed) == 1 and "lease_id" not in listed[0] and
          listed[0]["holder"] == "operator1/notebook-3" and listed[0]["expires"] == lease["expires"],
          f"GET /api/v1/leases {r.body}")
    c.problem("POST", "/api/v1/leases", 405, "method-not-allowed", token=OP)
    # Others: 409 leased for moves, operations, jobs; halt is always allowed.
    p = c.problem("POST", base + "/move", 409, "leased", body={"axes": {"X": 100}}, token=OP)
    check("operator1/notebook-3" in p["detail"], f"leased problem names the holder: {p['detail']}")
    c.problem("POST", base + "/move", 409, "leased", body={"axes": {"X": 100}}, token=OP,
              headers={"Lease-Id": "l-not-the-lease"})
    c.problem("POST", base + "/zero", 409, "leased", token=OP)
    c.problem("POST", "/api/v1/jobs", 409, "leased", body=small_next_array("sim2", 2), token=OP)
    c.problem("POST", base + "/lease", 409, "leased", body={}, token=ADMIN)
    r = c.request("POST", base + "/halt", token=OP)
    check(r.status == 200, f"halt while leased: {r.status} {r.body}")
    # The holder: allowed.
    held = {"Lease-Id": lid}
    r = c.request("POST", base + "/move", {"axes": {"X": 200}, "wait": True}, token=OP, headers=held)
    check(r.status == 200, f"holder's move: {r.status} {r.body}")
    job = submit(c, small_next_array("sim2", 2), headers=held).json()
    c.problem("POST", f"/api/v1/jobs/{job['id']}/cancel", 409, "leased", token=OP)
    control(c, job["id"], "cancel", headers=held)
    # Renew moves the expiry; a wrong id is refused.
    r = c.request("POST", base + "/lease/renew", {"ttl_s": 600}, token=OP, headers=held)
    check(r.status == 200 and r.json()["expires"] > lease["expires"], f"renew: {r.status} {r.body}")
    c.problem("POST", base + "/lease/renew", 409, "invalid-state", body={"ttl_s": 60}, token=OP,
              headers={"Lease-Id": "l-wrong"})
    c.problem("POST", base + "/lease/renew", 422, "invalid-value", body={"ttl_s": 60}, token=OP)
    c.problem("POST", base + "/lease/renew", 422, "invalid-value", body={"ttl_s": 0}, token=OP, headers=held)
    # Release: the wrong id is refused, the right one works, then the controller is free.
    c.problem("DELETE", base + "/lease", 409, "invalid-state", token=OP, headers={"Lease-Id": "l-wrong"})
    c.problem("DELETE", base + "/lease", 422, "invalid-value", token=OP)
    r = c.request("DELETE", base + "/lease", token=OP, headers=held, validate=False)  # 204: no body to validate
    check(r.status == 204 and r.body == "", f"release: {r.status} {r.body}")
    c.problem("GET", base + "/lease", 404, "not-found", token=VIEW)
    r = c.request("GET", "/api/v1/leases", token=VIEW)
    check(all(x["controller"] != "sim2" for x in r.json()["leases"]), f"a released lease is listed: {r.body}")
    r = c.request("POST", base + "/move", {"axes": {"X": 0}, "wait": True}, token=OP)
    check(r.status == 200, f"move after release: {r.status}")
    # Expiry.
    r = c.request("POST", base + "/lease", {"ttl_s": 1}, token=OP)
    check(r.status == 201, f"short lease: {r.status} {r.body}")
    wait_until("the 1 s lease to expire", lambda: c.request("GET", base + "/lease", token=VIEW).status == 404)
    r = c.request("POST", base + "/halt", token=OP)
    r = c.request("POST", base + "/zero", token=OP)
    check(r.status == 200, f"zero after expiry: {r.status} {r.body}")
    # Force: operators may not, admins may.
    lid2 = c.request("POST", base + "/lease", {}, token=OP).json()["lease_id"]
    c.problem("DELETE", base + "/lease?force=true", 403, "forbidden", token=OP)
    r = c.request("DELETE", base + "/lease?force=true", token=ADMIN, validate=False)
    check(r.status == 204, f"forced release: {r.status} {r.body}")
    c.problem("POST", base + "/lease/renew", 409, "invalid-state", body={}, token=OP, headers={"Lease-Id": lid2})
    # Roles and unknown controllers.
    c.problem("POST", base + "/lease", 403, "forbidden", body={}, token=VIEW)
    c.problem("GET", "/api/v1/controllers/nope/lease", 404, "unknown-controller", token=VIEW)
    c.problem("POST", base + "/lease", 422, "invalid-value", body={"ttl_s": 60, "color": "red"}, token=OP)
    c.problem("PUT", base + "/lease", 405, "method-not-allowed", token=OP)


def test_lease_waits_for_earlier_jobs(c):
    # Jobs submitted before a lease were not submitted under it: while one holds the controller or waits
    # for it, the lease is refused (409 busy, naming them) rather than letting them move a leased stage.
    base = "/api/v1/controllers/sim2"
    running = submit(c, small_next_array("sim2", 2)).json()
    wait_until("the first job to run", lambda: waiting_for_next(get_job(c, running["id"])))
    queued = submit(c, small_next_array("sim2", 2)).json()
    p = c.problem("POST", base + "/lease", 409, "busy", body={}, token=ADMIN)
    check(running["id"] in p["detail"] and queued["id"] in p["detail"], f"busy names the jobs: {p['detail']}")
    c.problem("GET", base + "/lease", 404, "not-found", token=VIEW)
    control(c, running["id"], "cancel")
    c.problem("POST", base + "/lease", 409, "busy", body={}, token=ADMIN)  # the queued one would run next
    control(c, queued["id"], "cancel")
    wait_state(c, queued["id"], "cancelled")
    r = c.request("POST", base + "/lease", {"ttl_s": 60}, token=ADMIN)
    check(r.status == 201, f"lease on a free controller: {r.status} {r.body}")
    r = c.request("DELETE", base + "/lease", token=ADMIN, headers={"Lease-Id": r.json()["lease_id"]}, validate=False)
    check(r.status == 204, f"release: {r.status}")


def test_cancel_pause_resume_next(c):
    # next: one well per call.
    job = submit(c, small_next_array("sim2", 3)).json()
    j = wait_until("the job to wait for next", lambda: (lambda j: j if waiting_for_next(j) else None)(get_job(c, job["id"])))
    done = j["progress"]["steps_done"]
    control(c, job["id"], "next")
    wait_until("steps_done to grow after next",
               lambda: get_job(c, job["id"])["progress"]["steps_done"] > done)
    # pause after the current step, resume continues from there.
    r = control(c, job["id"], "pause")
    # The pause takes effect after the current step, and this step waits for a `next` call: give it
    # one (409 when the pause already took effect between two steps).
    r = c.request("POST", f"/api/v1/jobs/{job['id']}/next", token=OP)
    check(r.status in (200, 409), f"next after pause: {r.status} {r.body[:300]}")
    paused = wait_state(c, job["id"], "paused")
    check(paused["reason"] != "" or True, "paused")
    steps_paused = paused["progress"]["steps_done"]
    check(paused["progress"]["steps_done"] >= done + 1, f"paused after the current step: {paused['progress']}")
    control(c, job["id"], "resume")
    final = run_to_end(c, job["id"])
    check(final["state"] == "succeeded" and final["progress"]["steps_done"] == 3,
          f"resumed job ended {final['state']} {final['progress']} (paused at {steps_paused})")
    c.problem("POST", f"/api/v1/jobs/{job['id']}/cancel", 409, "invalid-state", token=OP)
    c.problem("POST", f"/api/v1/jobs/{job['id']}/resume", 409, "invalid-state", token=OP)
    # cancel a running job: it stops with state cancelled and the stage idle.
    job = submit(c, small_next_array("sim2", 3)).json()
    wait_state(c, job["id"], "running")
    r = control(c, job["id"], "cancel")
    final = wait_state(c, job["id"], "cancelled")
    check(final["finished"] is not None, "a cancelled job has finished")
    wait_idle(c, "sim2")
    # cancel a queued job behind another.
    first = submit(c, small_next_array("sim2", 2)).json()
    second = submit(c, small_next_array("sim2", 2)).json()
    check(get_job(c, second["id"])["state"] == "queued", "the second job on a controller waits")
    control(c, second["id"], "cancel")
    check(get_job(c, second["id"])["state"] == "cancelled", "a queued job is cancelled at once")
    control(c, first["id"], "cancel")
    wait_state(c, first["id"], "cancelled")
    c.problem("POST", f"/api/v1/jobs/{first['id']}/pause", 403, "forbidden", token=VIEW)
    c.problem("POST", "/api/v1/jobs/j-01NOSUCHJOB0000000000000000/cancel", 404, "unknown-job", token=OP)


def test_state_events_without_the_program(c):
    """Issue 34: a job's state events carry its record without the spec, so an inline G-code program is
    stored once (with the job), not again with every transition (before: 0.6 MiB per state event)."""
    padding = "".join(f"(padding line {i:05d} so that the program is large: ................)\n"
                      for i in range(8000))
    moves = "".join("G01 X2 F60\nG01 X0\n" for _ in range(40))
    program = "G21 G90\n" + padding + moves
    check(len(program) > 500_000, f"program of {len(program)} bytes")
    job = submit(c, {"controller": "sim3", "type": "gcode", "spec": {"program": program}}).json()
    for _ in range(2):  # two pauses and resumes: each adds state events
        wait_state(c, job["id"], "running")
        control(c, job["id"], "pause")
        wait_state(c, job["id"], "paused")
        control(c, job["id"], "resume")
    control(c, job["id"], "cancel")
    wait_state(c, job["id"], TERMINAL)
    r = c.request("GET", f"/api/v1/jobs/{job['id']}/events", token=VIEW)
    check(r.status == 200, f"events: {r.status}")
    events = r.json()["events"]
    states = [e for e in events if e["type"] == "state"]
    check(len(states) >= 6, f"{len(states)} state events")
    check(all("spec" not in e["job"] for e in states), "a state event carries the spec")
    size = len(r.body)
    check(size < 100_000, f"the job's events take {size} bytes for a {len(program)}-byte program")
    stored = get_job(c, job["id"])
    check(stored["spec"]["program"] == program, "the job itself lost its program")


def test_waiting_for_and_eta(c):
    """A job that waits for `next` says so (waiting_for), keeps the motion ahead in remaining_s and has no
    eta; a `next` gives it an eta of now + remaining_s; the waits are events on its history; the list
    filters by controller and state and shows the same; an ended job has neither."""
    job = submit(c, job_body("sim2", "array", {"grid": {"columns": 3, "rows": 1, "column_step_mm": 2,
                                                        "row_step_mm": -1},
                                               "a1": {"X": 0, "Y": 0}, "advance": "next", "mode": "host"})).json()
    jid = job["id"]
    check(job["progress"]["remaining_s"] is not None and job["progress"]["remaining_s"] > 0,
          f"a next-advance job has its motion estimated from the start: {job['progress']}")
    j = wait_until("the job to wait for next", lambda: (lambda j: j if waiting_for_next(j) else None)(get_job(c, jid)))
    p = j["progress"]
    check(j["reason"] == "" and p["steps_done"] == 1, f"waiting job {j['state']} {j['reason']!r} {p}")
    check(p["remaining_s"] is not None and p["remaining_s"] > 0, f"the two moves ahead are in remaining_s: {p}")
    check(p["eta"] is None, f"no eta while waiting for next: {p}")
    # Filters: controller and state together; the listed job is the one GET shows.
    listed = c.request("GET", "/api/v1/jobs?controller=sim2&state=running", token=VIEW).json()["jobs"]
    check([x["id"] for x in listed] == [jid], f"controller+state filter: {[x['id'] for x in listed]}")
    check(listed[0]["progress"]["waiting_for"] == "next", f"the list shows the wait: {listed[0]['progress']}")
    other = c.request("GET", "/api/v1/jobs?controller=sim3&state=running", token=VIEW).json()["jobs"]
    check(jid not in [x["id"] for x in other], "another controller's filter lists it")
    before = time.time()
    r = control(c, jid, "next").json()
    after = time.time()
    check(r["progress"]["waiting_for"] is None and r["progress"]["eta"] is not None,
          f"after next: waiting_for {r['progress']['waiting_for']}, eta {r['progress']['eta']}")
    eta = epoch_s(r["progress"]["eta"])
    ahead = p["remaining_s"]
    check(before + ahead - 0.5 <= eta <= after + ahead + 0.5,
          f"eta {r['progress']['eta']} is not now + {ahead} s (asked at {before:.3f}..{after:.3f})")
    final = run_to_end(c, jid)
    check(final["state"] == "succeeded", f"ended {final['state']}: {final['reason']}")
    check(final["progress"]["waiting_for"] is None and final["progress"]["eta"] is None
          and final["progress"]["remaining_s"] == 0, f"an ended job: {final['progress']}")
    # The history: every wait and its end as a state event; steps with what a plate map shows.
    events = c.request("GET", f"/api/v1/jobs/{jid}/events", token=VIEW).json()["events"]
    waits = [e for e in events if e["type"] == "state" and e.get("waiting_for") == "next"]
    check(len(waits) == 2 and all(e["state"] == "running" and e["eta"] is None for e in waits),
          f"two next waits in the history: {[(e['type'], e.get('state'), e.get('waiting_for')) for e in events]}")
    steps = [e for e in events if e["type"] == "step"]
    check([s["well"] for s in steps] == ["A1", "A2", "A3"], f"wells {[s.get('well') for s in steps]}")
    for s, x in zip(steps, (0, 2000, 4000)):
        check(abs(s["target"]["X"] - x) < 0.01 and abs(s["target"]["Y"]) < 0.01, f"target of {s['well']}: {s}")
        check(abs(s["position"]["X"] - x) <= 1 and abs(s["position"]["Y"]) <= 1, f"measured {s['well']}: {s}")
        check(before - 60 < epoch_s(s["at"]) < time.time() + 1, f"at of {s['well']}: {s['at']}")
    check([epoch_s(s["at"]) for s in steps] == sorted(epoch_s(s["at"]) for s in steps), "steps in time order")


def test_bad_inputs(c):
    ok = small_next_array("sim2", 2)
    c.problem("POST", "/api/v1/jobs", 400, "malformed-json", raw_body=b'{"controller": ', token=OP,
              headers={"Content-Type": "application/json"})
    p = c.problem("POST", "/api/v1/jobs", 422, "invalid-value", body={**ok, "priority": 1}, token=OP)
    check(p.get("field") == "priority", f"unknown field names {p.get('field')}")
    c.problem("POST", "/api/v1/jobs", 404, "unknown-controller", body={**ok, "controller": "nope"}, token=OP)
    p = c.problem("POST", "/api/v1/jobs", 422, "invalid-value", body={**ok, "type": "tour"}, token=OP)
    check(p.get("field") == "type", f"wrong type names {p.get('field')}")
    p = c.problem("POST", "/api/v1/jobs", 422, "invalid-value", body={**ok, "type": 3}, token=OP)
    check(p.get("field") == "type", f"type 3 names {p.get('field')}")
    p = c.problem("POST", "/api/v1/jobs", 422, "invalid-value",
                  body={**ok, "spec": {**ok["spec"], "colour": "red"}}, token=OP)
    check(p.get("field", "").startswith("spec"), f"unknown spec field names {p.get('field')}")
    p = c.problem("POST", "/api/v1/jobs", 422, "invalid-value", body={**ok, "spec": []}, token=OP)
    check(p.get("field") == "spec", f"spec [] names {p.get('field')}")
    c.problem("POST", "/api/v1/jobs", 422, "invalid-value", token=OP)  # no body
    c.problem("POST", "/api/v1/jobs", 422, "invalid-value", body=[1], token=OP)
    c.problem("POST", "/api/v1/jobs?dry_run=maybe", 422, "invalid-value", body=ok, token=OP)
    c.problem("POST", "/api/v1/jobs?dryrun=true", 422, "invalid-value", body=ok, token=OP)
    c.problem("POST", "/api/v1/jobs", 403, "forbidden", body=ok, token=VIEW)
    c.problem("POST", "/api/v1/jobs", 401, "unauthorized", body=ok)
    c.problem("GET", "/api/v1/jobs/j-01NOSUCHJOB0000000000000000", 404, "unknown-job", token=VIEW)
    c.problem("GET", "/api/v1/jobs/j-01NOSUCHJOB0000000000000000/events", 404, "unknown-job", token=VIEW)
    c.problem("GET", "/api/v1/jobs/not.an.id", 404, "unknown-job", token=VIEW)
    c.problem("DELETE", "/api/v1/jobs", 405, "method-not-allowed", token=OP)
    c.problem("GET", "/api/v1/jobs/j-01NOSUCHJOB0000000000000000/cancel", 405, "method-not-allowed", token=OP)
    c.problem("GET", "/api/v1/jobs/j-01NOSUCHJOB0000000000000000/frobnicate", 404, "not-found", token=OP,
              validate=False)
    c.problem("GET", "/api/v1/jobs?before=a%2Fb", 422, "invalid-value", token=VIEW)
    c.problem("GET", "/api/v1/jobs?limit=%zz", 422, "invalid-value", token=VIEW)


def ws_request(ws, obj, seen):
    """WsClient.request that keeps the events it skips in `seen`."""
    ws.send(obj)
    return ws.wait_for(lambda m: m.get("type") in ("result", "error", "subscribed") and m.get("id") == obj.get("id"),
                       f"the answer to {obj}", seen=seen)


def test_websocket(c, port):
    ws = WsClient(port, OP, "jobs")
    skipped = []
    # Submit over the WebSocket; subscribe to its topic with resume 0 (the hub replays its buffer).
    r = ws.request({"op": "job", "id": "s1", "action": "submit", "args": small_next_array("sim3", 3)})
    check(r["type"] == "result" and r["result"]["state"] in ("queued", "running"), f"ws submit {r}")
    job_id = r["result"]["id"]
    topic = f"jobs/{job_id}"
    ack = ws.request({"op": "subscribe", "id": "sub", "topics": [topic], "resume": {topic: 0}})
    check(ack["type"] == "subscribed", f"subscribe {ack}")
    r = ws_request(ws, {"op": "job", "id": "g1", "action": "get", "job": job_id}, skipped)
    check(r["type"] == "result" and r["result"]["id"] == job_id, f"ws get {r}")
    r = ws_request(ws, {"op": "job", "id": "d1", "action": "submit", "dry_run": True,
                        "args": small_next_array("sim3", 3)}, skipped)
    check(r["type"] == "result" and r["result"]["dry_run"] is True, f"ws dry run {r}")
    events = [m for m in skipped if m.get("type") == "event" and m.get("topic") == topic]
    n = 0
    deadline = time.monotonic() + JOB_WAIT
    while True:
        check(time.monotonic() < deadline, f"ws job did not finish; events {events[-3:]}")
        j = get_job(c, job_id)
        if j["state"] in TERMINAL:
            break
        if waiting_for_next(j):
            n += 1
            got = []
            r = ws_request(ws, {"op": "job", "id": f"n{n}", "action": "next", "job": job_id}, got)
            events += [m for m in got if m.get("type") == "event" and m.get("topic") == topic]
            check(r["type"] in ("result", "error"), f"ws next {r}")
        try:
            while True:
                m = ws.recv_json(timeout=0.2)
                if m.get("type") == "event" and m.get("topic") == topic:
                    events.append(m)
        except (OSError, Failure):
            pass
    check(j["state"] == "succeeded", f"ws job ended {j['state']}: {j['reason']}")
    # Events until the final state event.
    deadline = time.monotonic() + WAIT
    while not any(e["data"].get("state") == "succeeded" for e in events):
        check(time.monotonic() < deadline, f"no final state event; got {[e['data'].get('type') for e in events]}")
        m = ws.wait_for(lambda m: m.get("type") == "event" and m.get("topic") == topic, "job events")
        events.append(m)
    seqs = [e["seq"] for e in events]
    check(seqs == sorted(seqs) and len(set(seqs)) == len(seqs), f"sequence numbers in order: {seqs}")
    steps = [e["data"]["index"] for e in events if e["data"].get("type") == "step"]
    check(steps == sorted(steps) and len(steps) == 3, "step events in order, one per well: " +
          str([(e["seq"], e["data"].get("type"), e["data"].get("index"), e["data"].get("name")) for e in events]))
    names = [e["data"]["name"] for e in events if e["data"].get("type") == "step"]
    check(names == ["A1", "A2", "A3"], f"step names {names}")
    states = [e["data"]["state"] for e in events if "state" in e["data"] and e["data"].get("type") != "step"]
    check(states and states[-1] == "succeeded" and "running" in states, f"state events {states}")
    # The stored history has the same events in the same order.
    stored = c.request("GET", f"/api/v1/jobs/{job_id}/events", token=VIEW).json()["events"]
    check([e.get("type") for e in stored] == [e["data"].get("type") for e in events],
          f"stored {[e.get('type') for e in stored]} vs live {[e['data'].get('type') for e in events]}")
    # The ended job's topic leaves the gateway's memory events.ended_job_topic_ttl_s (3 s here) after its
    # last event: its subscriber is told ("retired", with the last sequence number), and so is a client
    # that resumes it later, instead of hearing nothing. The history stays in GET .../events.
    last_seq = max(seqs)
    gone = ws.wait_for(lambda m: m.get("type") == "retired" and m.get("topic") == topic, "the retired event",
                       timeout=30)
    check(gone["last_seq"] >= last_seq and "data" not in gone, f"retired {gone}")
    late = WsClient(port, VIEW, "late")
    ack = late.request({"op": "subscribe", "id": "late", "topics": ["jobs/#"], "resume": {topic: 2}})
    check(ack["type"] == "subscribed", f"late subscribe {ack}")
    m = late.wait_for(lambda m: m.get("topic") == topic, "an answer for the retired topic", timeout=10)
    check(m["type"] == "retired" and m["last_seq"] == gone["last_seq"], f"late resume of a retired topic: {m}")
    late.close()
    stored = c.request("GET", f"/api/v1/jobs/{job_id}/events", token=VIEW).json()["events"]
    check(len(stored) >= len(events), f"the history is still stored: {len(stored)} events")
    # Errors and leases over the WebSocket.
    r = ws.request({"op": "job", "id": "c9", "action": "cancel", "job": job_id})
    check(r["type"] == "error" and r["problem"]["type"].endswith("/invalid-state"), f"cancel finished {r}")
    r = ws.request({"op": "job", "id": "u1", "action": "get", "job": "j-01NOSUCHJOB0000000000000000"})
    check(r["type"] == "error" and r["problem"]["status"] == 404, f"unknown job {r}")
    lid = c.request("POST", "/api/v1/controllers/sim3/lease", {"ttl_s": 60}, token=ADMIN).json()["lease_id"]
    r = ws.request({"op": "command", "id": "m1", "controller": "sim3", "operation": "move", "args": {"axes": {"X": 10}}})
    check(r["type"] == "error" and r["problem"]["type"].endswith("/leased"), f"ws move while leased {r}")
    r = ws.request({"op": "command", "id": "m2", "controller": "sim3", "operation": "move",
                    "args": {"axes": {"X": 10}}, "lease": lid})
    check(r["type"] == "result", f"ws move with the lease {r}")
    r = ws.request({"op": "job", "id": "s2", "action": "submit", "args": small_next_array("sim3", 2)})
    check(r["type"] == "error" and r["problem"]["type"].endswith("/leased"), f"ws job while leased {r}")
    r = ws.request({"op": "job", "id": "s3", "action": "submit", "args": small_next_array("sim3", 2), "lease": lid})
    check(r["type"] == "result", f"ws job with the lease {r}")
    leased_job = r["result"]["id"]
    for action in ("next", "pause", "cancel"):
        r = ws.request({"op": "job", "id": f"x-{action}", "action": action, "job": leased_job})
        check(r["type"] == "error" and r["problem"]["type"].endswith("/leased"), f"ws {action} without the lease {r}")
    r = ws.request({"op": "job", "id": "s4", "action": "cancel", "job": leased_job, "lease": lid})
    check(r["type"] == "result", f"ws cancel with the lease {r}")
    c.request("DELETE", "/api/v1/controllers/sim3/lease", token=ADMIN, headers={"Lease-Id": lid}, validate=False)
    viewer = WsClient(port, VIEW, "viewer")
    r = viewer.request({"op": "job", "id": "v1", "action": "submit", "args": small_next_array("sim3", 2)})
    check(r["type"] == "error" and r["problem"]["status"] == 403, f"viewer submit {r}")
    r = viewer.request({"op": "job", "id": "v2", "action": "get", "job": job_id})
    check(r["type"] == "result", f"viewer get {r}")
    viewer.close()
    ws.close()


def test_restart(fx, c, args, config, extra):
    """kill -9 mid-job; after the restart the history is intact, the job is interrupted with its
    steps_done and nothing was sent; resume completes it."""
    job = submit(c, small_next_array("sim2", 4)).json()
    jid = job["id"]
    wait_until("the job to wait for next", lambda: waiting_for_next(get_job(c, jid)))
    control(c, jid, "next")
    j = wait_until("two wells done", lambda: (lambda j: j if waiting_for_next(j) and j["progress"]["steps_done"] >= 2
                                               else None)(get_job(c, jid)))
    steps_before = j["progress"]["steps_done"]
    events_before = c.request("GET", f"/api/v1/jobs/{jid}/events", token=VIEW).json()["events"]
    listed_before = [x["id"] for x in c.request("GET", "/api/v1/jobs?limit=500", token=VIEW).json()["jobs"]]
    fx.gateway.kill()  # SIGKILL: no shutdown path runs
    fx.gateway.wait(timeout=WAIT)
    fx.start_gateway(args.gateway, config, extra)
    j = get_job(c, jid)
    check(j["state"] == "interrupted", f"after kill -9 the job is {j['state']}")
    check(j["progress"]["steps_done"] == steps_before, f"steps_done {j['progress']['steps_done']} != {steps_before}")
    check(j["reason"], "an interrupted job says why")
    listed_after = [x["id"] for x in c.request("GET", "/api/v1/jobs?limit=500", token=VIEW).json()["jobs"]]
    check(listed_after == listed_before, "the job history survived the restart")
    events_after = c.request("GET", f"/api/v1/jobs/{jid}/events", token=VIEW).json()["events"]
    check(events_after[:len(events_before)] == events_before, "stored events survived the restart unchanged")
    new_types = [e.get("type") for e in events_after[len(events_before):]]
    check("step" not in new_types, f"nothing ran after the restart: new events {new_types}")
    # Nothing is sent: the restarted simulator stays at its start position and idle.
    pos, busy = position(c, "sim2")
    check(not busy, "sim2 is idle after the restart")
    time.sleep(1.0)  # an absence check: a resend would have started a move by now
    pos2, busy2 = position(c, "sim2")
    check(pos2 == pos and not busy2 and get_job(c, jid)["state"] == "interrupted",
          f"sim2 moved or the job changed after the restart: {pos} -> {pos2}")
    control(c, jid, "resume")
    final = run_to_end(c, jid)
    check(final["state"] == "succeeded" and final["progress"]["steps_done"] == 4, f"resumed: {final['state']} "
                                                                                    f"{final['progress']}")
    names = [e["name"] for e in c.request("GET", f"/api/v1/jobs/{jid}/events", token=VIEW).json()["events"]
             if e.get("type") == "step"]
    check(len(names) == len(set(names)), f"no well was visited twice: {names}")


def check_wal_checkpointed(store_dir):
    """After a clean exit the WAL has been checkpointed into the database: jobs.sqlite3-wal is gone or empty."""
    wal = os.path.join(store_dir, "jobs.sqlite3-wal")
    size = os.path.getsize(wal) if os.path.exists(wal) else 0
    check(size == 0, f"{wal} holds {size} bytes after a clean exit")


def test_full_store(fx, args, contract):
    """Another program fills the store beyond storage.max_size_mb: a submission is refused with 503
    storage-unavailable (nothing stored, nothing queued) and the gateway keeps answering."""
    port = free_port()
    store = os.path.join(fx.tmp, "store-full")
    config = {
        "http": {"listen_address": "127.0.0.1", "port": port},
        "storage": {"path": store, "max_size_mb": 1},
        "auth": auth_tokens(),
        "logging": {"level": "info"},
    }
    extra = ["--simulate", "3", "--time-scale", str(TIME_SCALE), "--sim-dir", os.path.join(fx.tmp, "sims-full")]
    gateway = fx.start_gateway(args.gateway, config, extra)
    c = Client(port, contract)
    # A program of 20 KiB inline: the job's row takes more than a page, so storing it needs new pages
    # (a fresh store has room in the pages it has for anything smaller).
    program = "G21 G90\n" + "".join(f"(comment {i:04d} making the program longer .........)\n" for i in range(400))
    body = job_body("sim2", "gcode", {"program": program + "G01 X1 F60\n"})
    submit(c, body, status=200, query="?dry_run=true")  # a valid job: only the store can refuse it
    filler = sqlite3.connect(os.path.join(store, "jobs.sqlite3"), timeout=10)
    try:
        filler.execute("CREATE TABLE filler (b BLOB)")
        filler.execute("INSERT INTO filler VALUES (zeroblob(?))", (2 * 1024 * 1024,))
        filler.commit()
    finally:
        filler.close()
    p = c.problem("POST", "/api/v1/jobs", 503, "storage-unavailable", body=body, token=OP)
    check("full" in p["detail"], f"the problem says why: {p['detail']}")
    check(c.request("GET", "/api/v1/jobs?controller=sim2", token=VIEW).json()["jobs"] == [],
          "the refused job was not stored")
    r = c.request("GET", "/api/v1/ready", token=None, validate=False)
    check(r.status == 200, f"ready after the refusal: {r.status}")
    gateway.terminate()
    code = gateway.wait(timeout=WAIT)
    check(code == 0, f"SIGTERM exit code {code}")
    check_wal_checkpointed(store)


def cancel_leftovers(c):
    """Cancels every job a failed test left active, so that its controller is free for the next test."""
    r = c.request("GET", "/api/v1/jobs?limit=500", token=VIEW, validate=False)
    if r.status != 200:
        return
    for j in r.json()["jobs"]:
        if j["state"] not in TERMINAL:
            c.request("POST", f"/api/v1/jobs/{j['id']}/cancel", token=ADMIN, validate=False)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    ap.add_argument("--openapi", required=True)
    ap.add_argument("--only", default="", help="test names separated by ; (default: all)")
    ap.add_argument("--skip-examples", default="", help="comma-separated example names not to post (diagnosis)")
    args = ap.parse_args()
    with open(args.openapi) as f:
        contract = Contract(f.read())
    fx = Fixture("gw-jobs-")
    only = set(filter(None, args.only.split(";")))

    def run(name, fn, *a):
        if not only or name in only:
            fx.run(name, fn, *a)
            try:
                cancel_leftovers(c)
            except (OSError, Failure):
                pass

    results = {}
    try:
        port = free_port()
        config = {
            "http": {"listen_address": "127.0.0.1", "port": port},
            "storage": {"path": os.path.join(fx.tmp, "store")},
            "auth": auth_tokens(),
            "logging": {"level": "info"},
            "events": {"ended_job_topic_ttl_s": 3},  # test_websocket waits for a topic to retire
        }
        extra = ["--simulate", "3", "--time-scale", str(TIME_SCALE), "--sim-dir", os.path.join(fx.tmp, "sims")]
        fx.start_gateway(args.gateway, config, extra)
        c = Client(port, contract)
        run("openapi document is valid", contract.check_structure)
        run("bad inputs", test_bad_inputs, c)
        run("submit, get, list, filter, paginate", test_submit_get_list, c)
        run("dry run moves nothing", test_dry_run_moves_nothing, c)
        run("idempotency", test_idempotency, c)
        run("leases", test_leases, c)
        run("a lease waits for earlier jobs", test_lease_waits_for_earlier_jobs, c)
        run("cancel, pause, resume, next", test_cancel_pause_resume_next, c)
        run("waiting_for and eta", test_waiting_for_and_eta, c)
        run("state events without the program", test_state_events_without_the_program, c)
        run("websocket job commands and events", test_websocket, c, port)
        run("every openapi example (dry run and real run)", test_examples, c, contract, results,
            set(filter(None, args.skip_examples.split(","))))
        run("restart with kill -9 mid-job", test_restart, fx, c, args, config, extra)
        if results:
            print("examples:")
            for name, what in results.items():
                print(f"  {name}: {what}")
        fx.gateway.terminate()
        fx.expect_exit_0()
        run("the WAL is checkpointed at a clean exit", check_wal_checkpointed, config["storage"]["path"])
        run("a full store refuses submissions and the gateway answers", test_full_store, fx, args, contract)
        fx.finish_log(80)
    finally:
        fx.cleanup()
    return fx.report(f"; {len(contract.covered)} (path, method, status) combinations validated against the schema")


if __name__ == "__main__":
    sys.exit(main())
