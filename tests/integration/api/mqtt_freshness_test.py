"""MQTT commands that never run late, and run once (issue 37): a real mosquitto, the real asi-gateway
(--simulate) and Debian's python3-paho-mqtt clients.

- A signed command older than mqtt.commands.max_age_s (its ts), or past its "not_after", is answered
  stale-command (408) and not run: the stage stays where it was, and the audit trail has no entry.
- A HALT is never refused for its age.
- A command refused as stale can be sent again, fresh, under the same id, and runs.
- The same (sender, id) delivered twice (a QoS 1 redelivery, a bridge's resend) is run once and
  answered once; the second is counted as "duplicate". Over MQTT 3.1.1 (reply_to) as well.
- Over TLS with bearer tokens (unsigned, so no ts): a move without a deadline is refused (422,
  field not_after); with MQTT 5 message expiry or "not_after" it runs; a read needs no deadline.
- mqtt.session_expiry_s: the broker keeps the gateway's session while its link is cut
  (tests/support/link_cutter.py); a command sent meanwhile runs once the gateway is back, and one
  whose deadline passed meanwhile is answered stale-command, not run. Without it, neither arrives.

Run by ctest (mqtt_freshness); by hand:
  /usr/bin/python3 tests/integration/api/mqtt_freshness_test.py --gateway build/gateway/asi-gateway \\
      --asyncapi openapi/asyncapi.yaml
"""

import argparse
import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "support"))
from link_cutter import LinkCutter  # noqa: E402
from gateway_fixture import (TOKENS, Fixture, check, http_request, run_main, signed_command,  # noqa: E402
                             axis_position, signing_keys_config, wait_until)
from mqtt_api_test import Broker, Client, Contract, Gateway, command, make_pki, metric, unanswered  # noqa: E402

from paho.mqtt.packettypes import PacketTypes  # noqa: E402
from paho.mqtt.properties import Properties  # noqa: E402

MAX_AGE_S = 2
REPLY = "clients/fresh/replies"


def x_of(gw):
    return axis_position(gw.port, "sim1")


def now_ms():
    return int(time.time() * 1000)


def settled_x(gw):
    """X once the polled snapshot stops changing (a move that ran has arrived)."""
    last = [None]

    def steady():
        x = x_of(gw)
        same = last[0] is not None and abs(x - last[0]) < 0.01
        last[0] = x
        return [x] if same else None  # a list: 0.0 is a position, not a "not yet"
    time.sleep(0.5)
    return wait_until("X settles", steady, timeout=20)[0]


def audit_entries(gw, request_id):
    status, body = http_request(gw.port, "GET", "/api/v1/audit?controller=sim1&limit=500", token=TOKENS["admin"])
    check(status == 200, f"audit: {status} {body}")
    return [e for e in json.loads(body)["entries"] if e["request_id"] == request_id]


def signed(gw, message, role="operator", ts_ms=None):
    return signed_command(gw.topic("controllers", "sim1", "cmd"), message, role, ts_ms=ts_ms)


def send(c, gw, payload, v5=True):
    return command(c, gw.topic("controllers", "sim1", "cmd"), payload, REPLY, v5=v5, sign=False)


def move(x, cid):
    return {"id": cid, "operation": "move", "args": {"axes": {"X": x}, "wait": True}}


def check_stale(ans, source, contract):
    contract.validate(REPLY, json.dumps(ans))
    check(ans["type"] == "error", f"a stale command is refused: {ans}")
    p = ans["problem"]
    check(p["type"].endswith("/stale-command") and p["status"] == 408, f"stale-command 408: {p}")
    check(source in p["detail"] and "after its deadline" in p["detail"], f"the detail says why: {p['detail']}")


