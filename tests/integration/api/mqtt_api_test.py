"""The MQTT fleet interface end to end: a real mosquitto on free loopback ports (a generated config in
a scratch directory), the real asi-gateway (--simulate, sped up) with mqtt enabled, and Debian's
python3-paho-mqtt clients (MQTT 5 and 3.1.1).

Checks: the retained birth; retained controller states; rate-limited positions; commands and jobs
with responses (MQTT 5 response topic + correlation data, 3.1.1 reply_to); bad payloads answered
with errors (the gateway keeps working); job state retained while active and cleared after
retain_finished_s; a broker restart (the gateway reconnects, re-subscribes and republishes its
retained state); two gateways side by side on one broker; the Last Will on kill -9; "offline" on a
clean shutdown; TLS with a CA, server and client certificates made here with openssl. A gateway on
external ms2000-sims (control sockets, --sim) with its own broker (persistent sessions): encoder
report batches (every frame, in order; frames missed while the broker is down counted in the next
batch), TTL events, refused commands that send no serial byte (the simulator's byte counter), and
the bounded queue of job state changes kept while the broker is down. Every payload received is
validated against the schemas of openapi/asyncapi.yaml (when given).

Run by ctest (mqtt_api); by hand:
  /usr/bin/python3 tests/integration/api/mqtt_api_test.py --gateway build/gateway/asi-gateway \
      --sim build/devices/sim/ms2000-sim --asyncapi openapi/asyncapi.yaml
"""

import argparse
import http.client
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gateway_fixture import (TOKENS, WAIT, Failure, Fixture, auth_tokens, check,  # noqa: E402
                             free_port, http_request, signed_command, signed_if_token, signing_keys_config,
                             wait_until)

import paho.mqtt.client as mqtt  # noqa: E402  (Debian python3-paho-mqtt 1.6)
from paho.mqtt.packettypes import PacketTypes  # noqa: E402
from paho.mqtt.properties import Properties  # noqa: E402

PREFIX = "asi"
TIME_SCALE = 10
MOSQUITTO = "/usr/sbin/mosquitto"
MAX_PAYLOAD = 256 * 1024  # mqtt.commands.max_payload_bytes of the test gateways


# ---------------------------------------------------------------------------------------------
# The broker


class Broker:
    """mosquitto on 127.0.0.1:<port> (and a TLS listener when `tls` names the PEM files)."""

    def __init__(self, fx, name, tls=None, extra=(), persistent=False):
        self.fx = fx
        self.name = name
        self.tls = tls
        self.extra = list(extra)
        self.persistent = persistent
        self.proc = None
        self.started = False
        self.conf = os.path.join(fx.tmp, name + ".conf")
        self.log = os.path.join(fx.tmp, name + ".log")
        self.choose_ports()

    def choose_ports(self):
        self.port = free_port()
        self.tls_port = None
        while self.tls and self.tls_port in (None, self.port):
            self.tls_port = free_port()
        # persistent: sessions survive a restart (saved on exit), and QoS 0 messages are queued for a
        # persistent client while it is away, so a watcher misses nothing across a broker restart.
        persistence = ["persistence true", f"persistence_location {self.fx.tmp}/",
                       f"persistence_file {self.name}.db", "queue_qos0_messages true"] \
            if self.persistent else ["persistence false"]
        anonymous = [] if "allow_anonymous false" in self.extra else ["allow_anonymous true"]
        lines = ["per_listener_settings false", *anonymous, *persistence,
                 # as root, mosquitto would become user "mosquitto", who cannot read the 0700 scratch dir
                 *(["user root"] if os.geteuid() == 0 else []),
                 f"log_dest file {self.log}", "log_type error", "log_type warning", "log_type notice",
                 f"listener {self.port} 127.0.0.1"]
        lines += self.extra
        if self.tls:
            lines += [f"listener {self.tls_port} 127.0.0.1", f"cafile {self.tls['ca']}",
                      f"certfile {self.tls['cert']}", f"keyfile {self.tls['key']}", "require_certificate true"]
        with open(self.conf, "w") as f:
            f.write("\n".join(lines) + "\n")

    def start(self):
        # A port that free_port() found free may be taken (by a client's ephemeral port, or another
        # test) before mosquitto binds it: at the first start the broker takes new ports then. A
        # restart keeps its ports (the clients know them).
        for attempt in range(3):
            self.proc = subprocess.Popen([MOSQUITTO, "-c", self.conf], stdout=subprocess.DEVNULL,
                                         stderr=subprocess.STDOUT)
            self.fx.procs.append(self.proc)

            def accepting():
                if self.proc.poll() is not None:
                    return "exited"
                with socket.create_connection(("127.0.0.1", self.port), timeout=1):
                    return "accepting"
            if wait_until(f"mosquitto {self.name} on {self.port}", accepting) == "accepting":
                self.started = True
                return
            log = open(self.log).read() if os.path.exists(self.log) else ""
            if self.started or "Address already in use" not in log or attempt == 2:
                raise Failure(f"mosquitto {self.name} exited at start: {log[-2000:]}")
            self.choose_ports()

    def stop(self):
        self.proc.terminate()
        self.proc.wait(timeout=WAIT)


# ---------------------------------------------------------------------------------------------
# Clients


class Client:
    """A paho client that records every message; helpers wait for one that matches."""

    def __init__(self, broker_port, name, v5=True, tls=None, port=None, user=None, session=False):
        self.v5 = v5
        self.messages = []  # (topic, payload bytes, retained, properties)
        self.cv = threading.Condition()
        self.c = mqtt.Client(client_id=name, protocol=mqtt.MQTTv5 if v5 else mqtt.MQTTv311)
        if user:
            self.c.username_pw_set(user, user + "-password")
        if tls:
            self.c.tls_set(ca_certs=tls["ca"], certfile=tls["cert"], keyfile=tls["key"])
        self.c.on_message = self._on_message
        connected = threading.Event()
        self.c.on_connect = lambda *a: connected.set()
        self.port = port or broker_port
        kw = {}
        if session:  # MQTT 5: keep (or resume) the session and its queued messages for an hour
            props = Properties(PacketTypes.CONNECT)
            props.SessionExpiryInterval = 3600
            kw = {"clean_start": False, "properties": props}
        self.c.connect("127.0.0.1" if not tls else "localhost", self.port, keepalive=30, **kw)
        self.c.loop_start()
        check(connected.wait(WAIT), f"client {name} could not connect")

    def _on_message(self, client, userdata, msg):
        with self.cv:
            self.messages.append((msg.topic, msg.payload, bool(msg.retain), getattr(msg, "properties", None)))
            self.cv.notify_all()

    def subscribe(self, *filters):
        for f in filters:
            result, mid = self.c.subscribe(f, qos=1)
            check(result == mqtt.MQTT_ERR_SUCCESS, f"subscribe {f}: {result}")
        time.sleep(0.3)  # the SUBACK; retained messages follow it

    def publish(self, topic, payload, response_topic=None, correlation=None, retain=False, sign=True):
        """Publishes; a payload with a test token goes out signed with that role's key instead
        (sign=False sends the token as it is)."""
        if sign:
            payload = signed_if_token(topic, payload)
        props = None
        if self.v5 and (response_topic or correlation):
            props = Properties(PacketTypes.PUBLISH)
            if response_topic:
                props.ResponseTopic = response_topic
            if correlation:
                props.CorrelationData = correlation
        data = payload if isinstance(payload, (bytes, str)) else json.dumps(payload)
        info = self.c.publish(topic, data, qos=1, retain=retain, properties=props)
        info.wait_for_publish(WAIT)

    def wait_for(self, what, pred, timeout=WAIT, start=0):
        """The first recorded message (from index `start`) with pred(topic, payload, retained, props)."""
        deadline = time.monotonic() + timeout
        with self.cv:
            while True:
                for m in self.messages[start:]:
                    if pred(*m):
                        return m
                left = deadline - time.monotonic()
                if left <= 0:
                    raise Failure(f"timed out waiting for {what}; got {len(self.messages)} messages: "
                                  f"{[m[0] for m in self.messages[-8:]]}")
                self.cv.wait(left)

    def mark(self):
        with self.cv:
            return len(self.messages)

    def all(self, topic_pred, start=0):
        with self.cv:
            return [m for m in self.messages[start:] if topic_pred(m[0])]

    def close(self):
        self.c.loop_stop()
        self.c.disconnect()


def c_port(client):
    return client.port


def payload_json(p):
    return json.loads(p.decode()) if p else None


# ---------------------------------------------------------------------------------------------
# Schemas (openapi/asyncapi.yaml)


