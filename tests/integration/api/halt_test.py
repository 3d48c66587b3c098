#!/usr/bin/python3
"""HALT is the emergency stop (issue 31), end to end: the real asi-gateway, external ms2000-sims with
control sockets (sim1 full build: ARRAY, SCAN, RING BUFFER, TTL; sim2 plain; sim3 planar correction),
a real mosquitto, real HTTP, WebSocket and MQTT clients.

For each kind of job, a HALT in the middle of it: the stage stops (the simulator's motion ends at
most 100 ms of simulated time after the HALT was answered), no step follows it (steps and position
stay put while nobody resumes), a TTL-triggered mode is disarmed (IN0 pulses move nothing), a G-code
job's TTL output goes low, the job is paused with the reason "halted by <who>", the controller says
who halted it, and a resume finishes the job. Queued jobs do not start while the controller is halted
and a resume or a submission releases it. HALT ALL over REST, WebSocket and MQTT. A HALT is answered
while the controller is still being identified.

Run by ctest with Debian's /usr/bin/python3 (python3-paho-mqtt, python3-websockets not needed).
Exit code 0 when every check passed; the failures are listed otherwise.
"""

import argparse
import fcntl
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import termios
import time

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gateway_fixture import (TOKENS, Failure, Fixture, auth_tokens, check, free_port, run_main,  # noqa: E402
                             signing_keys_config, wait_until)
from http_api_test import Client, Contract  # noqa: E402
from mqtt_api_test import Broker, Client as MqttClient, command as mqtt_command  # noqa: E402
from ws_api_test import WsClient  # noqa: E402

OP = TOKENS["operator"]
VIEW = TOKENS["viewer"]
TIME_SCALE = 10
JOB_WAIT = 180.0
PREFIX = "halt-test"
# Simulated milliseconds the stage may still move after the HALT was answered (deceleration, the
# answer's own way back).
STOP_WITHIN_SIM_US = 100_000


def sim_state(sim):
    return json.loads(sim.control("state"))


def sim_xy(sim):
    axes = sim_state(sim)["axes"]
    return round(axes["X"]["position"]), round(axes["Y"]["position"])


def submit(c, controller, type_, spec, status=201):
    r = c.request("POST", "/api/v1/jobs", {"controller": controller, "type": type_, "spec": spec}, token=OP)
    check(r.status == status, f"submit {type_} on {controller}: {r.status} {r.body[:400]}")
    return r.json()["id"] if status == 201 else None


def job(c, job_id):
    r = c.request("GET", f"/api/v1/jobs/{job_id}", token=VIEW)
    check(r.status == 200, f"GET job {job_id}: {r.status} {r.body[:300]}")
    return r.json()


def wait_job(c, job_id, what, pred, timeout=JOB_WAIT):
    return wait_until(f"job {job_id}: {what}", lambda: (lambda j: j if pred(j) else None)(job(c, job_id)), timeout)


def action(c, job_id, name, status=200):
    r = c.request("POST", f"/api/v1/jobs/{job_id}/{name}", token=OP)
    check(r.status == status, f"{name} {job_id}: expected {status}, got {r.status}: {r.body[:300]}")
    return r


def controller(c, cid):
    r = c.request("GET", f"/api/v1/controllers/{cid}", token=VIEW)
    check(r.status == 200, f"GET controller {cid}: {r.status}")
    return r.json()


def halt(c, cid, token=OP):
    r = c.request("POST", f"/api/v1/controllers/{cid}/halt", token=token)
    check(r.status == 200, f"halt {cid}: {r.status} {r.body[:300]}")


def check_halted(c, sim, cid, job_id, who, halted_at_us):
    """After a HALT answered when the simulator's clock read `halted_at_us`: the stage stopped at once,
    the job is paused by it, and nothing moves or steps while nobody resumes."""
    j = wait_job(c, job_id, "paused by the HALT", lambda j: j["state"] == "paused")
    check(j["reason"] == f"halted by {who}", f"reason: {j['reason']!r}")
    check(controller(c, cid)["halted"]["by"] == who, f"controller halted: {controller(c, cid)['halted']}")
    wait_until(f"{cid} idle", lambda: not sim_state(sim)["busy"], 20)
    state = sim_state(sim)
    for name, axis in state["axes"].items():
        check(axis["motion_end_us"] <= halted_at_us + STOP_WITHIN_SIM_US,
              f"{cid} axis {name} moved until {axis['motion_end_us']} us, HALT answered at {halted_at_us} us")
    check(not state["array"]["self_scan"] and not state["scan"]["running"] and not state["ring_buffer"]["autoplay"],
          f"a firmware run still active: array {state['array']} scan {state['scan']}")
    steps, where = j["progress"]["steps_done"], sim_xy(sim)
    time.sleep(1.5)  # 15 s of simulated time
    j = job(c, job_id)
    check(j["state"] == "paused" and j["progress"]["steps_done"] == steps,
          f"a step after the HALT: {steps} -> {j['progress']['steps_done']} ({j['state']})")
    check(sim_xy(sim) == where, f"{cid} moved after the HALT: {where} -> {sim_xy(sim)}")
    return j