def test_stale_signed(gw, c, contract):
    start = settled_x(gw)
    # ts older than max_age_s (2 s) but inside the signature window (30 s): a known sender, answered.
    ans = send(c, gw, signed(gw, move(start + 500, "old-1"), ts_ms=now_ms() - 5000))
    check_stale(ans, "ts + mqtt.commands.max_age_s", contract)
    check(ans["id"] == "old-1", f"the answer names the command: {ans}")
    # not_after already past, ts fresh.
    ans = send(c, gw, signed(gw, {**move(start + 500, "late-1"), "not_after": now_ms() - 1}))
    check_stale(ans, "not_after", contract)
    check(abs(settled_x(gw) - start) < 1, "a stale command does not move the stage")
    check(not audit_entries(gw, "mqtt.old-1") and not audit_entries(gw, "mqtt.late-1"),
          "a stale command never reaches the call dispatch (no audit entry)")
    check(metric(gw, "gw_mqtt_commands_total", outcome="refused") >= 2, "counted as refused")
    # The same id, sent again in time, runs: a refusal does not use up the id.
    ans = send(c, gw, signed(gw, {**move(start + 500, "late-1"), "not_after": now_ms() + 10000}))
    check(ans["type"] == "result", f"the same id in time runs: {ans}")
    check(abs(settled_x(gw) - (start + 500)) < 1, "it moved")


def test_halt_is_never_stale(gw, c):
    ans = send(c, gw, signed(gw, {"id": "h-old", "operation": "halt", "not_after": now_ms() - 60000},
                             ts_ms=now_ms() - 20000))
    check(ans["type"] == "result", f"a HALT past every deadline still runs: {ans}")
    # And twice under one id: a HALT is never dropped as a repeat.
    for _ in range(2):
        ans = send(c, gw, signed(gw, {"id": "h-twice", "operation": "halt"}))
        check(ans["type"] == "result", f"a repeated HALT runs: {ans}")


def test_redelivery_runs_once(gw, c):
    start = settled_x(gw)
    before = metric(gw, "gw_mqtt_commands_total", outcome="duplicate")
    body = {"id": "dup-1", "operation": "move", "args": {"axes": {"X": 250}, "mode": "relative", "wait": True}}
    ans = send(c, gw, signed(gw, body))
    check(ans["type"] == "result", f"first delivery: {ans}")
    # The same command again (a new signature: a redelivery through a bridge is signed once, but
    # a resend by a client library may sign again); the barrier proves it got no answer.
    unanswered(c, gw.topic("controllers", "sim1", "cmd"), signed(gw, body), REPLY, sign=False)
    check(metric(gw, "gw_mqtt_commands_total", outcome="duplicate") == before + 1, "counted as duplicate")
    check(abs(settled_x(gw) - (start + 250)) < 1, f"moved once by 250 from {start}: X={x_of(gw)}")
    check(len(audit_entries(gw, "mqtt.dup-1")) == 1, "one audit entry for the command")
    # Another sender may use the same id.
    ans = send(c, gw, signed(gw, body, role="admin"))
    check(ans["type"] == "result", f"another sender's dup-1 runs: {ans}")
    check(abs(settled_x(gw) - (start + 500)) < 1, "and moved")


def test_redelivery_v311(gw, broker):
    c = Client(broker.port, "fresh-v311", v5=False)
    try:
        c.subscribe(REPLY)
        start = settled_x(gw)
        body = {"id": "dup-311", "operation": "move", "reply_to": REPLY,
                "args": {"axes": {"X": 100}, "mode": "relative", "wait": True}}
        ans = send(c, gw, signed(gw, body), v5=False)
        check(ans["type"] == "result", f"first delivery over 3.1.1: {ans}")
        mark = c.mark()
        c.publish(gw.topic("controllers", "sim1", "cmd"), signed(gw, body), sign=False)
        ans = send(c, gw, signed(gw, {"id": "barrier-311", "operation": "halt", "reply_to": REPLY}, "viewer"),
                   v5=False)
        check(ans["type"] == "result", f"barrier: {ans}")
        answers = [m for m in c.all(lambda t: t == REPLY, mark) if json.loads(m[1]).get("id") == "dup-311"]
        check(not answers, f"the repeat is not answered: {answers}")
        check(abs(settled_x(gw) - (start + 100)) < 1, "moved once")
        # not_after over 3.1.1, where there is no message expiry.
        ans = send(c, gw, signed(gw, {**body, "id": "late-311", "not_after": now_ms() - 1}), v5=False)
        check(ans["type"] == "error" and ans["problem"]["type"].endswith("/stale-command"), f"stale: {ans}")
    finally:
        c.close()