class Contract:
    """The AsyncAPI document: structure checks and payload validation per channel."""

    def __init__(self, path):
        self.doc = None
        if path:
            import yaml  # Debian python3-yaml
            with open(path) as f:
                self.doc = yaml.safe_load(f)
        self.checked = 0

    def schema_for(self, topic):
        """The payload schema of the channel whose address matches `topic`."""
        if not self.doc:
            return None
        levels = topic.split("/")
        for channel in self.doc["channels"].values():
            address = channel["address"].split("/")
            if len(address) != len(levels):
                continue
            if all(a.startswith("{") or a == lv for a, lv in zip(address, levels)):
                msgs = list(channel["messages"].values())
                schemas = [self.resolve(self.resolve(m)["payload"]) for m in msgs]
                return {"oneOf": schemas} if len(schemas) > 1 else schemas[0]
        if levels[0] != PREFIX:  # an answer topic: the channel whose address is one parameter
            for channel in self.doc["channels"].values():
                if channel["address"].startswith("{") and "/" not in channel["address"]:
                    msgs = list(channel["messages"].values())
                    return {"oneOf": [self.resolve(self.resolve(m)["payload"]) for m in msgs]}
        raise Failure(f"no channel of asyncapi.yaml matches {topic}")

    def resolve(self, node):
        while isinstance(node, dict) and "$ref" in node:
            ref = node["$ref"]
            check(ref.startswith("#/"), f"only local $refs: {ref}")
            target = self.doc
            for part in ref[2:].split("/"):
                target = target[part]
            node = target
        return node

    def validate(self, topic, payload):
        if not self.doc or not payload:
            return
        import jsonschema  # Debian python3-jsonschema
        schema = self.schema_for(topic)
        resolver = jsonschema.RefResolver.from_schema(self.doc)
        try:
            jsonschema.validate(json.loads(payload), schema, resolver=resolver)
        except jsonschema.ValidationError as e:
            raise Failure(f"{topic}: payload does not match asyncapi.yaml: {e.message} at "
                          f"{list(e.absolute_path)}: {payload[:300]!r}")
        self.checked += 1

    def check_structure(self):
        check(self.doc is not None, "no asyncapi document given")
        d = self.doc
        check(str(d.get("asyncapi", "")).startswith("3."), "asyncapi: 3.x expected")
        check("info" in d and "title" in d["info"] and "version" in d["info"], "info.title/version")
        import jsonschema
        for name, ch in d["channels"].items():
            check("address" in ch and ch.get("messages"), f"channel {name}: address and messages")
            for mname, m in ch["messages"].items():
                msg = self.resolve(m)
                check("payload" in msg, f"channel {name} message {mname}: payload")
                schema = self.resolve(msg["payload"])
                jsonschema.Draft7Validator.check_schema(schema)
                for ex in msg.get("examples", []):
                    jsonschema.validate(ex["payload"], schema,
                                        resolver=jsonschema.RefResolver.from_schema(self.doc))
        for name, op in d.get("operations", {}).items():
            check(op.get("action") in ("send", "receive"), f"operation {name}: action")
            ref = op.get("channel", {}).get("$ref", "")
            check(ref.startswith("#/channels/") and ref[len("#/channels/"):] in d["channels"],
                  f"operation {name}: channel {ref}")
        # Every topic the gateway publishes or reads has a channel.
        addresses = {ch["address"] for ch in d["channels"].values()}
        for needed in ["{prefix}/{gateway}/status", "{prefix}/{gateway}/controllers/{controller}/state",
                       "{prefix}/{gateway}/controllers/{controller}/position",
                       "{prefix}/{gateway}/controllers/{controller}/reports",
                       "{prefix}/{gateway}/controllers/{controller}/ttl",
                       "{prefix}/{gateway}/controllers/{controller}/errors",
                       "{prefix}/{gateway}/jobs/{job}/state", "{prefix}/{gateway}/controllers/{controller}/cmd",
                       "{prefix}/{gateway}/recordings/{recording}",
                       "{prefix}/{gateway}/jobs/submit", "{prefix}/{gateway}/jobs/cancel",
                       "{prefix}/{gateway}/jobs/pause", "{prefix}/{gateway}/jobs/resume",
                       "{prefix}/{gateway}/jobs/next", "{prefix}/{gateway}/gcode/check", "{reply_topic}"]:
            check(needed in addresses, f"asyncapi.yaml has no channel {needed}")


# ---------------------------------------------------------------------------------------------
# Gateways


class Gateway:
    """One asi-gateway process with mqtt enabled: its own config, log and job store."""

    def __init__(self, fx, binary, name, brokers, sims=2, mqtt_extra=None):
        self.fx = fx
        self.binary = binary
        self.name = name
        self.port = free_port()
        self.proc = None
        self.config = {
            "http": {"listen_address": "127.0.0.1", "port": self.port},
            "storage": {"path": os.path.join(fx.tmp, name + "-store")},
            "auth": auth_tokens(),
            "logging": {"level": "info"},
            "mqtt": {"enabled": True, "brokers": brokers, "gateway_id": name, "topic_prefix": PREFIX,
                     "keepalive_s": 5, "reconnect": {"min_ms": 100, "max_ms": 1000},
                     "telemetry": {"position_max_hz": 5}, "jobs": {"retain_finished_s": 3},
                     "commands": {"enabled": True, "max_payload_bytes": MAX_PAYLOAD,
                                  "signing_keys": signing_keys_config()}, **(mqtt_extra or {})},
        }
        self.extra = ["--simulate", str(sims), "--time-scale", str(TIME_SCALE),
                      "--sim-dir", os.path.join(fx.tmp, name + "-sims")]
        self.log_path = os.path.join(fx.tmp, name + ".log")

    def start(self, wait_ready=True):
        cfg = os.path.join(self.fx.tmp, self.name + ".json")
        with open(cfg, "w") as f:
            json.dump(self.config, f)
        log = open(self.log_path, "a")
        self.proc = subprocess.Popen([self.binary, "--config", cfg, *self.extra], stdout=log,
                                     stderr=subprocess.STDOUT)
        log.close()
        self.fx.procs.append(self.proc)
        if wait_ready:
            wait_until(f"gateway {self.name} ready",
                       lambda: http_request(self.port, "GET", "/api/v1/ready", token=None)[0] == 200)

    def topic(self, *levels):
        return "/".join([PREFIX, self.name, *levels])

    def tail(self, n=40):
        with open(self.log_path) as f:
            return "".join(f.readlines()[-n:])


def status_is(gw, state, reason=None):
    def pred(topic, payload, retained, props):
        if topic != gw.topic("status") or not payload:
            return False
        j = payload_json(payload)
        return j["state"] == state and (reason is None or j.get("reason") == reason)
    return pred


# ---------------------------------------------------------------------------------------------
# Tests


def test_birth(gw, c, contract):
    c.subscribe(gw.topic("status"))
    _, p, _, _ = c.wait_for("birth", status_is(gw, "online"))
    fresh = Client(c_port(c), "birth-late")
    try:
        fresh.subscribe(gw.topic("status"))
        _, _, retained, _ = fresh.wait_for("retained birth", status_is(gw, "online"))
        check(retained, "the birth message is retained")
    finally:
        fresh.close()
    contract.validate(gw.topic("status"), p)
    j = payload_json(p)
    check(j["gateway"] == gw.name and j["protocol"] == "5" and j["prefix"] == PREFIX, f"birth: {j}")
    check([x["id"] for x in j["controllers"]] == ["sim1", "sim2"], f"controllers: {j['controllers']}")
    check("commands" in j["capabilities"] and "jobs" in j["capabilities"], f"capabilities: {j}")
    check(j["version"], "version")


def test_retained_state(gw, broker, contract):
    # A client that comes later still gets every controller's state at once (retained).
    def connected_state(cid):
        def pred(topic, payload, retained, props):
            if topic != gw.topic("controllers", cid, "state") or not retained:
                return False
            return payload_json(payload)["data"]["state"] == "connected"
        return pred
    # The retained state is the newest one: wait until both are connected there.
    for cid in ("sim1", "sim2"):
        def fresh():
            late = Client(broker.port, f"late-{cid}-{time.monotonic_ns()}")
            try:
                late.subscribe(gw.topic("controllers", "+", "state"))
                return late.wait_for(f"retained {cid} state", connected_state(cid), timeout=2)
            except Failure:
                return None
            finally:
                late.close()
        _, p, _, _ = wait_until(f"retained connected state of {cid}", fresh)
        contract.validate(gw.topic("controllers", cid, "state"), p)
        j = payload_json(p)
        check(j["type"] == "event" and j["seq"] >= 1 and j["data"]["id"] == cid, f"state: {j}")
        check(isinstance(j["data"]["axes"], list) and j["data"]["axes"], "axes in the state")


def command(c, topic, body, reply_topic, correlation=None, v5=True, sign=True):
    """Publishes a command and waits for its answer (matched by correlation data or id)."""
    start = c.mark()
    if v5:
        corr = correlation or os.urandom(8)
        c.publish(topic, body, response_topic=reply_topic, correlation=corr, sign=sign)

        def pred(t, p, r, props):
            return t == reply_topic and props is not None and getattr(props, "CorrelationData", None) == corr
    else:
        c.publish(topic, body)
        want = body.get("id") if isinstance(body, dict) else None

        def pred(t, p, r, props):
            return t == reply_topic and (want is None or payload_json(p).get("id") == want)
    _, p, retained, _ = c.wait_for(f"answer on {reply_topic}", pred, start=start)
    check(not retained, "answers are not retained")
    return payload_json(p)


def unanswered(c, topic, body, reply_topic, barrier=None, sign=True):
    """Publishes a command that must get no answer at all: a known sender's command published after
    it on the same topic (`barrier`, a viewer's HALT unless given) is answered, and nothing came for
    the first one before that answer (the gateway handles a topic's messages in order)."""
    start = c.mark()
    corr = os.urandom(8)
    c.publish(topic, body, response_topic=reply_topic, correlation=corr, sign=sign)
    command(c, topic, barrier or {"operation": "halt", "token": TOKENS["viewer"]}, reply_topic)
    answers = [m for m in c.all(lambda t: t == reply_topic, start) if getattr(m[3], "CorrelationData", None) == corr]
    check(not answers, f"{body!r} was answered: {answers}")


