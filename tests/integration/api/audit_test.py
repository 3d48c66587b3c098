#!/usr/bin/python3
"""The audit trail (issue 34), end to end: the real asi-gateway with tokens, two simulated controllers
and a real mosquitto for signed MQTT commands.

Checks that every state-changing call leaves one entry with who, from where, over which transport,
what and how it ended, and nothing else does:
  - REST: a move (operator1, 127.0.0.1, 200 ok, its arguments), a viewer's raw command and lease
    release refused from the header (403, the route as the action), a
    raw command, a job submitted (its id as the target) and cancelled, a lease taken and broken by an
    admin, HALT ALL, a G-code program uploaded and deleted;
  - WebSocket: a HALT (transport websocket); MQTT: a signed HALT (transport mqtt, the key's name);
  - a shared port (pyserial on sim2's shared pty): a move (transport share, its line), a move refused
    while REST holds the lease (held-elsewhere, with the reason) and a HALT; its queries leave nothing;
  - reads, dry runs and G-code checks leave nothing;
  - GET /api/v1/audit is admin only, filters by controller, principal and time, pages with before,
    refuses a bad parameter (422);
  - failed authentications are logged at info with the address, rate-limited (100 tries: a few lines);
  - the job store's fill is in /api/v1/metrics (gw_job_store_fill_ratio);
  - the trail is on disk: after a restart of the gateway the entries are still there.

Run by ctest with Debian's /usr/bin/python3. Exit code 0 when every check passed.
"""

import argparse
import json
import os
import sys
import time

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gateway_fixture import (TOKENS, Failure, Fixture, auth_tokens, check, free_port, run_main,  # noqa: E402
                             signing_keys_config)
from http_api_test import Client, Contract  # noqa: E402
from mqtt_api_test import Broker, Client as MqttClient, command as mqtt_command  # noqa: E402
from ws_api_test import WsClient  # noqa: E402

OP, VIEW, ADMIN = TOKENS["operator"], TOKENS["viewer"], TOKENS["admin"]
PREFIX = "audit-test"
PROGRAM = "G21 G90\nG01 X1 Y1 F600\nM2\n"


def trail(c, query="", token=ADMIN):
    r = c.request("GET", "/api/v1/audit" + query, token=token)
    check(r.status == 200, f"GET /api/v1/audit{query}: {r.status} {r.body[:300]}")
    return r.json()


def newest(c, **want):
    """The newest entry whose fields equal `want`."""
    for e in trail(c, "?limit=500")["entries"]:
        if all(e.get(k) == v for k, v in want.items()):
            return e
    raise Failure(f"no audit entry with {want}")


def test_rest_calls(c):
    before = trail(c)["entries"]
    r = c.request("POST", "/api/v1/controllers/sim1/move", {"axes": {"X": 100}}, token=OP)
    check(r.status == 200, f"move: {r.status} {r.body[:200]}")
    e = newest(c, action="move", principal="operator1")
    check(e["transport"] == "rest" and e["address"] == "127.0.0.1" and e["role"] == "operator",
          f"who and from where: {e}")
    check(e["controller"] == "sim1" and e["status"] == 200 and e["outcome"] == "ok", f"what and outcome: {e}")
    check(e["detail"] == {"axes": {"X": 100}}, f"the arguments: {e['detail']}")
    check(e["request_id"] == r.header("X-Request-Id"), f"request id {e['request_id']} vs {r.header('X-Request-Id')}")
    check(not before or e["id"] > before[0]["id"], "ids grow")
    # Refused calls are in the trail too.
    r = c.request("POST", "/api/v1/controllers/sim1/move", {"axes": {"Q": 5}}, token=OP)
    check(r.status == 422, f"a move of an axis that is not there: {r.status}")
    e = newest(c, action="move", principal="operator1", status=422)
    check(e["outcome"] == "invalid_value" and e["detail"] == {"axes": {"Q": 5}}, f"a refusal: {e}")
    r = c.request("POST", "/api/v1/controllers/sim1/command", {"command": "W X"}, token=ADMIN)
    check(r.status == 200, f"raw command: {r.status}")
    e = newest(c, action="command", principal="admin1")
    check(e["detail"] == {"command": "W X"}, f"the raw command: {e}")
    # A role too low for the route, refused from the header: with a body (not read) and without one.
    r = c.request("POST", "/api/v1/controllers/sim1/command", {"command": "W X"}, token=VIEW)
    check(r.status == 403, f"a viewer's raw command: {r.status}")
    e = newest(c, action="POST /api/v1/controllers/{id}/command")
    check(e["principal"] == "viewer1" and e["outcome"] == "forbidden" and e["status"] == 403
          and e["controller"] == "sim1" and e["address"] == "127.0.0.1", f"the viewer's raw command: {e}")
    r = c.request("DELETE", "/api/v1/controllers/sim2/lease", token=VIEW)
    check(r.status == 403, f"a viewer's lease release: {r.status}")
    e = newest(c, action="DELETE /api/v1/controllers/{id}/lease")
    check(e["principal"] == "viewer1" and e["controller"] == "sim2", f"the viewer's lease release: {e}")