def test_bearer_deadlines(fx, binary, contract):
    """Unsigned commands carry no ts: a change needs not_after or message expiry."""
    pki = make_pki(fx.tmp)
    tls = {"ca": pki["ca"], "cert": pki["server_cert"], "key": pki["server_key"]}
    broker = Broker(fx, "fresh-tls", tls=tls)
    broker.start()
    gw = Gateway(fx, binary, "gw-bearer", [f"mqtts://localhost:{broker.tls_port}"], sims=1,
                 mqtt_extra={"tls": {"ca_file": pki["ca"], "cert_file": pki["client_cert"],
                                     "key_file": pki["client_key"], "verify": True},
                             "commands": {"enabled": True, "accept_bearer_tokens": True}})
    gw.start()
    c = Client(broker.port, "fresh-bearer", tls={"ca": pki["ca"], "cert": pki["client_cert"],
                                                 "key": pki["client_key"]}, port=broker.tls_port)
    topic = gw.topic("controllers", "sim1", "cmd")
    try:
        c.subscribe(REPLY)
        wait_until("gw-bearer on its broker", lambda: metric(gw, "gw_mqtt_connected") == 1)
        time.sleep(1)  # its command subscriptions
        token = TOKENS["operator"]
        ans = command(c, topic, {**move(300, "b-none"), "token": token}, REPLY, sign=False)
        contract.validate(REPLY, json.dumps(ans))
        check(ans["type"] == "error" and ans["problem"]["status"] == 422 and ans["problem"].get("field") == "not_after",
              f"a move without a deadline is refused: {ans}")
        check(not audit_entries(gw, "mqtt.b-none"), "and never dispatched")
        ans = command(c, topic, {**move(300, "b-after"), "token": token, "not_after": now_ms() + 10000}, REPLY,
                      sign=False)
        check(ans["type"] == "result", f"with not_after it runs: {ans}")
        # MQTT 5 message expiry: the broker's deadline.
        start = c.mark()
        props = Properties(PacketTypes.PUBLISH)
        props.ResponseTopic = REPLY
        props.CorrelationData = b"b-expiry"
        props.MessageExpiryInterval = 30
        c.c.publish(topic, json.dumps({**move(600, "b-expiry"), "token": token}), qos=1,
                    properties=props).wait_for_publish(10)
        _, p, _, _ = c.wait_for("the expiring command's answer",
                                lambda t, p, r, pr: t == REPLY and getattr(pr, "CorrelationData", None) == b"b-expiry",
                                start=start)
        ans = json.loads(p)
        check(ans["type"] == "result", f"with message expiry it runs: {ans}")
        # A read changes nothing: no deadline needed. A HALT never needs one.
        ans = command(c, topic, {"id": "b-halt", "operation": "halt", "token": token}, REPLY, sign=False)
        check(ans["type"] == "result", f"a HALT without a deadline: {ans}")
        ans = command(c, gw.topic("jobs", "submit"),
                      {"id": "b-plan", "token": token, "dry_run": True,
                       "args": {"controller": "sim1", "type": "array",
                                "spec": {"grid": {"columns": 2, "rows": 1, "column_step_mm": 0.1,
                                                  "row_step_mm": 0.1}, "a1": "current"}}}, REPLY, sign=False)
        check(ans["type"] == "result", f"a dry run (changes nothing) without a deadline: {ans}")
    finally:
        c.close()


def health_session(gw):
    status, body = http_request(gw.port, "GET", "/api/v1/health", token=None)
    check(status == 200, f"health: {status} {body}")
    return json.loads(body)["mqtt"]["session"]


def sent_while_away(fx, binary, broker, contract, session_expiry_s):
    """Two commands published while the gateway's link is cut: one in time after the link is back, one
    whose deadline passes meanwhile. Returns their answers ({} for none) once the gateway is back."""
    cutter = LinkCutter(broker.port)
    name = f"gw-away-{session_expiry_s}"
    gw = Gateway(fx, binary, name, [f"mqtt://127.0.0.1:{cutter.port}"], sims=1,
                 mqtt_extra={"session_expiry_s": session_expiry_s, "reconnect": {"min_ms": 100, "max_ms": 300},
                             "commands": {"enabled": True, "signing_keys": signing_keys_config(),
                                          "max_age_s": 30}})
    gw.start()
    c = Client(broker.port, f"away-watch-{session_expiry_s}")
    try:
        c.subscribe(REPLY)
        wait_until(f"{name} on its broker", lambda: metric(gw, "gw_mqtt_connected") == 1)
        time.sleep(1)  # its command subscriptions
        start = settled_x(gw)
        cutter.cut()
        wait_until(f"{name} lost its broker", lambda: metric(gw, "gw_mqtt_connected") == 0)
        topic = gw.topic("controllers", "sim1", "cmd")
        mark = c.mark()
        in_time = os.urandom(8)
        c.publish(topic, signed(gw, move(start + 300, "away-1")), response_topic=REPLY, correlation=in_time,
                  sign=False)
        too_late = os.urandom(8)
        c.publish(topic, signed(gw, {**move(start + 900, "away-2"), "not_after": now_ms() + 1000}),
                  response_topic=REPLY, correlation=too_late, sign=False)
        time.sleep(2)  # past away-2's deadline
        cutter.mend()
        wait_until(f"{name} back", lambda: metric(gw, "gw_mqtt_connected") == 1)
        time.sleep(3)  # what the broker kept is delivered at once; the move takes a moment
        answers = {}
        for _, p, _, props in c.all(lambda t: t == REPLY, mark):
            corr = getattr(props, "CorrelationData", None)
            if corr in (in_time, too_late):
                answers["in_time" if corr == in_time else "too_late"] = json.loads(p)
        return gw, start, answers, health_session(gw)
    finally:
        c.close()
        cutter.close()