def test_commands_v5(gw, c, contract):
    reply = "clients/v5/replies"
    c.subscribe(reply, gw.topic("controllers", "sim1", "position"))
    mark = c.mark()
    ans = command(c, gw.topic("controllers", "sim1", "cmd"),
                  {"id": "m1", "operation": "move", "args": {"axes": {"X": 1234}, "wait": True},
                   "token": TOKENS["operator"]}, reply)
    contract.validate(reply, json.dumps(ans))
    check(ans["type"] == "result" and ans["id"] == "m1", f"answer: {ans}")
    check(ans["result"]["operation"] == "move" and ans["result"]["id"] == "sim1", f"result: {ans}")
    x = [a for a in ans["result"]["positions"] if a["axis"] == "X"][0]["position_um"]
    check(abs(x - 1234) < 1, f"moved to X={x}")
    # Positions arrived meanwhile, at most position_max_hz (5/s) plus slack.
    pos = c.wait_for("a position", lambda t, p, r, pr: t == gw.topic("controllers", "sim1", "position"),
                     start=mark)
    contract.validate(pos[0], pos[1])
    # An answer without an id: the gateway names it.
    ans = command(c, gw.topic("controllers", "sim1", "cmd"), {"operation": "halt", "token": TOKENS["operator"]},
                  reply)
    check(ans["type"] == "result" and str(ans["id"]).startswith("mqtt-"), f"generated id: {ans}")


def upload_program(gw, text, name):
    """Stores a G-code program over REST; its id."""
    conn = http.client.HTTPConnection("127.0.0.1", gw.port, timeout=WAIT)
    conn.request("POST", f"/api/v1/gcode/files?name={name}", body=text.encode(),
                 headers={"Authorization": f"Bearer {TOKENS['operator']}", "Content-Type": "text/plain"})
    r = conn.getresponse()
    body = r.read().decode()
    conn.close()
    check(r.status == 201, f"upload: {r.status} {body}")
    return json.loads(body)["id"]


def test_gcode_check(gw, c, contract):
    reply = "clients/gcode/replies"
    c.subscribe(reply)
    good = upload_program(gw, "G21 G90\nG1 X10. Y0 F600\nG1 X10. Y5.\n", "square.ngc")
    ans = command(c, gw.topic("gcode", "check"), {"id": "g1", "file": good, "token": TOKENS["viewer"]}, reply)
    contract.validate(reply, json.dumps(ans))
    check(ans["type"] == "result" and ans["id"] == "g1", f"answer: {ans}")
    check(ans["result"]["move_count"] == 2 and ans["result"]["bounds"]["max"][:2] == [10, 5], f"summary: {ans}")
    # The same as REST's summary, option for option.
    status, text = http_request(gw.port, "POST", f"/api/v1/gcode/files/{good}/plan?moves=false&xyz_scale=2")
    check(status == 200, f"REST plan: {status} {text}")
    scaled = command(c, gw.topic("gcode", "check"),
                     {"id": "g2", "file": good, "options": {"xyz_scale": 2}, "token": TOKENS["viewer"]}, reply)
    check(scaled.get("result") == json.loads(text), f"MQTT {scaled} against REST {text}")
    bad = upload_program(gw, "G21\nG1 X1. Q7\n", "bad.ngc")
    err = command(c, gw.topic("gcode", "check"), {"id": "g3", "file": bad, "token": TOKENS["viewer"]}, reply)
    contract.validate(reply, json.dumps(err))
    p = err.get("problem", {})
    check(err["type"] == "error" and p.get("type", "").endswith("/invalid-gcode") and p.get("line") == 2,
          f"invalid program: {err}")
    check(p.get("instance") == gw.topic("gcode", "check"), f"instance: {p}")
    unknown = command(c, gw.topic("gcode", "check"),
                      {"id": "g4", "file": "g-00000000000000000000000000", "token": TOKENS["viewer"]}, reply)
    check(unknown["type"] == "error" and unknown["problem"]["status"] == 404, f"unknown file: {unknown}")
    unanswered(c, gw.topic("gcode", "check"), {"id": "g5", "file": good}, reply)  # no token


def test_position_rate(gw, c):
    topic = gw.topic("controllers", "sim2", "position")
    c.subscribe(topic)
    mark = c.mark()
    status, text = http_request(gw.port, "POST", "/api/v1/controllers/sim2/move", {"axes": {"X": 60000}})
    check(status == 200, f"move: {status} {text}")
    time.sleep(3)
    http_request(gw.port, "POST", "/api/v1/controllers/sim2/halt", {})
    n = len(c.all(lambda t: t == topic, start=mark))
    check(2 <= n <= 3 * 5 + 3, f"{n} positions in 3 s at position_max_hz 5")


def test_error_log(gw, c, contract):
    # The controller clamps a move beyond its lower soft limit and logs 35; the gateway publishes it.
    topic = gw.topic("controllers", "sim1", "errors")
    c.subscribe(topic)
    mark = c.mark()
    status, text = http_request(gw.port, "POST", "/api/v1/controllers/sim1/command", {"command": "M Y=-2000000"})
    check(status == 200, f"move beyond the limit: {status} {text}")
    wait_until("the error log message", lambda: c.all(lambda t: t == topic, start=mark), 30)
    t, p, r, _ = c.all(lambda t: t == topic, start=mark)[0]
    check(not r, "error log messages are not retained")
    contract.validate(t, p)
    m = payload_json(p)
    check(m["topic"] == "controllers/sim1/errors" and m["data"]["codes"] == [{"code": 35, "name": "LOWER_LIMIT"}],
          f"error log message {m}")
    # Back where the later tests expect the stage.
    status, text = http_request(gw.port, "POST", "/api/v1/controllers/sim1/move", {"axes": {"Y": 0}, "wait": True})
    check(status == 200, f"move back: {status} {text}")


def test_focus(fx, binary, contract):
    """CRISP and AUTOFOCUS over MQTT on a gateway with the fourth simulated build (sim4, "crisp")."""
    broker = Broker(fx, "broker-focus")
    broker.start()
    gw = Gateway(fx, binary, "gw-focus", [f"mqtt://127.0.0.1:{broker.port}"], sims=4)
    gw.start()
    c = Client(broker.port, "focus-client")
    try:
        reply = "clients/focus/replies"
        state = gw.topic("controllers", "sim4", "state")
        c.subscribe(reply, state)
        cmd = gw.topic("controllers", "sim4", "cmd")
        ans = command(c, cmd, {"id": "af", "operation": "autofocus", "token": TOKENS["operator"]}, reply)
        contract.validate(reply, json.dumps(ans))
        check(ans["type"] == "result" and abs(ans["result"]["z_um"] - 150) < 0.1, f"autofocus: {ans}")
        mark = c.mark()
        ans = command(c, cmd, {"id": "lk", "operation": "crisp", "args": {"action": "lock", "wait": True},
                               "token": TOKENS["operator"]}, reply)
        contract.validate(reply, json.dumps(ans))
        check(ans["type"] == "result" and ans["result"]["crisp"]["name"] == "locked", f"lock: {ans}")

        def locked_state(topic, payload, retained, props):
            return topic == state and (payload_json(payload)["data"]["crisp"] or {}).get("name") == "locked"
        _, p, _, _ = c.wait_for("a state message with CRISP locked", locked_state, start=mark)
        contract.validate(state, p)
        ans = command(c, gw.topic("controllers", "sim1", "cmd"),
                      {"id": "no", "operation": "crisp", "args": {}, "token": TOKENS["operator"]}, reply)
        check(ans["type"] == "error" and ans["problem"]["status"] == 409, f"sim1 has no CRISP: {ans}")
        contract.validate(reply, json.dumps(ans))
    finally:
        c.close()
        gw.proc.send_signal(signal.SIGTERM)
        gw.proc.wait(timeout=WAIT)
        broker.stop()


def test_commands_v311(gw, broker, contract):
    reply = "clients/v311/replies"
    c = Client(broker.port, "v311-client", v5=False)
    try:
        c.subscribe(reply)
        ans = command(c, gw.topic("controllers", "sim2", "cmd"),
                      {"id": 7, "operation": "here", "args": {"axes": {"Y": 0}}, "token": TOKENS["operator"],
                       "reply_to": reply}, reply, v5=False)
        contract.validate(reply, json.dumps(ans))
        check(ans["type"] == "result" and ans["id"] == 7 and ans["result"]["operation"] == "here", f"{ans}")
        ans = command(c, gw.topic("controllers", "sim2", "cmd"),
                      {"id": 8, "operation": "speed", "args": {"axes": {"X": 99999}}, "token": TOKENS["operator"],
                       "reply_to": reply}, reply, v5=False)
        check(ans["type"] == "error" and ans["problem"]["status"] == 422, f"out of range: {ans}")
    finally:
        c.close()