def halt_mid_run(c, sim, cid, job_id, started, who="operator1", token=OP):
    """Waits until `started(job)`, HALTs, checks check_halted(); returns the paused job."""
    wait_job(c, job_id, "under way", started)
    halt(c, cid, token)
    return check_halted(c, sim, cid, job_id, who, sim_state(sim)["time_us"])


def resume_to_end(c, cid, job_id, drive=None):
    """Resumes: the latch is released and the job ends well (`drive` makes a TTL/next job advance)."""
    action(c, job_id, "resume")
    check(controller(c, cid)["halted"] is None, "the resume released the HALT latch")
    deadline = time.monotonic() + JOB_WAIT
    while True:
        j = job(c, job_id)
        if j["state"] in ("succeeded", "failed", "cancelled"):
            break
        check(time.monotonic() < deadline, f"job {job_id} did not end after the resume: {j['state']}")
        if drive:
            drive(j)
        time.sleep(0.2)
    check(j["state"] == "succeeded", f"job {job_id} after the resume: {j['state']} ({j['reason']})")
    return j


# ---------------------------------------------------------------------------------------------
# HALT during each kind of job


def test_array_host(c, sims):
    job_id = submit(c, "sim2", "array", {"grid": {"columns": 6, "rows": 1, "column_step_mm": 3, "row_step_mm": -1},
                                         "a1": {"X": 0, "Y": 0}, "dwell_ms": 2000, "mode": "host"})
    j = halt_mid_run(c, sims["sim2"], "sim2", job_id, lambda j: j["progress"]["steps_done"] >= 1)
    check(j["progress"]["waiting_for"] == "halt", f"waiting_for: {j['progress']['waiting_for']}")
    done = resume_to_end(c, "sim2", job_id)
    check(done["progress"]["steps_done"] == 6, f"steps after the resume: {done['progress']}")


def check_edges_move_nothing(sim):
    """The TTL-triggered mode a halted job armed is put back: an IN0 edge now moves nothing."""
    check(sim_state(sim)["ttl"]["in0_mode"] == 0, f"IN0 mode after the HALT: {sim_state(sim)['ttl']}")
    where = sim_xy(sim)
    sim.control("pulse")
    time.sleep(1.0)
    check(sim_xy(sim) == where, f"an IN0 edge moved the halted stage: {where} -> {sim_xy(sim)}")


def test_array_firmware_ttl(c, sims):
    sim = sims["sim1"]
    job_id = submit(c, "sim1", "array", {"grid": {"columns": 4, "rows": 1, "column_step_mm": 1, "row_step_mm": -1},
                                         "a1": {"X": 0, "Y": 0}, "advance": "ttl", "mode": "firmware"})
    wait_job(c, job_id, "waiting for a TTL edge", lambda j: j["progress"]["waiting_for"] == "ttl")
    sim.control("pulse")
    halt_mid_run(c, sim, "sim1", job_id, lambda j: j["progress"]["steps_done"] >= 1)
    check_edges_move_nothing(sim)

    def pulse_when_waiting(j):
        if j["progress"]["waiting_for"] == "ttl":
            sim.control("pulse")
    resume_to_end(c, "sim1", job_id, pulse_when_waiting)


def test_scan_firmware(c, sims):
    job_id = submit(c, "sim1", "scan", {"fast_axis": "X", "slow_axis": "Y",
                                        "fast": {"start_mm": 0.0, "stop_mm": 4.0, "encoder_divide": 24},
                                        "slow": {"start_mm": 0.0, "stop_mm": 0.4, "lines": 8},
                                        "pattern": "serpentine", "mode": "firmware", "speed_mm_s": 0.5})
    halt_mid_run(c, sims["sim1"], "sim1", job_id, lambda j: j["progress"]["steps_done"] >= 1)
    resume_to_end(c, "sim1", job_id)


