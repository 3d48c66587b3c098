"""Jobs that record (issue 35: `"record": true` in a job spec), end to end: the real asi-gateway with an
external ms2000-sim whose report port answers TTL pulses (its control socket's `pulse N RATE_HZ`),
real HTTP clients (every answer checked against openapi/openapi.yaml), a real SQLite file, the rows
read back by pandas:

- the spec is checked (a boolean; a controller with a report port; not a planar correction) and the
  dry run shows the recording and the trigger input it sets;
- an array run advanced by triggers records one frame per trigger at the well the stage stood at (the
  job history's measured positions), names the job, tells its start and end in the job's history,
  and leaves the trigger input as it found it;
- a G-code trace records the triggers that come while it runs;
- a HALT stops the run and its recording, a resume records again (a recording per run); a cancel
  stops the recording and the input is put back;
- a recording already running on the controller fails the job before it moves.
"""

import argparse
import io
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gateway_fixture import TOKENS, Fixture, check, run_main, wait_until  # noqa: E402

from http_api_test import Contract  # noqa: E402
import recordings_api_test as rec  # noqa: E402  (its call/download/input_mode, against the same contract)

import pandas  # noqa: E402  (Debian python3-pandas)

VIEWER = TOKENS["viewer"]
GRID = {"grid": {"columns": 3, "rows": 1, "column_step_mm": 1, "row_step_mm": -1}, "a1": {"X": 0, "Y": 0},
        "mode": "host"}


def submit(port, controller, job_type, spec, dry_run=False):
    path = "/api/v1/jobs?dry_run=true" if dry_run else "/api/v1/jobs"
    return rec.call(port, "POST", path, {"controller": controller, "type": job_type, "spec": spec})


def job_of(port, job_id):
    status, job = rec.call(port, "GET", f"/api/v1/jobs/{job_id}", token=VIEWER)
    check(status == 200, f"GET job: {status} {job}")
    return job


def wait_job(port, job_id, state, waiting_for=None, steps_done=None):
    def reached():
        job = job_of(port, job_id)
        if job["state"] in ("failed", "cancelled") and state not in ("failed", "cancelled"):
            check(False, f"the job ended {job['state']}: {job['reason']}")
        ok = job["state"] == state
        ok = ok and (waiting_for is None or job["progress"]["waiting_for"] == waiting_for)
        ok = ok and (steps_done is None or job["progress"]["steps_done"] == steps_done)
        return job if ok else None
    return wait_until(f"job {state} (waiting for {waiting_for}, {steps_done} steps done)", reached)


def recording_events(port, job_id):
    status, body = rec.call(port, "GET", f"/api/v1/jobs/{job_id}/events", token=VIEWER)
    check(status == 200, f"job events: {status} {body}")
    return [e for e in body["events"] if e["type"] == "recording"]


def recordings_of(port, job_id):
    status, body = rec.call(port, "GET", f"/api/v1/recordings?job={job_id}", token=VIEWER)
    check(status == 200, f"recordings of the job: {status} {body}")
    return sorted(body["recordings"], key=lambda r: r["started"])


def frames(port, rid):
    _, text = rec.download(port, rid, "csv")
    return pandas.read_csv(io.StringIO(text), float_precision="round_trip")


def x_um(port):
    status, body = rec.call(port, "GET", "/api/v1/controllers/ext2", token=VIEWER)
    check(status == 200, f"GET controller: {status} {body}")
    return {a["axis"]: a["position_um"] for a in body["axes"]}["X"]


def input_on(port):
    return rec.input_mode(port).rsplit("=", 1)[-1].strip() != "0"  # ":A X=0": off


def pulse(sim, n, rate_hz):
    edges = json.loads(sim.control("state"))["ttl_edges"]
    check(sim.control(f"pulse {n} {rate_hz}") == "ok", "pulse")
    wait_until(f"{n} edges", lambda: json.loads(sim.control("state"))["ttl_edges"] - edges >= n)