def test_reads_leave_nothing(c):
    last = trail(c, "?limit=1")["entries"][0]["id"]
    c.request("GET", "/api/v1/controllers", token=VIEW)
    c.request("GET", "/api/v1/controllers/sim1", token=VIEW)
    c.request("GET", "/api/v1/leases", token=VIEW)
    r = c.request("POST", "/api/v1/jobs?dry_run=true",
                  {"controller": "sim1", "type": "array", "spec": {"plate": "96", "a1": "current"}}, token=OP)
    check(r.status == 200, f"a dry run: {r.status} {r.body[:200]}")
    check(trail(c, "?limit=1")["entries"][0]["id"] == last, "reads and a dry run added an entry")


def test_shared_port_commands(fx, c):
    import serial  # python3-serial

    port = serial.Serial(os.path.join(fx.tmp, "sims", "sim2", "share"), 115200, timeout=10)
    try:
        def send(line):
            port.write(line.encode() + b"\r")
            return port.readline().decode(errors="replace").strip()

        check(send("W X").startswith(":A"), "a query through the shared port")
        answer = send("M X=50")
        check(answer.startswith(":A"), f"a move through the shared port: {answer!r}")
        e = newest(c, action="command", transport="share")
        check(e["controller"] == "sim2" and e["detail"]["command"] == "M X=50" and e["outcome"] == "ok"
              and e["principal"] == "shared-port" and e["role"] == "admin" and e["status"] == 200,
              f"the shared move: {e}")
        r = c.request("POST", "/api/v1/controllers/sim2/lease", {"ttl_s": 60, "holder": "rest"}, token=OP)
        check(r.status in (200, 201), f"lease: {r.status} {r.body[:200]}")
        answer = send("M X=60")
        check(answer.startswith(":N-90"), f"a move while REST holds the lease: {answer!r}")
        e = newest(c, action="command", transport="share")
        check(e["detail"]["command"] == "M X=60" and e["outcome"] == "held-elsewhere" and e["status"] == 409
              and "rest" in e["detail"].get("reason", ""), f"the refused shared move: {e}")
        c.request("DELETE", "/api/v1/controllers/sim2/lease?force=true", token=ADMIN)
        send("\\")
        e = newest(c, action="halt", transport="share")
        check(e["controller"] == "sim2" and e["outcome"] == "ok", f"the shared HALT: {e}")
        queries = [x for x in trail(c, "?limit=500")["entries"]
                   if x["transport"] == "share" and x["detail"].get("command") == "W X"]
        check(not queries, f"a query through the shared port was audited: {queries}")
    finally:
        port.close()