def test_ring_buffer_ttl(c, sims):
    # sim3: the RING BUFFER module steps by itself on each IN0 edge (IN0 mode 1). On sim1's
    # TTL_REPORT_INT build IN0 only latches reports and the tour would be host-driven.
    sim = sims["sim3"]
    job_id = submit(c, "sim3", "ring_buffer", {"positions": [{"X": 0, "Y": 0}, {"X": 1000, "Y": 500},
                                                             {"X": 2000, "Y": 0}, {"X": 3000, "Y": 500}],
                                               "axes": "XY", "trigger": "ttl"})
    wait_until("IN0 armed for the ring buffer", lambda: sim_state(sim)["ttl"]["in0_mode"] == 1, 30)
    sim.control("pulse")
    halt_mid_run(c, sim, "sim3", job_id, lambda j: j["progress"]["steps_done"] >= 1)
    check_edges_move_nothing(sim)

    def pulse_when_armed(j):
        if sim_state(sim)["ttl"]["in0_mode"] == 1 and not sim_state(sim)["busy"]:
            sim.control("pulse")
            time.sleep(0.3)
    resume_to_end(c, "sim3", job_id, pulse_when_armed)


def test_planar(c, sims):
    job_id = submit(c, "sim3", "planar_correction",
                    {"action": "set", "points": ["current", {"X": 20000, "Y": -20000, "Z": 10},
                                                 {"X": -20000, "Y": -20000, "Z": -5}]})
    halt_mid_run(c, sims["sim3"], "sim3", job_id, lambda j: j["progress"]["waiting_for"] == "next")

    def next_when_waiting(j):
        if j["progress"]["waiting_for"] == "next":
            c.request("POST", f"/api/v1/jobs/{job_id}/next", token=OP)
    resume_to_end(c, "sim3", job_id, next_when_waiting)


def test_gcode_ttl(c, sims):
    sim = sims["sim2"]
    program = "G21 G90\nG00 X0 Y0\nM03\nG01 X20 F60\nY5\nX0\nM05\nG00 X0 Y0\n"
    job_id = submit(c, "sim2", "gcode", {"program": program})
    wait_until("the TTL output high", lambda: sim_state(sim)["ttl"]["out0_mode"] == 1, 60)
    halt_mid_run(c, sim, "sim2", job_id, lambda j: j["state"] == "running")
    wait_until("the TTL output low after the HALT", lambda: sim_state(sim)["ttl"]["out0_mode"] == 0, 20)
    resume_to_end(c, "sim2", job_id)
    check(sim_state(sim)["ttl"]["out0_mode"] == 0, "the TTL output low at the end")


# ---------------------------------------------------------------------------------------------
# The latch: queued jobs wait; a resume or a submission releases it


def test_queued_jobs_wait(c, sims):
    first = submit(c, "sim2", "array", {"grid": {"columns": 4, "rows": 1, "column_step_mm": 2, "row_step_mm": -1},
                                        "a1": {"X": 0, "Y": 0}, "dwell_ms": 2000, "mode": "host"})
    second = submit(c, "sim2", "array", {"grid": {"columns": 2, "rows": 1, "column_step_mm": 1, "row_step_mm": -1},
                                         "a1": {"X": 0, "Y": 0}, "mode": "host"})
    halt_mid_run(c, sims["sim2"], "sim2", first, lambda j: j["progress"]["steps_done"] >= 1)
    action(c, first, "cancel")
    wait_job(c, first, "cancelled", lambda j: j["state"] == "cancelled")
    # The controller is still halted: the queued job does not start, and says why.
    time.sleep(1.0)
    j = wait_job(c, second, "waiting for the halt", lambda j: j["progress"]["waiting_for"] == "halt", 10)
    check(j["state"] == "queued", f"a queued job started on a halted controller: {j['state']}")
    check(controller(c, "sim2")["halted"] is not None, "the cancel released the latch")
    # Resuming the queued job is the decision to go on.
    action(c, second, "resume")
    wait_job(c, second, "succeeded", lambda j: j["state"] == "succeeded")
    check(controller(c, "sim2")["halted"] is None, "latch after the resume")
    # A submission releases it too.
    halt(c, "sim2")
    check(controller(c, "sim2")["halted"]["by"] == "operator1", "halted again")
    third = submit(c, "sim2", "array", {"grid": {"columns": 2, "rows": 1, "column_step_mm": 1, "row_step_mm": -1},
                                        "a1": {"X": 0, "Y": 0}, "mode": "host"})
    check(controller(c, "sim2")["halted"] is None, "latch after a submission")
    wait_job(c, third, "succeeded", lambda j: j["state"] == "succeeded")