def test_kept_session(fx, binary, broker, contract):
    gw, start, answers, session = sent_while_away(fx, binary, broker, contract, 60)
    check(answers.get("in_time", {}).get("type") == "result", f"the command in time ran when it was back: {answers}")
    check(abs(settled_x(gw) - (start + 300)) < 1, f"it moved to {start + 300}: X={x_of(gw)}")
    check_stale(answers.get("too_late", {"type": None}), "not_after", contract)
    check(not audit_entries(gw, "mqtt.away-2"), "the stale one never ran")
    check(len(audit_entries(gw, "mqtt.away-1")) == 1, "the one in time ran once")
    with open(gw.log_path) as f:
        log = f.read()
    check("the broker had no session for it: a new one begins" in log and "the broker kept the session" in log,
          f"its log says the broker had no session at first, and kept it after the cut: {gw.tail(8)}")
    check(session == "kept", f"health says so: {session}")


def test_clean_session(fx, binary, broker, contract):
    gw, start, answers, session = sent_while_away(fx, binary, broker, contract, 0)
    check(answers == {}, f"without a kept session the broker kept nothing for the gateway: {answers}")
    check(session == "clean", f"health: {session}")
    check(abs(settled_x(gw) - start) < 1, "and nothing moved")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    ap.add_argument("--asyncapi", default="")
    args = ap.parse_args()
    fx = Fixture("asi-mqtt-fresh-")
    contract = Contract(args.asyncapi)
    gateways = []
    try:
        broker = Broker(fx, "broker")
        broker.start()
        gw = Gateway(fx, args.gateway, "gw-fresh", [f"mqtt://127.0.0.1:{broker.port}"], sims=1,
                     mqtt_extra={"commands": {"enabled": True, "signing_keys": signing_keys_config(),
                                              "max_age_s": MAX_AGE_S}})
        gateways.append(gw)
        gw.start()
        c = Client(broker.port, "fresh-watch")
        c.subscribe(REPLY)
        wait_until("gw-fresh on its broker", lambda: metric(gw, "gw_mqtt_connected") == 1)
        time.sleep(1)  # its command subscriptions
        fx.run("a command past its deadline is refused, not run", test_stale_signed, gw, c, contract)
        fx.run("a HALT is never stale nor a repeat", test_halt_is_never_stale, gw, c)
        fx.run("a redelivered command runs once, answered once", test_redelivery_runs_once, gw, c)
        fx.run("the same over MQTT 3.1.1", test_redelivery_v311, gw, broker)
        c.close()
        fx.run("a kept session: what was sent while away runs when it is back, or is refused as late",
               test_kept_session, fx, args.gateway, broker, contract)
        fx.run("a clean session: nothing sent while away arrives", test_clean_session, fx, args.gateway, broker,
               contract)
        fx.run("bearer tokens: a change needs a deadline", test_bearer_deadlines, fx, args.gateway, contract)
    except Exception as e:  # noqa: BLE001
        fx.failures.append(("setup", e))
        print(f"[FAIL] setup: {e}")
    finally:
        if fx.failures:
            for g in gateways:
                print(f"---- {g.name} log (tail) ----\n{g.tail()}")
        code = fx.report()
        fx.cleanup()
    return code


if __name__ == "__main__":
    run_main(main)