def test_bad_payloads(gw, c, contract):
    reply = "clients/v5/bad"
    c.subscribe(reply)
    cmd = gw.topic("controllers", "sim1", "cmd")
    # From a sender that is not known, nothing is answered: not JSON, no token, a wrong one, too big.
    for body in (b"not json at all", b"[1,2]", {"id": "b3", "operation": "move", "args": {"axes": {"X": 1}}},
                 {"id": "b4", "operation": "move", "args": {"axes": {"X": 1}}, "token": "wrong-token-0000000"},
                 {"id": "b9", "operation": "halt", "token": TOKENS["admin"], "pad": "x" * (MAX_PAYLOAD + 1)}):
        unanswered(c, cmd, body, reply)
    cases = [
        ({"id": "b1", "operation": "fly", "token": TOKENS["admin"]}, 422, "invalid-value", "operation"),
        ({"id": "b2", "operation": "move", "args": {"axes": {"Q": 1}}, "token": TOKENS["admin"]}, 422,
         "invalid-value", None),
        ({"id": "b5", "operation": "move", "args": {"axes": {"X": 1}}, "token": TOKENS["viewer"]}, 403,
         "forbidden", None),
        ({"id": "b6", "operation": "command", "args": {"command": "W X"}, "token": TOKENS["operator"]}, 403,
         "forbidden", None),
        ({"id": "b7", "operation": "halt", "controller": "sim2", "token": TOKENS["admin"]}, 422, "invalid-value",
         "controller"),
        ({"id": "b8", "operation": "halt", "token": TOKENS["admin"], "reply_to": "asi/x/status"}, 422,
         "invalid-value", "reply_to"),
    ]
    for body, status, kind, field in cases:
        ans = command(c, cmd, body, reply)
        contract.validate(reply, json.dumps(ans))
        check(ans["type"] == "error", f"{body!r}: {ans}")
        p = ans["problem"]
        check(p["status"] == status and p["type"].endswith("/" + kind), f"{body!r}: {p}")
        check(field is None or p.get("field") == field, f"{body!r}: field {p.get('field')}")
        check(p["instance"] == cmd, f"instance: {p}")
    # Unknown controller, an unknown job, a job command without a job.
    ans = command(c, gw.topic("controllers", "nope", "cmd"), {"operation": "halt", "token": TOKENS["admin"]}, reply)
    check(ans["type"] == "error" and ans["problem"]["status"] == 404, f"unknown controller: {ans}")
    ans = command(c, gw.topic("jobs", "cancel"), {"job": "j-00000000000000000000000000", "token": TOKENS["admin"]},
                  reply)
    check(ans["type"] == "error" and ans["problem"]["status"] == 404, f"unknown job: {ans}")
    ans = command(c, gw.topic("jobs", "pause"), {"token": TOKENS["admin"]}, reply)
    check(ans["type"] == "error" and ans["problem"].get("field") == "job", f"no job: {ans}")
    # A retained command is never run.
    ans = None
    start = c.mark()
    corr = b"retained-cmd"
    props = Properties(PacketTypes.PUBLISH)
    props.ResponseTopic = reply
    props.CorrelationData = corr
    c.c.publish(cmd, signed_command(cmd, {"operation": "halt"}, "admin"), qos=1, retain=True,
                properties=props).wait_for_publish(WAIT)
    _, p, _, _ = c.wait_for("retained refusal",
                            lambda t, p, r, pr: t == reply and getattr(pr, "CorrelationData", None) == corr,
                            start=start)
    check(payload_json(p)["type"] == "error", f"retained command: {p}")
    c.c.publish(cmd, b"", qos=1, retain=True).wait_for_publish(WAIT)  # clear it
    # Still alive and answering.
    ans = command(c, cmd, {"operation": "halt", "token": TOKENS["operator"]}, reply)
    check(ans["type"] == "result", f"after bad payloads: {ans}")
    check(gw.proc.poll() is None, "the gateway is still running")


def test_signed_commands(gw, c):
    # Commands are signed (HMAC-SHA256 over topic, ts, nonce and body): what the command topic's
    # readers see holds no token, and cannot be used again, elsewhere or later.
    reply = "clients/v5/signed"
    cmd = gw.topic("controllers", "sim1", "cmd")
    c.subscribe(reply, cmd)
    replayed_before = metric(gw, "gw_mqtt_commands_total", outcome="replayed")
    payload = signed_command(cmd, {"operation": "halt"}, "operator")
    mark = c.mark()
    ans = command(c, cmd, payload, reply)
    check(ans["type"] == "result", f"a signed HALT: {ans}")
    _, seen, _, _ = c.wait_for("the command as the topic's readers see it", lambda t, *_: t == cmd, start=mark)
    check(b"token" not in seen and not any(t.encode() in seen for t in TOKENS.values()),
          f"a signed command carries no token: {seen!r}")
    # Before, a reader of the topic harvested the operator's bearer token here and used it on REST.
    unanswered(c, cmd, seen.decode(), reply)  # published again as seen: a replay
    unanswered(c, gw.topic("controllers", "sim2", "cmd"), payload, reply)  # the topic is signed
    forged = json.loads(signed_command(cmd, {"operation": "halt"}, "operator"))
    forged["body"] = json.dumps({"operation": "move", "args": {"axes": {"X": 5000}}})
    unanswered(c, cmd, json.dumps(forged), reply)  # a body not signed
    unknown = json.loads(signed_command(cmd, {"operation": "halt"}, "operator"))
    unknown["key"] = "nobody"
    unanswered(c, cmd, json.dumps(unknown), reply)
    an_hour_ago = int(time.time() * 1000) - 3600 * 1000
    unanswered(c, cmd, signed_command(cmd, {"operation": "halt"}, "operator", ts_ms=an_hour_ago), reply)
    # A bearer token is not taken at all without mqtt.commands.accept_bearer_tokens (and never over
    # a plain connection, as here).
    unanswered(c, cmd, {"operation": "halt", "token": TOKENS["admin"]}, reply, sign=False)
    # A token inside a signed command is answered (the sender is known) and refused.
    ans = command(c, cmd, signed_command(cmd, {"operation": "halt", "token": TOKENS["operator"]}, "operator"),
                  reply)
    check(ans["type"] == "error" and ans["problem"].get("field") == "token", f"a token in a signed body: {ans}")
    # Roles come from the key: a viewer's key may HALT, not move.
    ans = command(c, cmd, signed_command(cmd, {"operation": "move", "args": {"axes": {"X": 10}}}, "viewer"), reply)
    check(ans["type"] == "error" and ans["problem"]["status"] == 403, f"a viewer's move: {ans}")
    check(metric(gw, "gw_mqtt_commands_total", outcome="replayed") >= replayed_before + 1,
          "the replay is counted")


def job_state_pred(gw, job_id, states):
    def pred(topic, payload, retained, props):
        return topic == gw.topic("jobs", job_id, "state") and payload and \
            payload_json(payload)["job"]["state"] in states
    return pred