def test_jobs_and_leases(c):
    r = c.request("POST", "/api/v1/jobs", {"controller": "sim1", "type": "array",
                                           "spec": {"plate": "96", "a1": "current"}}, token=OP)
    check(r.status == 201, f"submit: {r.status} {r.body[:200]}")
    job = r.json()["id"]
    e = newest(c, action="job.submit")
    check(e["target"] == job and e["controller"] == "sim1" and e["status"] == 201, f"the submission: {e}")
    r = c.request("POST", f"/api/v1/jobs/{job}/cancel", token=OP)
    check(r.status == 200, f"cancel: {r.status} {r.body[:200]}")
    e = newest(c, action="job.cancel")
    check(e["target"] == job and e["outcome"] == "ok", f"the cancel: {e}")
    r = c.request("POST", "/api/v1/controllers/sim2/lease", {"ttl_s": 60, "holder": "notebook"}, token=OP)
    check(r.status in (200, 201), f"lease: {r.status} {r.body[:200]}")
    e = newest(c, action="lease.take")
    check(e["controller"] == "sim2" and e["detail"].get("holder") == "notebook", f"the lease: {e}")
    r = c.request("DELETE", "/api/v1/controllers/sim2/lease?force=true", token=ADMIN)
    check(r.status in (200, 204), f"break: {r.status} {r.body[:200]}")
    e = newest(c, action="lease.break")
    check(e["principal"] == "admin1" and e["controller"] == "sim2", f"the break: {e}")
    r = c.request("POST", "/api/v1/halt", token=VIEW)
    check(r.status == 200, f"HALT ALL: {r.status}")
    e = newest(c, action="halt_all")
    check(e["principal"] == "viewer1" and e["controller"] is None, f"HALT ALL: {e}")


def test_gcode_files(c):
    r = c.request("POST", "/api/v1/gcode/files?name=audit.ngc", token=OP, raw_body=PROGRAM.encode(),
                  headers={"Content-Type": "text/plain"})
    check(r.status == 201, f"upload: {r.status} {r.body[:200]}")
    file_id = r.json()["id"]
    e = newest(c, action="gcode.upload")
    check(e["target"] == file_id and e["principal"] == "operator1" and e["address"] == "127.0.0.1",
          f"the upload: {e}")
    r = c.request("DELETE", f"/api/v1/gcode/files/{file_id}", token=OP)
    check(r.status == 204, f"delete: {r.status}")
    e = newest(c, action="gcode.delete")
    check(e["target"] == file_id and e["status"] == 204, f"the delete: {e}")


def test_websocket_and_mqtt(c, port, broker, gateway_topic):
    ws = WsClient(port, token=OP, name="audit-ws")
    try:
        a = ws.request({"op": "command", "id": "h1", "controller": "sim2", "operation": "halt"})
        check(a["type"] == "result", f"WebSocket HALT: {a}")
    finally:
        ws.close()
    e = newest(c, action="halt", transport="websocket")
    check(e["principal"] == "operator1" and e["address"] == "127.0.0.1" and e["controller"] == "sim2", f"{e}")
    m = MqttClient(broker.port, "audit-mqtt")
    try:
        reply = "audit-clients/replies"
        m.subscribe(reply)
        a = mqtt_command(m, gateway_topic("controllers", "sim1", "cmd"), {"operation": "halt", "token": OP}, reply)
        check(a["type"] == "result", f"MQTT HALT: {a}")
    finally:
        m.close()
    e = newest(c, action="halt", transport="mqtt")
    check(e["principal"] == "operator" and e["address"] is None, f"the signing key is the principal: {e}")


def test_query(c):
    c.problem("GET", "/api/v1/audit", 403, "forbidden", token=OP)
    c.problem("GET", "/api/v1/audit", 403, "forbidden", token=VIEW)
    c.problem("GET", "/api/v1/audit?limit=0", 422, "invalid-value", token=ADMIN)
    c.problem("GET", "/api/v1/audit?since=yesterday", 422, "invalid-value", token=ADMIN)
    c.problem("GET", "/api/v1/audit?colour=red", 422, "invalid-value", token=ADMIN)
    only = trail(c, "?controller=sim2&limit=500")["entries"]
    check(only and all(e["controller"] == "sim2" for e in only), f"controller filter: {only[:3]}")
    mine = trail(c, "?principal=viewer1&limit=500")["entries"]
    check(mine and all(e["principal"] == "viewer1" for e in mine), "principal filter")
    everything = trail(c, "?limit=500")["entries"]
    check(len(everything) >= 10, f"entries so far: {len(everything)}")
    newest_ms = int(time.time() * 1000) + 1000
    check(trail(c, f"?since={newest_ms}")["entries"] == [], "nothing after now")
    # Pages of two, newest first, end to end the same as one page.
    paged, cursor = [], ""
    while True:
        page = trail(c, "?limit=2" + (f"&before={cursor}" if cursor else ""))
        paged += page["entries"]
        if page["next_before"] is None:
            break
        cursor = page["next_before"]
    check([e["id"] for e in paged] == [e["id"] for e in everything], "paging gives every entry once, in order")


