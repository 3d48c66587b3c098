"""MQTT failover on a clustered broker (issue 37): a 3-node NATS JetStream cluster with
its MQTT front end (Debian's nats-server; MQTT 3.1.1, sessions and retained messages replicated on
all three nodes) and the real asi-gateway given every node in mqtt.brokers, its reconnect settings
left at their defaults.

- The gateway tells which node it is connected to: in its log, GET /api/v1/health (mqtt.broker),
  /metrics (gw_mqtt_broker{broker=...} 1) and its birth ("broker").
- kill -9 of that node: the gateway connects to another node within a second (not after a backoff,
  and not after trying the dead node first) and publishes its birth and every controller's state again; a
  watcher on the third node sees them, and says how long after the kill. The log, health, metrics
  and birth then name the node it is on, and every live node serves the birth naming it as the
  retained one (the gateway reads it back and publishes it again when a node does not).
- Its command subscriptions are made again: a command through a live node is answered.
- The same again once the first node is back (two of three must live for the cluster's quorum): the
  node it moved to is killed, and it moves on.
- A kept session (mqtt.session_expiry_s, QoS 1 command subscriptions; a second gateway, its links
  through tests/support/link_cutter.py): a command published while its links are cut waits in the
  session and runs once, answered, when it is back; so does one published while its node is dead
  (the node that led NATS's MQTT message stream) and its way to the others cut.

Command subscriptions at QoS 0 (mqtt.qos.responses 0), as the README advises for NATS: a QoS 1
subscription there is a JetStream consumer, which the cluster cannot create for many seconds after a
node's death, and the birth waits behind the subscriptions (the broker handles a connection's packets
in order).

Run by ctest (mqtt_cluster); by hand:
  /usr/bin/python3 tests/integration/api/mqtt_cluster_test.py --gateway build/gateway/asi-gateway \\
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
from gateway_fixture import (TOKENS, Fixture, axis_position, check, http_request, run_main,  # noqa: E402
                             signed_if_token, wait_until)
from mqtt_api_test import Client, Contract, Gateway, command, payload_json  # noqa: E402
from mqtt_freshness_test import audit_entries  # noqa: E402
from nats_cluster import NatsCluster  # noqa: E402

# Time from a node's death to the birth on another one. NATS itself needs a few seconds after the
# death when the node led the cluster's MQTT session stream (a connect waits for its new leader:
# about 5 s, more on a loaded machine); this bound catches a gateway that hangs on the dead node or lets its
# command subscriptions hold the birth up (NATS creates a JetStream consumer for each QoS 1
# subscription, which timed out for 15 s after a death: the test subscribes at QoS 0, as the README
# advises for NATS).
REPUBLISH_BOUND_S = 30.0


def health_mqtt(gw):
    status, body = http_request(gw.port, "GET", "/api/v1/health", token=None)
    check(status == 200, f"health: {status} {body}")
    return json.loads(body)["mqtt"]


def broker_metric(gw):
    """{broker: value} of gw_mqtt_broker in /metrics."""
    status, text = http_request(gw.port, "GET", "/api/v1/metrics", token=TOKENS["viewer"])
    check(status == 200, f"metrics: {status}")
    out = {}
    for line in text.splitlines():
        if line.startswith('gw_mqtt_broker{broker="'):
            name = line.split('"')[1]
            out[name] = float(line.rsplit(" ", 1)[1])
    return out


def birth_after(watcher, gw, start, contract):
    """The first birth (state online) of `gw` recorded from message index `start`: (arrival, payload)."""
    topic = gw.topic("status")

    def pred(t, p, retained, props):
        return t == topic and p and payload_json(p).get("state") == "online"
    watcher.wait_for(f"{gw.name}'s birth", pred, timeout=30, start=start)
    with watcher.cv:
        for arrived, m in zip(watcher.arrived[start:], watcher.messages[start:]):
            if pred(*m):
                contract.validate(m[0], m[1])
                return arrived, payload_json(m[1])
    raise AssertionError("unreachable")


class StampedClient(Client):
    """A 3.1.1 client that notes when each message arrived. It subscribes at QoS 0: on NATS a QoS 1
    subscription is a JetStream consumer, which the cluster cannot create while it elects leaders."""

    def __init__(self, port, name):
        self.arrived = []
        self.filters = []
        super().__init__(port, name, v5=False)
        # NATS drops connections while it elects; paho connects again, with a clean session.
        self.c.on_connect = lambda client, *a: [client.subscribe(f, qos=0) for f in self.filters]

    def subscribe(self, *filters):
        self.filters += filters
        for f in filters:
            self.c.subscribe(f, qos=0)
        time.sleep(0.3)

    def _on_message(self, client, userdata, msg):
        self.arrived.append(time.monotonic())
        super()._on_message(client, userdata, msg)


def fail_over(fx, cluster, gw, contract, label):
    """Kills the node the gateway is on; checks it comes back through another and says so. Returns
    the seconds from the kill to the birth a watcher saw."""
    before = health_mqtt(gw)
    check(before["connected"] and before["broker"] in cluster.broker_uris(), f"{label}: health before: {before}")
    on = cluster.broker_uris().index(before["broker"])
    dead = before["broker"]
    watch_port = next(p for i, p in enumerate(cluster.mqtt_ports) if i != on and cluster.nodes[i].poll() is None)
    watcher = StampedClient(watch_port, f"watcher-{label}")
    watcher.subscribe(gw.topic("status"), gw.topic("controllers", "+", "state"))
    mark = watcher.mark()
    with open(gw.log_path) as f:
        log_mark = len(f.read())
    killed_at = time.monotonic()
    cluster.kill(on)
    arrived, birth = birth_after(watcher, gw, mark, contract)
    seconds = arrived - killed_at
    print(f"    {label}: node n{on + 1} killed; birth through {birth['broker']} after {seconds:.2f} s")
    check(birth["broker"] != dead and birth["broker"] in cluster.broker_uris(),
          f"{label}: the birth names a live node: {birth['broker']} (was on {dead})")
    check(seconds < REPUBLISH_BOUND_S, f"{label}: the birth came {seconds:.1f} s after the node's death")
    # The states follow the birth on the same connection; but while NATS elects it was seen to drop a
    # connection it had just taken 4 s later (its session could not be stored), after the birth went
    # through and before the states did. The gateway then connects again and publishes both again:
    # the states are due within the same bound from the kill as the birth.
    for cid in ("sim1", "sim2"):
        topic = gw.topic("controllers", cid, "state")
        left = max(1.0, REPUBLISH_BOUND_S - (time.monotonic() - killed_at))
        watcher.wait_for(f"{cid}'s state again", lambda t, p, r, props, topic=topic: t == topic, timeout=left,
                         start=mark)
    # Its command subscriptions are in place again: a command through the watcher's node is answered.
    reply = f"clients/{label}/replies"
    watcher.subscribe(reply)
    answer = command(watcher, gw.topic("controllers", "sim2", "cmd"),
                     {"id": f"{label}-here", "operation": "here", "args": {"axes": {"Y": 0}},
                      "token": TOKENS["operator"], "reply_to": reply}, reply, v5=False)
    check(answer["type"] == "result" and answer["id"] == f"{label}-here",
          f"{label}: a command after the failover: {answer}")
    watcher.close()
    # Health, metrics and the log name the node it is on (NATS may have moved it on once more).
    after = health_mqtt(gw)
    check(after["connected"] and after["broker"] != dead and after["broker"] in cluster.broker_uris()
          and after["connects"] > before["connects"], f"{label}: health after: {after} (before: {before})")
    metric = broker_metric(gw)
    check(metric.get(after["broker"]) == 1 and sum(metric.values()) == 1, f"{label}: gw_mqtt_broker: {metric}")
    with open(gw.log_path) as f:
        log = f.read()[log_mark:]
    check(f"connected to {after['broker']}" in log, f"{label}: the log names the node: {gw.tail(10)}")
    # Every attempt after the loss tried the live nodes first, the dead one last.
    for line in log.splitlines():
        if "cannot connect to any of" in line:
            tried = line.split("cannot connect to any of ", 1)[1].split(":", 2)
            first_tried = ":".join(tried[:3]).split(",")[0]
            check(first_tried != dead, f"{label}: an attempt tried the dead node first: {line}")
    # Every live node serves a newcomer the birth naming the node the gateway is on. NATS was seen to
    # keep serving the birth from before a failover (it acknowledged the new one and lost it while
    # its retained-message stream elected a leader); the gateway reads its retained birth back and
    # publishes it again until the broker serves it (api/mqtt/retained_birth_check.hpp).
    started = time.monotonic()
    for i, port in enumerate(cluster.mqtt_ports):
        if cluster.nodes[i].poll() is not None:
            continue
        back = " (back after its own death)" if i in cluster.restarted else ""

        def served_now(i=i, port=port):
            fresh = StampedClient(port, f"fresh-{label}-{i}-{time.monotonic_ns()}")
            try:
                fresh.subscribe(gw.topic("status"))
                time.sleep(1)
                served = [payload_json(m[1]).get("broker") for m in fresh.all(lambda t: t == gw.topic("status"))
                          if m[1] and m[2]]
                return served if served and served[-1] == health_mqtt(gw)["broker"] else None
            finally:
                fresh.close()
        wait_until(f"{label}: n{i + 1}{back} serves the birth naming the gateway's node", served_now, timeout=60)
        print(f"    {label}: n{i + 1}{back} serves the current retained birth "
              f"({time.monotonic() - started:.1f} s after the checks began)")
    with open(gw.log_path) as f:
        republished = f.read()[log_mark:].count("publishing the birth and states again")
    print(f"    {label}: the gateway published its birth again {republished} time(s) after reading it back")
    return seconds


def falls_back_to_3_1_1(fx, cluster, binary, contract):
    """A gateway left at MQTT 5 (the default) on NATS, which speaks 3.1.1 only: it speaks 3.1.1 after
    the first refusal, and says so in its log, its birth and its health."""
    gw = Gateway(fx, binary, "gw-v5", cluster.broker_uris(), sims=1)
    gw.config["mqtt"].pop("reconnect", None)
    gw.config["mqtt"]["qos"] = {"responses": 0}
    watcher = StampedClient(int(cluster.broker_uris()[1].rsplit(":", 1)[1]), "v5-watch")
    try:
        watcher.subscribe(gw.topic("status"))
        gw.start()
        _, birth = birth_after(watcher, gw, 0, contract)
        check(birth["protocol"] == "3.1.1", f"the birth says what it speaks: {birth}")
        h = wait_until("gw-v5 connected", lambda: (lambda m: m if m["connected"] else None)(health_mqtt(gw)))
        check(h["protocol"] == "3.1.1", f"health: {h}")
        log = open(gw.log_path).read()
        check("refused MQTT 5" in log and "speaking MQTT 3.1.1" in log, f"the log says so: {gw.tail(10)}")
        check(log.count("refused MQTT 5") == 1, "said once")
        # And it takes commands over 3.1.1 (reply_to).
        reply = "clients/v5/replies"
        watcher.subscribe(reply)
        ans = command(watcher, gw.topic("controllers", "sim1", "cmd"),
                      {"id": "v5-halt", "operation": "halt", "reply_to": reply, "token": TOKENS["operator"]},
                      reply, v5=False)
        check(ans["type"] == "result", f"a command after the fallback: {ans}")
    finally:
        watcher.close()
        gw.proc.terminate()
        gw.proc.wait(timeout=10)


def publish_until_acknowledged(client, topic, payload):
    """Publishes at QoS 1 until NATS acknowledges it (it stores it first; while it elects a leader of
    its message stream the store times out), as any QoS 1 publisher does. Returns the seconds it took."""
    sent = time.monotonic()
    while True:
        info = client.c.publish(topic, payload, qos=1)
        try:
            info.wait_for_publish(10)
            if info.is_published():
                return time.monotonic() - sent
        except RuntimeError:  # NATS dropped the publisher's connection; paho connects again
            time.sleep(1)
        check(time.monotonic() - sent < 60, "NATS acknowledged the command within a minute")


def kept_session(fx, cluster, binary):
    """A gateway keeping its session (session_expiry_s, QoS 1 command subscriptions) on the node a
    that leads NATS's MQTT message stream. Its links to a and b go through link cutters; the scheduler
    is on c.
    1. Both links cut: a command sent meanwhile waits in the session and runs once, answered, when
       the link to a is mended; the gateway says the broker kept its session.
    2. The link to b cut, a killed: the command sent meanwhile is acknowledged once NATS has elected
       a new leader of the stream (seconds); when the link to b is mended, the gateway is back with
       its session and the command runs once.
    NATS hands over what a session kept only when its ack_wait runs out (30 s by default; then the
    signed command is older than commands.signature_window_s and is dropped): the cluster runs with
    ack_wait 2 s, as the README advises."""
    dead = [i for i, p in enumerate(cluster.nodes) if p.poll() is not None]
    for i in dead:  # all three: one is killed below, and two must live for the quorum
        cluster.start_node(i)
        wait_until(f"n{i + 1} back in the cluster", lambda i=i: cluster.rejoined(i), timeout=60)
    a = cluster.stream_leader("$MQTT_msgs")
    b, c = [i for i in range(3) if i != a]
    to_a, to_b = LinkCutter(cluster.mqtt_ports[a]), LinkCutter(cluster.mqtt_ports[b])
    gw = Gateway(fx, binary, "gw-kept", [f"tcp://127.0.0.1:{to_a.port}", f"tcp://127.0.0.1:{to_b.port}"], sims=1,
                 mqtt_extra={"protocol": "3.1.1", "session_expiry_s": 300, "qos": {"responses": 1}})
    # The command signed before NATS's election is run after it (seconds; more on a loaded machine).
    gw.config["mqtt"]["commands"].update({"max_age_s": 120, "signature_window_s": 120})
    scheduler = None
    topic = gw.topic("controllers", "sim1", "cmd")
    reply = "clients/kept/replies"

    def connected():
        return gw.proc.poll() is None and health_mqtt(gw)["connected"]

    def send_while_away(cid, x):
        wait_until(f"gw-kept lost its broker ({cid})", lambda: not connected(), timeout=30)
        body = {"id": cid, "operation": "move", "args": {"axes": {"X": x}, "wait": True},
                "token": TOKENS["operator"], "reply_to": reply}
        took = publish_until_acknowledged(scheduler, topic, signed_if_token(topic, body))
        check(not connected(), f"{cid} was acknowledged while the gateway had no broker")
        return took

    def answers_to(cid, mark):
        return [payload_json(m[1]) for m in scheduler.all(lambda t: t == reply, mark)
                if payload_json(m[1]).get("id") == cid]

    try:
        gw.start()
        wait_until(f"gw-kept on n{a + 1}", connected)
        time.sleep(1)  # its command subscriptions (JetStream consumers on NATS)
        scheduler = StampedClient(cluster.mqtt_ports[c], "kept-scheduler")
        scheduler.subscribe(reply)

        # 1. The links cut, no node dies.
        start = axis_position(gw.port, "sim1")
        mark = scheduler.mark()
        with open(gw.log_path) as f:
            log_mark = len(f.read())
        to_a.cut()
        to_b.cut()
        send_while_away("kept-cut", start + 300)
        to_a.mend()
        mended = time.monotonic()
        scheduler.wait_for("kept-cut's answer", lambda t, p, r, props: t == reply and payload_json(p).get("id")
                           == "kept-cut", timeout=60, start=mark)
        print(f"    links cut: kept-cut answered {time.monotonic() - mended:.1f} s after the link was mended")
        wait_until("X moved", lambda: abs(axis_position(gw.port, "sim1") - (start + 300)) < 1, timeout=20)
        time.sleep(2)  # a redelivery would come now
        answers = answers_to("kept-cut", mark)
        check(len(answers) == 1 and answers[0]["type"] == "result", f"ran and answered once: {answers}")
        check(len(audit_entries(gw, "mqtt.kept-cut")) == 1, "it ran once")
        with open(gw.log_path) as f:
            log = f.read()[log_mark:]
        check("the broker kept the session" in log, f"the gateway says the broker kept its session: {gw.tail(5)}")
        check(health_mqtt(gw)["session"] == "kept", f"and its health: {health_mqtt(gw)}")

        # 2. Its node dies while the way to the others is cut.
        start = axis_position(gw.port, "sim1")
        mark = scheduler.mark()
        to_b.cut()
        cluster.kill(a)
        took = send_while_away("kept-death", start + 300)
        to_b.mend()
        wait_until(f"gw-kept on n{b + 1}", connected, timeout=60)
        h = health_mqtt(gw)
        check(h["broker"] == f"tcp://127.0.0.1:{to_b.port}", f"through n{b + 1}: {h}")
        wait_until("kept-death ran", lambda: audit_entries(gw, "mqtt.kept-death"), timeout=60)
        time.sleep(3)  # a redelivery would come now
        answers = answers_to("kept-death", mark)
        runs = len(audit_entries(gw, "mqtt.kept-death"))
        # While NATS elects, an answer can be lost on its way to the scheduler (bench/RESULTS.md).
        check(runs == 1 and len(answers) <= 1, f"ran once, answered once at most: {runs} run(s), {answers}")
        wait_until("X moved", lambda: abs(axis_position(gw.port, "sim1") - (start + 300)) < 1, timeout=20)
        print(f"    n{a + 1} (the message stream's leader) killed: the command was acknowledged {took:.1f} s "
              f"after it was first sent, ran once, answered {len(answers)} time(s)")
    except Exception:
        print(f"---- {gw.name} log (tail) ----\n{gw.tail(40)}")
        raise
    finally:
        if scheduler:
            scheduler.close()
        to_a.close()
        to_b.close()
        if gw.proc:
            gw.proc.terminate()
            gw.proc.wait(timeout=10)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    ap.add_argument("--asyncapi", required=True)
    args = ap.parse_args()
    contract = Contract(args.asyncapi)
    fx = Fixture("gw-mqtt-cluster-")
    try:
        cluster = NatsCluster(fx.tmp, fx.procs, ack_wait="2s")  # for kept sessions (the README's advice)
        cluster.start()
        gw = Gateway(fx, args.gateway, "gw-cluster", cluster.broker_uris(), mqtt_extra={"protocol": "3.1.1"})
        gw.config["mqtt"].pop("reconnect", None)  # the defaults, as a lab would run it
        gw.config["mqtt"]["keepalive_s"] = 30
        gw.config["mqtt"]["qos"] = {"responses": 0}
        gw.start()

        def connected():
            h = health_mqtt(gw)
            return h if h["connected"] else None
        first = wait_until("connected to a node", connected)
        fx.run("the gateway names the node it is on (health, metrics, log)", lambda: (
            check(first["broker"] in cluster.broker_uris() and first["session"] == "clean", f"health: {first}"),
            check(broker_metric(gw).get(first["broker"]) == 1, f"metrics: {broker_metric(gw)}"),
            check(f"connected to {first['broker']}" in open(gw.log_path).read(), "log"),
        ))
        fx.run("MQTT 5 refused by NATS: the gateway speaks 3.1.1 and says so",
               lambda: falls_back_to_3_1_1(fx, cluster, args.gateway, contract))
        fx.run("kill -9 of its node: birth and states through another node at once",
               lambda: fail_over(fx, cluster, gw, contract, "first"))
        def second():
            # The dead node back first: two of three must live for the cluster's quorum.
            dead = next(i for i, p in enumerate(cluster.nodes) if p.poll() is not None)
            cluster.start_node(dead)
            wait_until(f"n{dead + 1} back in the cluster", lambda: cluster.rejoined(dead), timeout=60)
            fail_over(fx, cluster, gw, contract, "second")
        fx.run("n1 back, then kill -9 of the node it moved to: it moves on again", second)
        fx.run("a kept session: a command sent while the gateway had no broker runs once",
               lambda: kept_session(fx, cluster, args.gateway))
        if fx.failures:
            print("---- gateway log (tail) ----\n" + gw.tail(60))
            for i in range(len(cluster.nodes)):
                print(f"---- n{i + 1} (tail) ----\n" + cluster.tail(i, 8))
        return fx.report()
    finally:
        fx.cleanup()


if __name__ == "__main__":
    run_main(main)