def test_viewer_may_halt(c, sims):
    job_id = submit(c, "sim2", "array", {"grid": {"columns": 4, "rows": 1, "column_step_mm": 2, "row_step_mm": -1},
                                         "a1": {"X": 0, "Y": 0}, "dwell_ms": 2000, "mode": "host"})
    halt_mid_run(c, sims["sim2"], "sim2", job_id, lambda j: j["progress"]["steps_done"] >= 1, "viewer1", VIEW)
    action(c, job_id, "cancel")


# ---------------------------------------------------------------------------------------------
# A job holds its controller


ADMIN = TOKENS["admin"]
# The move waits for its end: "zero" right after it would otherwise find the stage still moving (409
# busy) on a loaded machine.
CHANGES = [("move", {"axes": {"X": 5}, "wait": True}), ("here", {"axes": {"X": 0}}), ("zero", {}),
           ("home", {"axes": ["Z"]}),
           ("speed", {"axes": {"X": 1}}), ("ttl", {"in0_mode": 0}), ("command", {"command": "S X=1"})]


def next_array(c, lease=None):
    headers = {"Lease-Id": lease} if lease else None
    r = c.request("POST", "/api/v1/jobs", {"controller": "sim2", "type": "array", "spec": {
        "grid": {"columns": 3, "rows": 1, "column_step_mm": 0.5, "row_step_mm": -0.5},
        "a1": {"X": 0, "Y": 0}, "advance": "next", "mode": "host"}}, token=OP, headers=headers)
    check(r.status == 201, f"submit: {r.status} {r.body[:300]}")
    job_id = r.json()["id"]
    wait_job(c, job_id, "waiting for next", lambda j: j["progress"]["waiting_for"] == "next")
    return job_id


def test_job_holds_its_controller(c, sims):
    job_id = next_array(c)
    base = "/api/v1/controllers/sim2"
    for op, body in CHANGES:
        p = c.problem("POST", f"{base}/{op}", 409, "job-active", body=body, token=ADMIN)
        check(job_id in p["detail"], f"{op}: the problem does not name the job: {p['detail']}")
    # Reads and HALT are everyone's.
    r = c.request("POST", f"{base}/command", {"command": "W X Y"}, token=ADMIN)
    check(r.status == 200, f"a raw read during the job: {r.status} {r.body[:200]}")
    check(c.request("GET", base, token=VIEW).status == 200, "GET the controller during the job")
    halt(c, "sim2")
    wait_job(c, job_id, "paused by the HALT", lambda j: j["state"] == "paused")
    c.problem("POST", f"{base}/move", 409, "job-active", body={"axes": {"X": 5}}, token=ADMIN)  # paused: still held
    action(c, job_id, "cancel")
    wait_job(c, job_id, "cancelled", lambda j: j["state"] == "cancelled")
    r = c.request("POST", f"{base}/move", {"axes": {"X": 5}, "wait": True}, token=OP)
    check(r.status == 200, f"a move once the job ended: {r.status} {r.body[:200]}")


def test_the_lease_holder_keeps_control(c, sims):
    base = "/api/v1/controllers/sim2"
    r = c.request("POST", base + "/lease", {"ttl_s": 120, "holder": "acquisition"}, token=OP)
    check(r.status in (200, 201), f"take the lease: {r.status} {r.body[:200]}")
    lease = r.json()["lease_id"]
    held = {"Lease-Id": lease}
    job_id = None
    try:
        job_id = next_array(c, lease)
        for op, body in CHANGES:
            if op == "command":
                continue  # admin only
            r = c.request("POST", f"{base}/{op}", body, token=OP, headers=held)
            check(r.status == 200, f"{op} by the job's lease holder: {r.status} {r.body[:200]}")
        c.problem("POST", f"{base}/move", 409, "leased", body={"axes": {"X": 5}}, token=OP)
    finally:
        # Also after a failed check: a job left running would hold sim2 for the tests after this one.
        if job_id:
            c.request("POST", f"/api/v1/jobs/{job_id}/cancel", token=OP, headers=held)
            wait_job(c, job_id, "cancelled", lambda j: j["state"] == "cancelled")
        c.request("DELETE", base + "/lease", token=OP, headers=held)