def test_spec_and_plan(port):
    status, body = submit(port, "ext2", "array", {**GRID, "record": "yes"}, dry_run=True)
    check(status == 422 and body.get("field") == "spec.record", f"record must be a boolean: {status} {body}")
    status, body = submit(port, "ext1", "array", {**GRID, "record": True}, dry_run=True)
    check(status == 422 and body.get("field") == "spec.record" and "report port" in body.get("detail", ""),
          f"a controller without a report port: {status} {body}")
    status, body = submit(port, "ext2", "planar_correction", {"record": True}, dry_run=True)
    check(status == 422 and body.get("field") == "spec.record", f"a planar correction records nothing: {status} {body}")
    status, body = submit(port, "ext2", "array", {**GRID, "record": False}, dry_run=True)
    check(status == 200 and body["plan"]["record"] is False, f"record false: {status} {body}")
    check(not input_on(port), f"the input is off before: {rec.input_mode(port)}")
    status, body = submit(port, "ext2", "array", {**GRID, "record": True}, dry_run=True)
    plan = body["plan"]
    check(status == 200 and plan["record"] is True and "records" in plan["summary"], f"the plan records: {body}")
    check(plan["commands"][0] == "TTL X=1" and plan["commands"][-1] == "TTL X=0",
          f"the input is set first and put back last: {plan['commands']}")
    # Every type that moves can record.
    scan = {"fast": {"start_mm": 0, "stop_mm": 1}, "slow": {"lines": 2, "stop_mm": 0.1}}
    tour = {"positions": [{"X": 0, "Y": 0}, {"X": 500, "Y": 0}], "trigger": "ttl"}
    for job_type, spec in (("scan", scan), ("ring_buffer", tour), ("gcode", {"program": "G01 X1 F60\n"})):
        status, body = submit(port, "ext2", job_type, {**spec, "record": True}, dry_run=True)
        check(status == 200 and body["plan"]["record"] is True, f"a {job_type} job records: {status} {body}")


def test_array_records_each_trigger(port, sim):
    before_mode = rec.input_mode(port)
    status, job = submit(port, "ext2", "array", {**GRID, "advance": "ttl", "record": True})
    check(status == 201, f"submit: {status} {job}")
    jid = job["id"]
    # Each trigger makes a frame at the well the stage stands at, and moves the job on to the next.
    for done in (1, 2):
        wait_job(port, jid, "running", waiting_for="ttl", steps_done=done)
        pulse(sim, 1, 10)
    wait_job(port, jid, "succeeded")

    recordings = recordings_of(port, jid)
    check(len(recordings) == 1, f"one recording for one run: {recordings}")
    r = recordings[0]
    check(r["job"] == jid and r["state"] == "stopped" and r["frames"] == 2 and r["losses"] == 0,
          f"the run's recording: {r}")
    check(r["metadata"] == {"job": jid, "job_type": "array", "first_step": 0}, f"metadata: {r['metadata']}")
    status, body = rec.call(port, "GET", "/api/v1/recordings?job=j-nothing", token=VIEWER)
    check(status == 200 and body["recordings"] == [], f"another job has none: {body}")

    table = frames(port, r["id"])
    check(list(table["index"]) == [0, 1] and table["loss"].isna().all(), f"frames 0 and 1: {table}")
    status, body = rec.call(port, "GET", f"/api/v1/jobs/{jid}/events", token=VIEWER)
    steps = [e for e in body["events"] if e["type"] == "step"]
    for k in (0, 1):
        for axis in "XY":
            at = steps[k]["position"][axis]
            check(abs(table[f"{axis}_um"][k] - at) < 0.5,
                  f"frame {k} at well {steps[k]['well']}: {axis}={table[f'{axis}_um'][k]} vs {at}")

    events = recording_events(port, jid)
    check([e["state"] for e in events] == ["recording", "stopped"], f"its start and end in the history: {events}")
    check(all(e["recording"] == r["id"] for e in events) and events[-1]["frames"] == 2, f"events: {events}")
    check(rec.input_mode(port) == before_mode, f"the input put back: {rec.input_mode(port)} vs {before_mode}")


def test_gcode_records_while_it_runs(port, sim):
    before_mode = rec.input_mode(port)
    program = "G21 G90\nG01 X2 Y0 F60\nG01 X0 F60\n"  # 4 s of feed along X
    status, job = submit(port, "ext2", "gcode", {"program": program, "record": True})
    check(status == 201, f"submit: {status} {job}")
    jid = job["id"]
    wait_job(port, jid, "running")
    wait_until("the recording", lambda: recordings_of(port, jid))
    wait_until("the trigger input set by the run", lambda: input_on(port))
    pulse(sim, 100, 100)
    wait_job(port, jid, "succeeded")
    r = recordings_of(port, jid)[0]
    check(r["state"] == "stopped" and r["frames"] == 100 and r["losses"] == 0, f"every trigger of the run: {r}")
    table = frames(port, r["id"])
    check(list(table["index"]) == list(range(100)), "frames 0..99")
    check(((table["X_um"] >= -0.5) & (table["X_um"] <= 2000.5)).all(), f"on the path: {table['X_um'].describe()}")
    check(table["X_um"].nunique() > 10, f"the stage moved under the triggers: {table['X_um'].unique()[:20]}")
    check(rec.input_mode(port) == before_mode, f"the input put back: {rec.input_mode(port)}")