def test_jobs(gw, c, broker, contract):
    reply = "clients/v5/jobs"
    c.subscribe(reply, gw.topic("jobs", "+", "state"))
    spec = {"grid": {"columns": 3, "rows": 2, "column_step_mm": 0.2, "row_step_mm": -0.2}, "a1": "current",
            "advance": "next"}
    ans = command(c, gw.topic("jobs", "submit"),
                  {"id": "s1", "args": {"controller": "sim1", "type": "array", "spec": spec},
                   "idempotency_key": "mqtt-plate-1", "token": TOKENS["operator"]}, reply)
    contract.validate(reply, json.dumps(ans))
    check(ans["type"] == "result" and ans["result"]["id"].startswith("j-"), f"submit: {ans}")
    job = ans["result"]["id"]
    # Idempotency through MQTT too.
    again = command(c, gw.topic("jobs", "submit"),
                    {"id": "s2", "args": {"controller": "sim1", "type": "array", "spec": spec},
                     "idempotency_key": "mqtt-plate-1", "token": TOKENS["operator"]}, reply)
    check(again.get("replayed") is True and again["result"]["id"] == job, f"replay: {again}")
    _, p, _, _ = c.wait_for("job running", job_state_pred(gw, job, {"running"}))
    fresh = Client(broker.port, "jobs-late")
    try:
        fresh.subscribe(gw.topic("jobs", job, "state"))
        _, _, retained, _ = fresh.wait_for("retained job state", job_state_pred(gw, job, {"running", "paused"}))
        check(retained, "the job state is retained")
    finally:
        fresh.close()
    contract.validate(gw.topic("jobs", job, "state"), p)
    ans = command(c, gw.topic("jobs", "pause"), {"id": "p", "job": job, "token": TOKENS["operator"]}, reply)
    check(ans["type"] == "result", f"pause: {ans}")
    ans = command(c, gw.topic("jobs", "resume"), {"id": "r", "job": job, "token": TOKENS["viewer"]}, reply)
    check(ans["type"] == "error" and ans["problem"]["status"] == 403, f"viewer resume: {ans}")
    ans = command(c, gw.topic("jobs", "cancel"), {"id": "c", "job": job, "token": TOKENS["operator"]}, reply)
    check(ans["type"] == "result", f"cancel: {ans}")
    c.wait_for("job cancelled", job_state_pred(gw, job, {"cancelled"}))
    # Retained while it is recent; cleared (empty retained message) retain_finished_s (3) later.
    c.wait_for("job state cleared", lambda t, p, r, pr: t == gw.topic("jobs", job, "state") and not p)
    late = Client(broker.port, "late-jobs")
    try:
        late.subscribe(gw.topic("jobs", job, "state"))
        time.sleep(1)
        check(not late.all(lambda t: True), "no retained state left for an old job")
    finally:
        late.close()
    # Dry run: the plan, nothing stored.
    ans = command(c, gw.topic("jobs", "submit"),
                  {"args": {"controller": "sim1", "type": "array", "spec": spec}, "dry_run": True,
                   "token": TOKENS["operator"]}, reply)
    check(ans["type"] == "result" and ans["result"]["dry_run"] is True, f"dry run: {ans}")
    # Leases hold over MQTT as over REST.
    status, text = http_request(gw.port, "POST", "/api/v1/controllers/sim2/lease", {"ttl_s": 60},
                                token=TOKENS["operator"])
    check(status == 201, f"lease: {status} {text}")
    lease = json.loads(text)["lease_id"]
    try:
        ans = command(c, gw.topic("controllers", "sim2", "cmd"),
                      {"operation": "move", "args": {"axes": {"X": 10}}, "token": TOKENS["operator"]}, reply)
        check(ans["type"] == "error" and ans["problem"]["type"].endswith("/leased"), f"leased: {ans}")
        ans = command(c, gw.topic("controllers", "sim2", "cmd"),
                      {"operation": "move", "args": {"axes": {"X": 10}}, "lease": lease, "token": TOKENS["operator"]},
                      reply)
        check(ans["type"] == "result", f"with the lease: {ans}")
        # Jobs: submit and control actions need the lease too.
        body = {"controller": "sim2", "type": "array",
                "spec": {"grid": {"columns": 2, "rows": 1, "column_step_mm": 0.1, "row_step_mm": 0.1},
                         "a1": "current", "advance": "next"}}
        ans = command(c, gw.topic("jobs", "submit"), {"id": "ls1", "args": body, "token": TOKENS["operator"]}, reply)
        check(ans["type"] == "error" and ans["problem"]["type"].endswith("/leased"), f"job without the lease: {ans}")
        ans = command(c, gw.topic("jobs", "submit"),
                      {"id": "ls2", "args": body, "lease": lease, "token": TOKENS["operator"]}, reply)
        check(ans["type"] == "result", f"job with the lease: {ans}")
        leased_job = ans["result"]["id"]
        ans = command(c, gw.topic("jobs", "cancel"), {"id": "lc1", "job": leased_job, "token": TOKENS["operator"]},
                      reply)
        check(ans["type"] == "error" and ans["problem"]["type"].endswith("/leased"), f"cancel without the lease: {ans}")
        ans = command(c, gw.topic("jobs", "cancel"),
                      {"id": "lc2", "job": leased_job, "lease": lease, "token": TOKENS["operator"]}, reply)
        check(ans["type"] == "result" and ans["result"]["state"] == "cancelled", f"cancel with the lease: {ans}")
    finally:
        http_request(gw.port, "DELETE", "/api/v1/controllers/sim2/lease?force=true", token=TOKENS["admin"])


def test_broker_restart(gw, broker, c_factory):
    # While the broker is down, a job changes state; after the restart (no persistence: every retained
    # message is gone) the gateway reconnects, publishes its birth, every controller state and the
    # job's state again, and answers commands (it subscribed again).
    broker.stop()
    status, text = http_request(gw.port, "POST", "/api/v1/jobs",
                                {"controller": "sim2", "type": "array",
                                 "spec": {"grid": {"columns": 2, "rows": 1, "column_step_mm": 0.1, "row_step_mm": 0.1},
                                          "a1": "current", "advance": "next"}}, token=TOKENS["operator"])
    check(status == 201, f"submit while the broker is down: {status} {text}")
    job = json.loads(text)["id"]
    time.sleep(1)
    t0 = time.monotonic()
    broker.start()
    c = c_factory("after-restart")
    try:
        c.subscribe(gw.topic("#"), "clients/restart")
        c.wait_for("birth again", status_is(gw, "online"), timeout=15)
        for cid in ("sim1", "sim2"):
            c.wait_for(f"{cid} state again", lambda t, p, r, pr, cid=cid: t == gw.topic("controllers", cid, "state"),
                       timeout=15)
        c.wait_for("the job's state", job_state_pred(gw, job, {"queued", "running"}), timeout=15)
        elapsed = time.monotonic() - t0
        check(elapsed < 10, f"republished after {elapsed:.1f} s")
        ans = command(c, gw.topic("controllers", "sim1", "cmd"), {"operation": "halt", "token": TOKENS["operator"]},
                      "clients/restart")
        check(ans["type"] == "result", f"a command after the restart: {ans}")
    finally:
        http_request(gw.port, "POST", f"/api/v1/jobs/{job}/cancel", token=TOKENS["operator"])
        c.close()


def test_two_gateways(gw_a, gw_b, broker, contract):
    c = Client(broker.port, "fleet-view")
    try:
        c.subscribe(f"{PREFIX}/+/status", f"{PREFIX}/+/controllers/+/state")
        for gw in (gw_a, gw_b):
            _, p, _, _ = c.wait_for(f"{gw.name} online", status_is(gw, "online"))
            contract.validate(gw.topic("status"), p)
        seen = {(t.split("/")[1], t.split("/")[3]) for t, *_ in c.all(lambda t: t.endswith("/state"))}
        for gw, cids in ((gw_a, ("sim1", "sim2")), (gw_b, ("sim1",))):
            for cid in cids:
                check((gw.name, cid) in seen, f"{gw.name}/{cid} state not seen: {sorted(seen)}")
    finally:
        c.close()


def test_last_will(gw, broker, contract):
    c = Client(broker.port, "will-watcher")
    try:
        c.subscribe(gw.topic("status"))
        c.wait_for("online", status_is(gw, "online"))
        mark = c.mark()
        gw.proc.send_signal(signal.SIGKILL)
        gw.proc.wait(timeout=WAIT)
        _, p, _, _ = c.wait_for("the Last Will", status_is(gw, "offline", "connection lost"), start=mark, timeout=20)
        contract.validate(gw.topic("status"), p)
        check(payload_json(p)["time"] is None, "the will carries no time")
    finally:
        c.close()
    late = Client(broker.port, "will-late")
    try:
        late.subscribe(gw.topic("status"))
        _, p, r, _ = late.wait_for("retained offline", status_is(gw, "offline"))
        check(r, "the will is retained")
    finally:
        late.close()


def test_clean_shutdown(gw, broker, contract):
    c = Client(broker.port, "shutdown-watcher")
    try:
        c.subscribe(gw.topic("status"))
        c.wait_for("online", status_is(gw, "online"))
        mark = c.mark()
        gw.proc.send_signal(signal.SIGTERM)
        code = gw.proc.wait(timeout=WAIT)
        check(code == 0, f"exit code {code}")
        _, p, r, _ = c.wait_for("offline (shutdown)", status_is(gw, "offline", "shutdown"), start=mark, timeout=10)
        contract.validate(gw.topic("status"), p)
        check(payload_json(p)["time"], "a clean shutdown says when")
    finally:
        c.close()


# ---------------------------------------------------------------------------------------------
# A gateway on external simulators (control sockets): encoder reports, TTL events, job state changes
# queued while the broker is away, and no serial byte for a refused command. It has its own broker
# with persistent sessions, so that a watcher that was away while the broker restarted still gets
# every message (non-retained ones included) in order.


def metrics(gw):
    """/api/v1/metrics as {(name, frozenset(labels)): value}."""
    status, text = http_request(gw.port, "GET", "/api/v1/metrics", token=TOKENS["viewer"])
    check(status == 200, f"metrics: {status}")
    out = {}
    for line in text.splitlines():
        if not line or line.startswith("#"):
            continue
        key, value = line.rsplit(" ", 1)
        name, _, labels = key.partition("{")
        pairs = frozenset(tuple(kv.split("=", 1)) for kv in labels.rstrip("}").split(",") if kv)
        out[(name, frozenset((k, v.strip('"')) for k, v in pairs))] = float(value)
    return out


def metric(gw, name, **labels):
    return metrics(gw).get((name, frozenset(labels.items())), 0.0)


def sim_bytes_in(sim):
    """Bytes the simulated controller received on its serial port (complete command lines)."""
    return json.loads(sim.control("state"))["port"]["bytes_in"]


def broker_outage(gw, broker, watcher_name, topics, during):
    """The watcher (a persistent session) leaves, the broker stops, `during()` runs once the gateway
    knows it is disconnected, the broker starts again; returns the watcher, back on its session."""
    w = Client(broker.port, watcher_name, session=True)
    w.subscribe(*topics)
    w.close()
    broker.stop()
    wait_until("the gateway sees the broker gone", lambda: metric(gw, "gw_mqtt_connected") == 0, timeout=20)
    during()
    broker.start()
    return Client(broker.port, watcher_name, session=True)


def reports_of(c, gw, cid, start=0):
    msgs = c.all(lambda t: t == gw.topic("controllers", cid, "reports"), start=start)
    return [payload_json(p) for _, p, _, _ in msgs], msgs