# ---------------------------------------------------------------------------------------------
# HALT ALL


def start_moves(c):
    """A long move on every controller (a job would hold the controller; these are a client's own)."""
    for cid in ("sim1", "sim2", "sim3"):
        r = c.request("POST", f"/api/v1/controllers/{cid}/move", {"axes": {"X": 60000}}, token=OP)
        check(r.status == 200, f"move {cid}: {r.status} {r.body[:200]}")
    wait_until("every stage moving", lambda: all(controller(c, cid)["busy"] for cid in ("sim1", "sim2", "sim3")), 20)


def check_all_halted(c, sims, answer, who):
    check(answer["operation"] == "halt_all", f"answer: {answer}")
    got = {a["id"]: a["halted"] for a in answer["controllers"]}
    check(got == {"sim1": True, "sim2": True, "sim3": True}, f"HALT ALL answered {answer['controllers']}")
    for cid, sim in sims.items():
        wait_until(f"{cid} idle after HALT ALL", lambda: not sim_state(sim)["busy"], 20)
        check(sim_xy(sim)[0] < 600000 - 1000, f"{cid} arrived although halted: {sim_xy(sim)}")
        check(controller(c, cid)["halted"]["by"] == who, f"{cid}: {controller(c, cid)['halted']}")


def back_home(c):
    for cid in ("sim1", "sim2", "sim3"):
        r = c.request("POST", f"/api/v1/controllers/{cid}/move", {"axes": {"X": 0, "Y": 0}, "wait": True}, token=OP)
        check(r.status == 200, f"move {cid} home: {r.status}")


def test_halt_all_rest(c, sims):
    start_moves(c)
    r = c.request("POST", "/api/v1/halt", token=VIEW)
    check(r.status == 200, f"POST /api/v1/halt: {r.status} {r.body[:300]}")
    check_all_halted(c, sims, r.json(), "viewer1")
    back_home(c)


def test_halt_all_ws(c, sims, port):
    start_moves(c)
    ws = WsClient(port, OP, "operator")
    a = ws.request({"op": "halt_all", "id": "stop-everything"})
    ws.close()
    check(a["type"] == "result" and a["id"] == "stop-everything", f"answer: {a}")
    check_all_halted(c, sims, a["result"], "operator1")
    back_home(c)


def test_halt_all_mqtt(c, sims, broker):
    start_moves(c)
    m = MqttClient(broker.port, "halt-test-client")
    reply = "halt-test-clients/replies"
    m.subscribe(reply)
    a = mqtt_command(m, f"{PREFIX}/lab/halt", {"id": "m-halt", "token": OP}, reply)  # signed with "operator"
    m.close()
    check(a["type"] == "result", f"answer: {a}")
    check_all_halted(c, sims, a["result"], "operator")  # the signing key's name
    back_home(c)


# ---------------------------------------------------------------------------------------------
# HALT before the controller is identified


def test_halt_before_identification(fx, args, contract):
    sim = fx.start_sim(args.sim, "late", "plain", time_scale=TIME_SCALE)
    sim.control("delay-next 3000")  # the first answer (to the identification) comes 3 s late
    port = free_port()
    config = {"http": {"listen_address": "127.0.0.1", "port": port}, "auth": auth_tokens(),
              "storage": {"path": os.path.join(fx.tmp, "late-store")},
              "controllers": [{"id": "late", "port": sim.link}]}
    cfg = os.path.join(fx.tmp, "late.json")
    with open(cfg, "w") as f:
        json.dump(config, f)
    with open(os.path.join(fx.tmp, "late.log"), "w") as log:
        proc = subprocess.Popen([args.gateway, "--config", cfg], stdout=log, stderr=log)
    fx.procs.append(proc)
    c = Client(port, contract)
    wait_until("late identifying", lambda: controller(c, "late")["state"] == "identifying", 30)
    r = c.request("POST", "/api/v1/controllers/late/halt", token=OP)
    check(r.status == 200, f"HALT while identifying: {r.status} {r.body[:300]}")
    proc.terminate()


# ---------------------------------------------------------------------------------------------
# Never refused for the gateway's own reasons


def raw_request(port, head, body=b""):
    """One raw HTTP/1.1 request on its own connection: (status, the socket still open)."""
    s = socket.create_connection(("127.0.0.1", port), timeout=30)
    s.sendall(head.encode() + body)
    data = b""
    while b"\r\n\r\n" not in data:
        chunk = s.recv(4096)
        if not chunk:
            break
        data += chunk
    return (int(data.split(b" ", 2)[1]) if data else None), s