def test_halt_resume_cancel(port, sim):
    before_mode = rec.input_mode(port)
    status, job = submit(port, "ext2", "array", {**GRID, "advance": "next", "record": True})
    check(status == 201, f"submit: {status} {job}")
    jid = job["id"]
    wait_job(port, jid, "running", waiting_for="next", steps_done=1)
    pulse(sim, 5, 100)
    status, body = rec.call(port, "POST", "/api/v1/controllers/ext2/halt", token=TOKENS["operator"])
    check(status in (200, 202), f"HALT: {status} {body}")
    wait_job(port, jid, "paused")
    first = wait_until("the recording stopped by the HALT",
                       lambda: [r for r in recordings_of(port, jid) if r["state"] != "recording"])
    check(first[0]["frames"] == 5, f"the triggers before the HALT: {first}")
    status, body = rec.call(port, "POST", f"/api/v1/jobs/{jid}/resume")
    check(status == 200, f"resume: {status} {body}")
    wait_job(port, jid, "running", waiting_for="next")
    both = wait_until("a second recording", lambda: len(recordings_of(port, jid)) == 2 and recordings_of(port, jid))
    check(both[1]["state"] == "recording" and both[1]["metadata"]["first_step"] >= 1,
          f"the resumed run records again, from the step it resumes at: {both}")
    pulse(sim, 3, 100)
    wait_until("3 frames", lambda: recordings_of(port, jid)[1]["frames"] == 3)
    status, body = rec.call(port, "POST", f"/api/v1/jobs/{jid}/cancel")
    check(status == 200, f"cancel: {status} {body}")
    wait_job(port, jid, "cancelled")
    ended = wait_until("the second recording stopped",
                       lambda: recordings_of(port, jid)[1]["state"] != "recording" and recordings_of(port, jid))
    check(ended[1]["state"] == "stopped" and ended[1]["frames"] == 3, f"stopped with its frames: {ended[1]}")
    wait_until("the input put back", lambda: rec.input_mode(port) == before_mode)
    states = [e["state"] for e in recording_events(port, jid)]
    check(states == ["recording", "stopped", "recording", "stopped"], f"two runs, two recordings: {states}")


def test_recording_already_running(port):
    status, mine = rec.call(port, "POST", "/api/v1/controllers/ext2/recordings", {"name": "by hand"})
    check(status == 201, f"a recording by hand: {status} {mine}")
    try:
        before = x_um(port)
        status, job = submit(port, "ext2", "array", {**GRID, "a1": {"X": 3000, "Y": 0}, "record": True})
        check(status == 201, f"submit: {status} {job}")
        failed = wait_job(port, job["id"], "failed")
        check("cannot record" in failed["reason"] and "recording already" in failed["reason"],
              f"the reason: {failed['reason']}")
        check(abs(x_um(port) - before) < 1 and abs(before - 3000) > 100, f"nothing moved: X {before} -> {x_um(port)}")
    finally:
        rec.call(port, "POST", f"/api/v1/recordings/{mine['id']}/stop")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    ap.add_argument("--sim", required=True)
    ap.add_argument("--openapi", required=True)
    args = ap.parse_args()
    with open(args.openapi) as f:
        rec.CONTRACT = Contract(f.read())

    fx = Fixture("gw-job-recordings-test-")
    try:
        port, ext2, _ = rec.start_rig(fx, args)
        fx.run("spec.record is checked; the dry run shows the recording and the input it sets", test_spec_and_plan,
               port)
        fx.run("an array run advanced by triggers: a frame per trigger at its well, named in the job's history",
               test_array_records_each_trigger, port, ext2)
        fx.run("a G-code trace records the triggers that come while it runs", test_gcode_records_while_it_runs,
               port, ext2)
        fx.run("HALT stops the run and its recording, a resume records again, a cancel stops it",
               test_halt_resume_cancel, port, ext2)
        fx.run("a recording already running fails the job before it moves", test_recording_already_running, port)
        return fx.stop_and_report()
    finally:
        fx.cleanup()


if __name__ == "__main__":
    run_main(main)