def check_report_batches(batches):
    """Batch structure: frames in hub order with from/to their first and last sequence numbers, and
    every frame in between either in a batch or counted in a "missed" (at the latest in the batch that
    follows the loss). Returns the frames."""
    frames = []
    prev_to = None
    pending = 0  # missed frames announced by empty batches, before the next frame
    for b in batches:
        check(b["type"] == "reports" and isinstance(b["frames"], list), f"batch: {b}")
        if not b["frames"]:
            check(b["from"] is None and b["to"] is None and b["missed"] > 0, f"an empty batch says why: {b}")
            pending += b["missed"]
            continue
        span = b["to"] - b["from"] + 1
        check(len(b["frames"]) <= span <= len(b["frames"]) + b["missed"],
              f"from/to vs frames: {b['from']}..{b['to']} with {len(b['frames'])} frames, missed {b['missed']}")
        if prev_to is not None:
            check(b["to"] - prev_to == len(b["frames"]) + b["missed"] + pending,
                  f"after {prev_to}: {b['from']}..{b['to']}, {len(b['frames'])} frames, missed {b['missed']}"
                  f" (+{pending} announced before)")
        prev_to = b["to"]
        pending = 0
        frames += b["frames"]
    return frames


def test_reports(gw, sims, broker, contract):
    # A burst of TTL pulses on the controller with TTL_REPORT: every frame arrives, batched, in order.
    topic = gw.topic("controllers", "extr", "reports")
    c = Client(broker.port, "reports-watch")
    try:
        c.subscribe(topic)
        status, text = http_request(gw.port, "POST", "/api/v1/controllers/extr/ttl", {"in0_mode": 1},
                                    token=TOKENS["operator"])
        check(status == 200, f"ttl in0_mode 1: {status} {text}")
        frames_before = metric(gw, "gw_controller_report_frames_total", controller="extr")
        n = 40
        check(sims["extr"].control(f"pulse {n} 200") == "ok", "pulse")

        def decoded():
            return int(metric(gw, "gw_controller_report_frames_total", controller="extr") - frames_before)
        # What the gateway decoded (a loaded machine may make the simulator drop a frame itself:
        # TTL_REPORT overrun) must all reach MQTT.
        last = [-1]

        def settled():
            d = decoded()
            done, last[0] = d == last[0] and d > 0, d
            return done
        wait_until("the frames decoded", lambda: time.sleep(0.5) or settled())
        got = decoded()
        check(got >= n - 2, f"the gateway decoded {got} frames of {n} pulses")
        try:
            wait_until(f"{got} report frames over MQTT",
                       lambda: sum(len(b["frames"]) for b in reports_of(c, gw, "extr")[0]) >= got)
        except Failure:
            batches = reports_of(c, gw, "extr")[0]
            raise Failure(f"{sum(len(b['frames']) for b in batches)} frames in {len(batches)} batches "
                          f"(missed {sum(b['missed'] for b in batches)}); the gateway decoded {got}")
        time.sleep(0.5)  # nothing more may come
        batches, msgs = reports_of(c, gw, "extr")
        for t, p, r, _ in msgs:
            check(not r, "reports are not retained")
            contract.validate(t, p)
        check(all(b["controller"] == "extr" and b["missed"] == 0 for b in batches), f"no loss: {batches}")
        frames = check_report_batches(batches)
        check(len(frames) == got, f"{len(frames)} frames over MQTT, {got} decoded")
        seqs = [f["controller_seq"] for f in frames]
        check(seqs == list(range(seqs[0], seqs[0] + got)), f"the controller's frames, in order: {seqs}")
        check(all(f["id"] == "extr" and [a["axis"] for a in f["axes"]] == ["X", "Y", "Z"] and
                  all(isinstance(a["counts"], int) for a in f["axes"]) for f in frames), f"frame: {frames[0]}")
        print(f"    {got} frames ({n} pulses) in {len(batches)} batches "
              f"(largest {max(len(b['frames']) for b in batches)})")
    finally:
        c.close()


def test_recording(gw, sims, broker, contract):
    # A position recording's live topic: its rows, every one, in order, and its end.
    c = Client(broker.port, "recording-watch")
    try:
        c.subscribe(gw.topic("recordings", "#"))
        status, text = http_request(gw.port, "POST", "/api/v1/controllers/extr/recordings", {"name": "mqtt"},
                                    token=TOKENS["operator"])
        check(status == 201, f"start: {status} {text}")
        rid = json.loads(text)["id"]
        topic = gw.topic("recordings", rid)
        n = 30
        check(sims["extr"].control(f"pulse {n} 100") == "ok", "pulse")
        wait_until(f"{n} frames stored", lambda: json.loads(http_request(
            gw.port, "GET", f"/api/v1/recordings/{rid}", token=TOKENS["viewer"])[1])["frames"] >= n)
        status, text = http_request(gw.port, "POST", f"/api/v1/recordings/{rid}/stop", token=TOKENS["operator"])
        check(status == 200, f"stop: {status} {text}")
        stored = json.loads(text)["frames"]

        def ended():
            events = [json.loads(p) for _, p, _, _ in c.all(lambda t: t == topic)]
            return events if events and events[-1]["data"]["state"] != "recording" else None
        events = wait_until("the recording's end over MQTT", ended)
        for t, p, r, _ in c.all(lambda t: t == topic):
            check(not r, "recording events are not retained")
            contract.validate(t, p)
        rows = [row for e in events for row in e["data"]["rows"]]
        check([row["index"] for row in rows] == list(range(stored)), f"every row in order: {len(rows)} of {stored}")
        check(events[-1]["data"]["state"] == "stopped", f"the end: {events[-1]['data']['state']}")
    finally:
        c.close()


def test_report_gap(gw, sims, broker, contract):
    # Frames that arrive while the broker is down cannot be published: the first batch after the
    # reconnect says how many ("missed"), /metrics counts them, and the sequence numbers agree.
    topic = gw.topic("controllers", "extr", "reports")
    pre = Client(broker.port, "gap-pre")
    pre.subscribe(topic)
    check(sims["extr"].control("pulse 3 100") == "ok", "pulse")
    pre.wait_for("frames before the outage",
                 lambda t, p, r, pr: sum(len(b["frames"]) for b in reports_of(pre, gw, "extr")[0]) >= 3)
    last_to = reports_of(pre, gw, "extr")[0][-1]["to"]
    pre.close()
    dropped_before = metric(gw, "gw_mqtt_dropped_total", kind="reports")
    n = 15

    lost = {}

    def pulses():
        before = metric(gw, "gw_controller_report_frames_total", controller="extr")
        check(sims["extr"].control(f"pulse {n} 100") == "ok", "pulse")
        last = [-1]

        def settled():  # every frame the simulator sent is decoded (one may be lost to an overrun)
            d = int(metric(gw, "gw_controller_report_frames_total", controller="extr") - before)
            done, last[0] = d == last[0] and d >= n - 2, d
            return done
        wait_until("the frames decoded while the broker is down", lambda: time.sleep(0.5) or settled())
        lost["n"] = last[0]
    c = broker_outage(gw, broker, "gap-watch", [topic], pulses)
    n = lost["n"]
    try:
        c.wait_for("the missed-frames batch", lambda t, p, r, pr: t == topic and payload_json(p)["missed"] > 0)
        check(sims["extr"].control("pulse 4 100") == "ok", "pulse")
        wait_until("frames after the outage", lambda: sum(len(b["frames"]) for b in reports_of(c, gw, "extr")[0]) >= 4)
        time.sleep(0.5)
        batches, msgs = reports_of(c, gw, "extr")
        for t, p, _, _ in msgs:
            contract.validate(t, p)
        check(sum(b["missed"] for b in batches) == n, f"missed {[b['missed'] for b in batches]}, expected {n}")
        check(batches[0]["frames"] == [] and batches[0]["missed"] == n, f"announced at once: {batches[0]}")
        frames = check_report_batches(batches)
        check(len(frames) == 4, f"{len(frames)} frames after the outage")
        check(batches[1]["from"] == last_to + n + 1, f"hub sequence after the gap: {batches[1]['from']}, "
              f"expected {last_to} + {n} + 1")
        check(metric(gw, "gw_mqtt_dropped_total", kind="reports") - dropped_before == n,
              "gw_mqtt_dropped_total{kind=reports} counts them")
    finally:
        c.close()


def test_ttl_events(gw, sims, broker, contract):
    # TTL IN0 mode 5: an edge starts serial position reports ("T: ..." lines), the next edge stops them.
    topic = gw.topic("controllers", "extt", "ttl")
    c = Client(broker.port, "ttl-watch")
    try:
        c.subscribe(topic)
        status, text = http_request(gw.port, "POST", "/api/v1/controllers/extt/ttl", {"in0_mode": 5},
                                    token=TOKENS["operator"])
        check(status == 200, f"ttl in0_mode 5: {status} {text}")
        check(sims["extt"].control("pulse") == "ok", "pulse: reports on")
        wait_until("TTL events", lambda: len(c.all(lambda t: t == topic)) >= 4)
        check(sims["extt"].control("pulse") == "ok", "pulse: reports off")
        time.sleep(1)  # the last ones in flight
        n = len(c.all(lambda t: t == topic))
        time.sleep(1)
        msgs = c.all(lambda t: t == topic)
        check(len(msgs) == n, f"TTL events go on after the second edge: {n} -> {len(msgs)}")
        events = []
        for t, p, r, _ in msgs:
            check(not r, "TTL events are not retained")
            contract.validate(t, p)
            events.append(payload_json(p))
        check(all(e["type"] == "event" and e["topic"] == "controllers/extt/ttl" for e in events), f"{events[0]}")
        seqs = [e["seq"] for e in events]
        check(seqs == list(range(seqs[0], seqs[0] + len(seqs))), f"every TTL event, in order: {seqs}")
        data = [e["data"] for e in events]
        # "T: <ms> <x> <y>": the position report carries X and Y.
        check(all(d["id"] == "extt" and [a["axis"] for a in d["axes"]] == ["X", "Y"] for d in data), f"{data[0]}")
        ms = [d["controller_ms"] for d in data]
        check(ms == sorted(ms) and ms[-1] > ms[0], f"the controller's time stamps advance: {ms}")
    finally:
        c.close()