def test_failed_authentications_logged(fx, c):
    # At info level, with the client's address, and rate-limited: 100 tries in a row are a handful of lines.
    for _ in range(100):
        r = c.request("GET", "/api/v1/controllers", token="not-a-token-0123456789", validate=False)
        check(r.status == 401, f"a wrong token: {r.status}")
    time.sleep(0.5)
    with open(fx.log_path) as f:
        lines = [line for line in f if "authentication failed from 127.0.0.1: GET /api/v1/controllers" in line]
    check(1 <= len(lines) <= 8, f"{len(lines)} log lines for 100 failed authentications")


def test_store_fill_metric(c):
    text = c.request("GET", "/api/v1/metrics", token=VIEW).body
    lines = [line for line in text.splitlines() if line.startswith("gw_job_store_fill_ratio ")]
    check(len(lines) == 1, f"gw_job_store_fill_ratio: {lines}")
    value = float(lines[0].split()[1])
    check(0 < value < 0.01, f"a new store is a small part of 1024 MB: {value}")


def test_durable(fx, args, config, c):
    count = len(trail(c, "?limit=500")["entries"])
    fx.gateway.terminate()
    fx.gateway.wait(timeout=30)
    fx.start_gateway(args.gateway, config)
    check(len(trail(c, "?limit=500")["entries"]) >= count, "the trail outlives a restart")


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--gateway", required=True)
    p.add_argument("--openapi", required=True)
    args = p.parse_args()
    with open(args.openapi) as f:
        contract = Contract(f.read())
    fx = Fixture("asi-audit-test-")
    try:
        broker = Broker(fx, "audit-broker")
        broker.start()
        port = free_port()
        config = {
            "http": {"listen_address": "127.0.0.1", "port": port}, "auth": auth_tokens(),
            "simulate": {"count": 2, "directory": os.path.join(fx.tmp, "sims")},
            "mqtt": {"enabled": True, "brokers": [f"mqtt://127.0.0.1:{broker.port}"], "gateway_id": "lab",
                     "topic_prefix": PREFIX, "commands": {"enabled": True, "signing_keys": signing_keys_config()}}}
        fx.start_gateway(args.gateway, config)
        c = Client(port, contract)

        def gateway_topic(*levels):
            return "/".join((PREFIX, "lab") + levels)

        # The bridge subscribes to the command topics once connected.
        time.sleep(1)
        fx.run("REST calls: who, from where, what, how it ended", test_rest_calls, c)
        fx.run("reads and dry runs leave nothing", test_reads_leave_nothing, c)
        fx.run("jobs, leases and HALT ALL", test_jobs_and_leases, c)
        fx.run("shared port commands: moves, refusals and HALT, not queries", test_shared_port_commands, fx, c)
        fx.run("G-code uploads and deletes", test_gcode_files, c)
        fx.run("WebSocket and MQTT calls", test_websocket_and_mqtt, c, port, broker, gateway_topic)
        fx.run("GET /api/v1/audit: admin only, filters, paging", test_query, c)
        fx.run("failed authentications are logged, rate-limited", test_failed_authentications_logged, fx, c)
        fx.run("the job store's fill is a metric", test_store_fill_metric, c)
        fx.run("the trail outlives a restart", test_durable, fx, args, config, c)
        fx.finish_log(60)
        return fx.report()
    finally:
        fx.cleanup()


if __name__ == "__main__":
    run_main(main)