def test_halt_beside_an_exhausted_body_budget(fx, args):
    # A gateway whose request bodies may take 1 MiB of memory in all; an operator's client declares a
    # body that large and sends one byte of it: its reservation holds the whole budget while it
    # trickles. (An unauthenticated client's body costs nothing: http_limits_test.py.)
    g = SoloGateway(fx, args, "budget")
    g.start({"limits": {"max_buffered_body_mb": 1, "max_body_bytes": 1048576}})
    hog = socket.create_connection(("127.0.0.1", g.port), timeout=30)
    hog.sendall(f"POST /api/v1/jobs HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer {OP}\r\n"
                "Content-Type: application/json\r\nContent-Length: 1048576\r\n\r\n{".encode())
    try:
        def budget_gone():
            r = g.c.request("POST", "/api/v1/controllers/budget/move", {"axes": {"X": 10}}, token=OP)
            return r.status == 503 and r.json()["type"].endswith("/body-budget-exhausted")
        wait_until("the body budget exhausted", budget_gone, 10)
        for path in ("/api/v1/controllers/budget/halt", "/api/v1/halt"):
            r = g.c.request("POST", path, {}, token=OP)  # with a body: it is not read
            check(r.status == 200, f"POST {path} with the budget exhausted: {r.status} {r.body[:200]}")
        # A HALT that declares a body of its own as large: answered from its header.
        status, s = raw_request(g.port, "POST /api/v1/controllers/budget/halt HTTP/1.1\r\nHost: x\r\n"
                                        f"Authorization: Bearer {OP}\r\nContent-Type: application/json\r\n"
                                        "Content-Length: 1048576\r\n\r\n", b"{}")
        s.close()
        check(status == 200, f"a HALT declaring a 1 MiB body: {status}")
    finally:
        hog.close()
        g.proc.terminate()
        g.proc.wait(timeout=30)


def test_halt_with_every_connection_slot_taken(fx, args):
    g = SoloGateway(fx, args, "crowded")
    g.start({"limits": {"max_connections": 8, "max_connections_per_address": 8}})
    clients = []
    try:
        # 7 WebSockets (an address may hold 7/8 of the slots): the next connection is refused...
        for i in range(7):
            clients.append(WsClient(g.port, VIEW, f"viewer{i}"))
        r = g.c.request("GET", "/api/v1/controllers", token=VIEW, validate=False)
        check(r.status == 503 and r.json()["type"].endswith("/too-many-connections"), f"a GET: {r.status}")
        # ... but not a HALT, nor HALT ALL, however many come.
        for _ in range(3):
            for path in ("/api/v1/controllers/crowded/halt", "/api/v1/halt"):
                r = g.c.request("POST", path, token=VIEW)
                check(r.status == 200, f"POST {path} with every slot taken: {r.status} {r.body[:200]}")
    finally:
        for ws in clients:
            ws.close()
    check(controller_of(g, "crowded")["halted"]["by"] == "viewer1", "the HALT latched the controller")


def controller_of(g, cid):
    return wait_until(f"GET {cid}", lambda: (lambda r: r.json() if r.status == 200 else None)(
        g.c.request("GET", f"/api/v1/controllers/{cid}", token=VIEW)), 20)


def test_halt_while_gcode_is_uploaded_and_planned(c):
    # A large program (about 6 MB) uploaded and planned while HALTs are sent.
    program = "G21 G90\n" + "".join(f"G01 X{i % 50} Y{(i * 7) % 50} F600\n" for i in range(300000))
    errors = []

    def upload_and_plan():
        try:
            r = c.request("POST", "/api/v1/gcode/files?name=big.ngc", token=OP, raw_body=program.encode(),
                          headers={"Content-Type": "text/plain"}, validate=False)
            if r.status != 201:
                errors.append(f"upload {r.status}")
                return
            fid = r.json()["id"]
            c.request("POST", f"/api/v1/gcode/files/{fid}/plan?moves=false", token=OP, validate=False)
        except Exception as e:  # noqa: BLE001
            errors.append(repr(e))
    t = threading.Thread(target=upload_and_plan)
    t.start()
    halts = 0
    while t.is_alive():
        r = c.request("POST", "/api/v1/controllers/sim2/halt", token=OP)
        check(r.status == 200, f"a HALT during the upload or plan: {r.status} {r.body[:200]}")
        halts += 1
        time.sleep(0.05)
    t.join()
    check(not errors, f"the upload and plan: {errors}")
    check(halts >= 2, f"only {halts} HALT(s) went out during the upload and the plan")