def test_no_serial_byte(gw, sims, broker, contract):
    # extt is not polled (poll_ms 0): only commands reach its serial port. A valid command moves its
    # byte counter; a batch of refused ones (malformed, unauthorized, invalid) must not.
    reply = "clients/ext/bad"
    cmd = gw.topic("controllers", "extt", "cmd")
    c = Client(broker.port, "serial-watch")
    try:
        c.subscribe(reply)
        before = sim_bytes_in(sims["extt"])
        ans = command(c, cmd, {"operation": "halt", "token": TOKENS["operator"]}, reply)
        check(ans["type"] == "result", f"halt: {ans}")
        wait_until("the valid command on the serial port", lambda: sim_bytes_in(sims["extt"]) > before)
        time.sleep(0.3)
        before = sim_bytes_in(sims["extt"])
        user_before = metric(gw, "gw_controller_commands_total", controller="extt", origin="user")
        move = {"axes": {"X": 100}}
        # From unknown senders: not answered at all.
        for body in (b"not json", b"", b"\xff\xfe\x00", b"[]", b"null", b'{"operation": "move"', b"{" * 5000,
                     {"operation": "move", "args": move},  # no token
                     {"operation": "move", "args": move, "token": "wrong-token-0000000"}):
            # The barrier is refused too (a viewer may not move): nothing reaches the serial port.
            unanswered(c, cmd, body, reply, barrier={"operation": "move", "args": move, "token": TOKENS["viewer"]})
        bad = [
            {"operation": "move", "args": move, "token": TOKENS["viewer"]},
            {"operation": "command", "args": {"command": "M X=100"}, "token": TOKENS["operator"]},
            {"operation": "move", "args": {"axes": {"Q": 1}}, "token": TOKENS["admin"]},
            {"operation": "move", "args": {"axes": {"X": "far"}}, "token": TOKENS["admin"]},
            {"operation": "move", "args": {"axes": {"X": 1e300}}, "token": TOKENS["admin"]},
            {"operation": "move", "args": move, "token": TOKENS["admin"], "extra": 1},
            {"operation": "speed", "args": {"axes": {"X": -5}}, "token": TOKENS["admin"]},
            {"operation": "ttl", "args": {"in0_mode": "x"}, "token": TOKENS["admin"]},
            {"operation": "command", "args": {"command": "M X=1\rM Y=2"}, "token": TOKENS["admin"]},
            {"operation": "fly", "token": TOKENS["admin"]},
            {"operation": 7, "token": TOKENS["admin"]},
            {"operation": "halt", "token": TOKENS["admin"], "controller": "sim1"},
            {"operation": "halt", "token": TOKENS["admin"], "reply_to": "asi/x/status"},
        ]
        for body in bad:
            ans = command(c, cmd, body, reply)
            check(ans["type"] == "error", f"{body!r:.80}: {ans}")
            contract.validate(reply, json.dumps(ans))
        # A retained command and one without any way to answer: refused (or ignored), never run.
        c.c.publish(cmd, signed_command(cmd, {"operation": "move", "args": move}, "admin"), qos=1,
                    retain=True).wait_for_publish(WAIT)
        c.c.publish(cmd, b"", qos=1, retain=True).wait_for_publish(WAIT)
        c.c.publish(cmd, json.dumps({"operation": "move", "args": move}), qos=1).wait_for_publish(WAIT)
        time.sleep(1)
        check(sim_bytes_in(sims["extt"]) == before, f"serial bytes: {before} -> {sim_bytes_in(sims['extt'])}")
        check(metric(gw, "gw_controller_commands_total", controller="extt", origin="user") == user_before,
              "no user command reached the controller")
        check(gw.proc.poll() is None, "the gateway is still running")
    finally:
        c.close()


def test_job_queue(gw, sims, broker, contract):
    # While the broker is down a job runs through all its states; the bridge keeps the newest
    # queue_limit (4) changes, drops the oldest (counted), and publishes the kept ones in order on the
    # reconnect, then the job's current state again.
    limit = gw.config["mqtt"]["jobs"]["queue_limit"]
    topics = [gw.topic("jobs", "+", "state")]
    dropped_before = metric(gw, "gw_mqtt_dropped_total", kind="jobs")
    job = {}

    def run_job():
        status, text = http_request(gw.port, "POST", "/api/v1/jobs",
                                    {"controller": "extr", "type": "array",
                                     "spec": {"grid": {"columns": 3, "rows": 1, "column_step_mm": 0.05,
                                                       "row_step_mm": 0.05}, "a1": "current", "advance": "timer",
                                              "dwell_ms": 50}},
                                    token=TOKENS["operator"])
        check(status == 201, f"submit: {status} {text}")
        job["id"] = json.loads(text)["id"]
        def done():
            j = json.loads(http_request(gw.port, "GET", f"/api/v1/jobs/{job['id']}", token=TOKENS["viewer"])[1])
            check(j["state"] in ("queued", "running", "succeeded"), f"job: {j}")
            return j["state"] == "succeeded"
        wait_until("the job done", done)
        time.sleep(0.3)
        check(metric(gw, "gw_mqtt_job_queue") == limit, f"the queue holds {limit}")
    c = broker_outage(gw, broker, "jobs-watch", topics, run_job)
    try:
        topic = gw.topic("jobs", job["id"], "state")
        c.wait_for("the republished job", lambda t, p, r, pr: t == topic and len(c.all(lambda x: x == topic)) > limit)
        time.sleep(0.5)
        msgs = c.all(lambda t: t == topic)
        for t, p, _, _ in msgs:
            contract.validate(t, p)
        states = [payload_json(p) for _, p, _, _ in msgs]
        seqs = [s["seq"] for s in states]
        last = seqs[limit - 1]
        check(seqs[:limit] == list(range(last - limit + 1, last + 1)), f"the newest {limit}, in order: {seqs}")
        check(states[limit - 1]["job"]["state"] == "succeeded", f"the last queued: {states[limit - 1]['job']['state']}")
        check(seqs[limit:] == [last] * (len(seqs) - limit), f"then the current state again: {seqs}")
        dropped = metric(gw, "gw_mqtt_dropped_total", kind="jobs") - dropped_before
        check(dropped == last - limit, f"dropped {dropped}, expected {last} changes - {limit} kept")
        check(metric(gw, "gw_mqtt_job_queue") == 0, "the queue is empty again")
        with open(gw.log_path) as f:
            check("job state queue full" in f.read(), "the overflow is logged")
    finally:
        c.close()


def start_ext_gateway(fx, binary, sim_bin):
    broker = Broker(fx, "ext-broker", persistent=True)
    broker.start()
    sims = {"extr": fx.start_sim(sim_bin, "extr", "full", report=True),
            "extt": fx.start_sim(sim_bin, "extt", "plain")}
    gw = Gateway(fx, binary, "gw-ext", [f"mqtt://127.0.0.1:{broker.port}"], sims=0,
                 mqtt_extra={"jobs": {"retain_finished_s": 600, "queue_limit": 4}})
    gw.config["controllers"] = [
        {"id": "extr", "port": sims["extr"].link, "report_port": sims["extr"].report_link, "baud": 115200},
        {"id": "extt", "port": sims["extt"].link, "baud": 115200, "poll_ms": 0}]
    gw.start()
    return gw, broker, sims