# ---------------------------------------------------------------------------------------------
# When the gateway dies: a crash, a hang-up, a kill -9 and the restart after it


class SoloGateway:
    """A gateway of its own on one simulator at real speed (time scale 1): long moves to stop."""

    def __init__(self, fx, args, name):
        self.fx, self.args, self.name = fx, args, name
        self.sim = fx.start_sim(args.sim, name, "plain", time_scale=1)
        self.port = free_port()
        self.store = os.path.join(fx.tmp, name + "-store")
        self.proc = None

    def start(self, http_extra=None, terminal=False):
        """Starts the gateway; `terminal`: on a new pseudo-terminal that is its controlling terminal
        (as when started from a shell), whose master end self.terminal holds."""
        config = {"http": {"listen_address": "127.0.0.1", "port": self.port, **(http_extra or {})}, "auth": auth_tokens(),
                  "storage": {"path": self.store}, "controllers": [{"id": self.name, "port": self.sim.link}]}
        cfg = os.path.join(self.fx.tmp, self.name + ".json")
        with open(cfg, "w") as f:
            json.dump(config, f)
        self.log = os.path.join(self.fx.tmp, self.name + ".log")
        stdin, self.terminal = subprocess.DEVNULL, None
        if terminal:
            self.terminal, stdin = os.openpty()
        with open(self.log, "a") as log:
            self.proc = subprocess.Popen([self.args.gateway, "--config", cfg], stdin=stdin, stdout=log, stderr=log,
                                         start_new_session=terminal,
                                         preexec_fn=(lambda: fcntl.ioctl(0, termios.TIOCSCTTY, 0)) if terminal else None)
        if terminal:
            os.close(stdin)
        self.fx.procs.append(self.proc)
        self.c = Client(self.port, self.args.contract)
        wait_until(f"{self.name} ready", lambda: self.c.request("GET", "/api/v1/ready", validate=False).status == 200, 30)

    def x(self):
        return sim_state(self.sim)["axes"]["X"]["position"] / 10  # tenths of a micrometre

    def moving(self):
        return sim_state(self.sim)["busy"]


def test_crash_halts(fx, args, signal_number, name, terminal=False):
    """Starts a gateway, moves its stage far, then sends it `signal_number`, or with `terminal`
    closes its terminal (the kernel sends SIGHUP); the exit code, once the stage is checked halted."""
    g = SoloGateway(fx, args, name)
    g.start(terminal=terminal)
    r = g.c.request("POST", f"/api/v1/controllers/{name}/move", {"axes": {"X": 100000}}, token=OP)
    check(r.status == 200, f"move: {r.status} {r.body[:200]}")
    wait_until("the stage moving", g.moving, 10)
    if terminal:
        os.close(g.terminal)  # the terminal window closes
    else:
        os.kill(g.proc.pid, signal_number)
    code = g.proc.wait(timeout=30)
    wait_until("the stage stopped after the gateway died", lambda: not g.moving(), 5)
    check(g.x() < 90000, f"the stage went on to X={g.x()} um")
    return code


def test_hangup_halts(fx, args):
    """A gateway started from a terminal: the terminal closing (SIGHUP) stops it with a HALT, since no
    one watches the stages any more. (As a service, SIGHUP reloads the TLS certificate: tls_test.)"""
    code = test_crash_halts(fx, args, signal.SIGHUP, "hup", terminal=True)
    check(code == 0, f"SIGHUP: a controlled stop with exit code 0, got {code}")
    with open(os.path.join(fx.tmp, "hup.log")) as f:
        check("signal 1: stopping" in f.read(), "the log does not say SIGHUP stopped it")


def test_fatal_signals_halt(fx, args):
    for n, s in ((1, signal.SIGSEGV), (2, signal.SIGABRT)):
        code = test_crash_halts(fx, args, s, f"crash{n}")
        check(code == -s, f"killed by signal {s}: exit {code}")