def make_pki(tmp):
    """A test CA, a server certificate for localhost/127.0.0.1 and a client certificate (openssl)."""
    d = os.path.join(tmp, "pki")
    os.makedirs(d)

    def run(*args):
        subprocess.run(["openssl", *args], cwd=d, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    run("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", "ca.key", "-out", "ca.pem", "-days", "2",
        "-subj", "/CN=asi-gateway test CA")
    with open(os.path.join(d, "san.ext"), "w") as f:
        f.write("subjectAltName=DNS:localhost,IP:127.0.0.1\n")
    for name, cn in (("server", "localhost"), ("client", "gateway-client")):
        run("req", "-newkey", "rsa:2048", "-nodes", "-keyout", f"{name}.key", "-out", f"{name}.csr",
            "-subj", f"/CN={cn}")
        run("x509", "-req", "-in", f"{name}.csr", "-CA", "ca.pem", "-CAkey", "ca.key", "-CAcreateserial",
            "-out", f"{name}.pem", "-days", "2", *(["-extfile", "san.ext"] if name == "server" else []))
    # Another CA, which the broker's certificate does not come from.
    run("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", "other.key", "-out", "other.pem", "-days", "2",
        "-subj", "/CN=some other CA")
    p = lambda n: os.path.join(d, n)  # noqa: E731
    return {"ca": p("ca.pem"), "server_cert": p("server.pem"), "server_key": p("server.key"),
            "client_cert": p("client.pem"), "client_key": p("client.key"), "other_ca": p("other.pem")}


def test_tls(fx, binary, contract):
    pki = make_pki(fx.tmp)
    broker = Broker(fx, "tls-broker", tls={"ca": pki["ca"], "cert": pki["server_cert"], "key": pki["server_key"]})
    broker.start()
    # Over TLS a bearer token in the payload may be allowed (accept_bearer_tokens).
    gw = Gateway(fx, binary, "gw-tls", [f"mqtts://localhost:{broker.tls_port}"], sims=1,
                 mqtt_extra={"tls": {"ca_file": pki["ca"], "cert_file": pki["client_cert"],
                                     "key_file": pki["client_key"], "verify": True},
                             "commands": {"enabled": True, "accept_bearer_tokens": True}})
    bad = Gateway(fx, binary, "gw-badca", [f"mqtts://localhost:{broker.tls_port}"], sims=1,
                  mqtt_extra={"tls": {"ca_file": pki["other_ca"], "cert_file": pki["client_cert"],
                                      "key_file": pki["client_key"], "verify": True}})
    # Watched over TLS as well, with the client certificate the broker requires.
    c = Client(broker.port, "tls-watch", tls={"ca": pki["ca"], "cert": pki["client_cert"], "key": pki["client_key"]},
               port=broker.tls_port)
    try:
        c.subscribe(f"{PREFIX}/+/status")
        gw.start()
        bad.start()
        _, p, _, _ = c.wait_for("birth over TLS", status_is(gw, "online"))
        contract.validate(gw.topic("status"), p)
        reply = "clients/tls/replies"
        c.subscribe(reply)
        ans = command(c, gw.topic("controllers", "sim1", "cmd"), {"operation": "halt", "token": TOKENS["operator"]},
                      reply, sign=False)
        check(ans["type"] == "result", f"a bearer token over TLS with accept_bearer_tokens: {ans}")
        time.sleep(2)
        check(not c.all(lambda t: t == bad.topic("status")),
              "a gateway that does not trust the broker's CA must not connect")
        for g in (gw, bad):
            g.proc.send_signal(signal.SIGTERM)
            g.proc.wait(timeout=WAIT)
    finally:
        c.close()


README_ACL = """
# each gateway writes its own tree and answers, reads its own command topics and its birth (read
# back after each connect)
user gw-lab3
topic write asi/lab3/#
topic read asi/lab3/status
topic read asi/lab3/controllers/+/cmd
topic read asi/lab3/jobs/+
topic read asi/lab3/gcode/+
topic write clients/#
# dashboards read everything and command nothing
user dashboard
topic read asi/#
# the scheduler reads everything, commands every gateway, reads its own answers
user scheduler
topic read asi/#
topic write asi/+/controllers/+/cmd
topic write asi/+/jobs/+
topic write asi/+/gcode/+
topic read clients/scheduler/#
"""


def test_acl(fx, binary, readme_path):
    # The README's ACL, taken from README.md itself, with users and passwords: only the scheduler
    # may command; the dashboard's commands never reach the gateway.
    with open(readme_path) as f:
        check(README_ACL.strip() in f.read(), "README.md shows this ACL")
    acl = os.path.join(fx.tmp, "acl")
    with open(acl, "w") as f:
        f.write(README_ACL)
    pw = os.path.join(fx.tmp, "passwd")
    for i, user in enumerate(("gw-lab3", "dashboard", "scheduler")):
        subprocess.run(["mosquitto_passwd", "-b", *(["-c"] if i == 0 else []), pw, user, user + "-password"],
                       check=True)
    broker = Broker(fx, "acl-broker", extra=["allow_anonymous false", f"password_file {pw}", f"acl_file {acl}"])
    broker.start()
    gw = Gateway(fx, binary, "lab3", [f"mqtt://127.0.0.1:{broker.port}"], sims=1,
                 mqtt_extra={"username": "gw-lab3", "password": "gw-lab3-password"})
    dash = Client(broker.port, "dash", user="dashboard")
    sched = Client(broker.port, "sched", user="scheduler")
    try:
        dash.subscribe(f"{PREFIX}/+/status")
        sched.subscribe("clients/scheduler/#")
        gw.start()
        dash.wait_for("the gateway's birth, read by the dashboard", status_is(gw, "online"))
        ans = command(sched, gw.topic("controllers", "sim1", "cmd"), {"operation": "halt", "token": TOKENS["operator"]},
                      "clients/scheduler/replies")
        check(ans["type"] == "result", f"the scheduler commands: {ans}")
        # The gateway reads its G-code check topic through the ACL too (an unknown file: 404 answered).
        ans = command(sched, gw.topic("gcode", "check"),
                      {"file": "g-00000000000000000000000000", "token": TOKENS["viewer"]}, "clients/scheduler/replies")
        check(ans["type"] == "error" and ans["problem"]["status"] == 404, f"the scheduler checks G-code: {ans}")
        # The answer would go where the scheduler listens: had the broker let the command through,
        # the scheduler would see it.
        mark = sched.mark()
        dash.publish(gw.topic("controllers", "sim1", "cmd"), {"operation": "halt", "token": TOKENS["admin"]},
                     response_topic="clients/scheduler/from-dashboard", correlation=b"d1")
        sched.publish(gw.topic("controllers", "sim1", "cmd"), {"operation": "halt", "token": TOKENS["admin"]},
                      response_topic="clients/scheduler/from-scheduler", correlation=b"s1")
        sched.wait_for("the scheduler's own answer", lambda t, *_: t == "clients/scheduler/from-scheduler",
                       start=mark)
        time.sleep(1)
        check(not sched.all(lambda t: t == "clients/scheduler/from-dashboard", start=mark),
              "a dashboard command must not reach the gateway")
        # Through the ACL the gateway reads its retained birth back (2 s after the connect; an ACL
        # that hid it would make it publish the birth again after 3 s more, and say so).
        time.sleep(6)
        check("the broker serves" not in open(gw.log_path).read(), f"the birth read back: {gw.tail(5)}")
        gw.proc.send_signal(signal.SIGTERM)
        gw.proc.wait(timeout=WAIT)
    finally:
        dash.close()
        sched.close()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    ap.add_argument("--asyncapi", default="")
    ap.add_argument("--sim", required=True, help="the ms2000-sim executable (external simulators)")
    ap.add_argument("--readme", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "../../../README.md"))
    ap.add_argument("--only", default="", help="test names separated by ; (default: all)")
    args = ap.parse_args()
    only = set(filter(None, args.only.split(";")))
    fx = Fixture("asi-mqtt-test-")
    contract = Contract(args.asyncapi)

    def run(name, fn, *a):
        if not only or name in only:
            fx.run(name, fn, *a)

    gateways = []
    try:
        if args.asyncapi:
            run("asyncapi document is valid", contract.check_structure)
        broker = Broker(fx, "broker")
        broker.start()
        gw = Gateway(fx, args.gateway, "gw-a", [f"mqtt://127.0.0.1:{broker.port}"])
        gateways.append(gw)
        c = Client(broker.port, "watcher")
        gw.start()
        run("birth", test_birth, gw, c, contract)
        run("retained controller state", test_retained_state, gw, broker, contract)
        run("commands over MQTT 5 (response topic, correlation data)", test_commands_v5, gw, c, contract)
        run("position rate limit", test_position_rate, gw, c)
        run("G-code check", test_gcode_check, gw, c, contract)
        run("the controller's error log", test_error_log, gw, c, contract)
        run("commands over MQTT 3.1.1 (reply_to)", test_commands_v311, gw, broker, contract)
        run("bad payloads", test_bad_payloads, gw, c, contract)
        run("signed commands: no token on the topic, no replays", test_signed_commands, gw, c)
        run("jobs", test_jobs, gw, c, broker, contract)
        c.close()
        run("broker restart", test_broker_restart, gw, broker,
            lambda name: Client(broker.port, name))
        gw_b = Gateway(fx, args.gateway, "gw-b", [f"mqtt://127.0.0.1:{broker.port}"], sims=1,
                       mqtt_extra={"protocol": "3.1.1"})
        gateways.append(gw_b)
        gw_b.start()
        run("two gateways on one broker", test_two_gateways, gw, gw_b, broker, contract)
        run("Last Will on kill -9", test_last_will, gw, broker, contract)
        run("offline on a clean shutdown", test_clean_shutdown, gw_b, broker, contract)
        gw_x, broker_x, sims = start_ext_gateway(fx, args.gateway, args.sim)
        gateways.append(gw_x)
        run("encoder reports: batched, every frame, in order", test_reports, gw_x, sims, broker_x, contract)
        run("encoder reports: frames missed while the broker is down are counted", test_report_gap, gw_x, sims,
            broker_x, contract)
        run("TTL events", test_ttl_events, gw_x, sims, broker_x, contract)
        run("a position recording's rows and end on its topic", test_recording, gw_x, sims, broker_x, contract)
        run("refused commands send no serial byte", test_no_serial_byte, gw_x, sims, broker_x, contract)
        run("job state changes queued while the broker is down (bounded, in order)", test_job_queue, gw_x, sims,
            broker_x, contract)
        run("TLS with a test CA", test_tls, fx, args.gateway, contract)
        run("the README's ACL: only the scheduler commands", test_acl, fx, args.gateway, args.readme)
        run("CRISP and autofocus commands, CRISP in the state", test_focus, fx, args.gateway, contract)
        if contract.doc:
            print(f"{contract.checked} payloads validated against asyncapi.yaml")
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
    sys.exit(main())