def test_restart_halts_first(fx, args):
    g = SoloGateway(fx, args, "reborn")
    g.start()
    job_id = submit(g.c, "reborn", "array", {"grid": {"columns": 2, "rows": 1, "column_step_mm": 90, "row_step_mm": -1},
                                             "a1": {"X": -45000, "Y": 0}, "mode": "host"})
    wait_until("the stage moving to the first well", g.moving, 20)
    g.proc.kill()  # SIGKILL: no handler runs, the stage keeps moving
    g.proc.wait(timeout=30)
    time.sleep(0.3)
    check(g.moving(), "the stage stopped although nothing halted it")
    g.start()
    wait_until("the stage halted by the restarted gateway", lambda: not g.moving(), 10)
    check(g.x() > -44000, f"the stage reached the well at X={g.x()} um: not halted")
    j = job(g.c, job_id)
    check(j["state"] == "interrupted", f"the job after the restart: {j['state']}")
    with open(g.log) as f:
        check("HALT sent first" in f.read(), "the log does not say the HALT went first")


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--gateway", required=True)
    p.add_argument("--sim", required=True)
    p.add_argument("--openapi", required=True)
    p.add_argument("--only", default="", help="run only the checks whose name contains this")
    args = p.parse_args()
    with open(args.openapi) as f:
        contract = Contract(f.read())
    args.contract = contract
    fx = Fixture("asi-halt-test-")
    try:
        sims = {"sim1": fx.start_sim(args.sim, "sim1", "full", time_scale=TIME_SCALE, report=True),
                "sim2": fx.start_sim(args.sim, "sim2", "plain", time_scale=TIME_SCALE),
                "sim3": fx.start_sim(args.sim, "sim3", "planar", time_scale=TIME_SCALE)}
        broker = Broker(fx, "halt-broker")
        broker.start()
        port = free_port()
        controllers = [{"id": "sim1", "port": sims["sim1"].link, "report_port": sims["sim1"].report_link},
                       {"id": "sim2", "port": sims["sim2"].link}, {"id": "sim3", "port": sims["sim3"].link}]
        fx.start_gateway(args.gateway, {
            "http": {"listen_address": "127.0.0.1", "port": port}, "auth": auth_tokens(),
            "controllers": controllers,
            "mqtt": {"enabled": True, "brokers": [f"mqtt://127.0.0.1:{broker.port}"], "gateway_id": "lab",
                     "topic_prefix": PREFIX,
                     "commands": {"enabled": True, "signing_keys": signing_keys_config()}}})
        c = Client(port, contract)
        run = fx.run
        fx.run = lambda name, *a: run(name, *a) if args.only in name else None
        fx.run("HALT during a host-driven array job", test_array_host, c, sims)
        fx.run("HALT during a firmware array advanced by TTL", test_array_firmware_ttl, c, sims)
        fx.run("HALT during a firmware scan", test_scan_firmware, c, sims)
        fx.run("HALT during a ring-buffer tour advanced by TTL", test_ring_buffer_ttl, c, sims)
        fx.run("HALT during a planar correction", test_planar, c, sims)
        fx.run("HALT during a G-code trace with TTL", test_gcode_ttl, c, sims)
        fx.run("queued jobs wait for a resume or a submission", test_queued_jobs_wait, c, sims)
        fx.run("a viewer may HALT", test_viewer_may_halt, c, sims)
        fx.run("a job holds its controller: changes refused (job-active), reads and HALT not",
               test_job_holds_its_controller, c, sims)
        fx.run("the lease holder that submitted a job keeps control", test_the_lease_holder_keeps_control, c, sims)
        fx.run("HALT ALL over REST", test_halt_all_rest, c, sims)
        fx.run("HALT ALL over WebSocket", test_halt_all_ws, c, sims, port)
        fx.run("HALT ALL over MQTT", test_halt_all_mqtt, c, sims, broker)
        fx.run("HALT before identification", test_halt_before_identification, fx, args, contract)
        fx.run("HALT beside an exhausted body budget", test_halt_beside_an_exhausted_body_budget, fx, args)
        fx.run("HALT with every connection slot taken", test_halt_with_every_connection_slot_taken, fx, args)
        fx.run("HALT while a large G-code program is uploaded and planned",
               test_halt_while_gcode_is_uploaded_and_planned, c)
        fx.run("the terminal closing (SIGHUP) stops with a HALT", test_hangup_halts, fx, args)
        fx.run("a crash (SIGSEGV, SIGABRT) halts the moving stage", test_fatal_signals_halt, fx, args)
        fx.run("after a kill -9, the restart sends HALT first", test_restart_halts_first, fx, args)
        fx.finish_log(80)
        return fx.report()
    finally:
        fx.cleanup()


if __name__ == "__main__":
    run_main(main)
