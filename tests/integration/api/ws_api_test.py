#!/usr/bin/python3
"""End-to-end test of the WebSocket API (/api/v1/ws): starts the real asi-gateway (three simulated
controllers in-process, plus two external ms2000-sims with control sockets: ext1 to unplug, ext2
with a report port whose TTL pulses make report events) on a free loopback port and talks to it
with real WebSocket clients over loopback.

Covers: protocol errors answered without closing; subscribe with wildcards and events while a move
runs; every report frame in order; resume from a sequence number (replay) and an explicit gap when
too old; commands over the WebSocket answered with the same id (errors as problems, roles
included); a stalled client (raw TCP: upgrades, stuffs its pipe, never reads) that neither slows a
healthy client nor stays connected; a controller unplugged while clients watch; "going away" on
SIGTERM.

The client is a small RFC 6455 implementation on the standard library (no python3-websockets
needed), so the stalled client can misbehave at the socket level. Run by ctest with Debian's
/usr/bin/python3. Exit code 0 when every check passed; the failures are listed otherwise.
The gateway, sims, config and run/report harness come from gateway_fixture.py (shared).
Timeouts are generous (a loaded 2-core machine); nothing asserts wall-clock speed.
"""

import argparse
import base64
import hashlib
import json
import os
import socket
import struct
import sys
import threading
import time

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gateway_fixture import TOKENS, WAIT, Failure, Fixture, auth_tokens, check, free_port, http_request, wait_until  # noqa: E402,E501

WS_GUID = b"258EAFA5-E914-47DA-95CA-C5AB0DC85B11"


# --------------------------------------------------------------------------------------------
# A minimal WebSocket client (RFC 6455): text frames, masking, fragmentation, ping/pong, close.


class Closed(Exception):
    def __init__(self, code, reason):
        super().__init__(f"closed {code} {reason!r}")
        self.code = code
        self.reason = reason


def upgrade(port, token=None, rcvbuf=None, query="", extra_headers=()):
    """A connected socket after a successful upgrade to /api/v1/ws, plus any bytes read past it.
    `query` ("?access_token=...") is appended to the target; `extra_headers` ("Origin: ...") replace
    the default of the same name."""
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    if rcvbuf:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)
    s.settimeout(WAIT)
    s.connect(("127.0.0.1", port))
    key = base64.b64encode(os.urandom(16)).decode()
    headers = [
        f"GET /api/v1/ws{query} HTTP/1.1",
        f"Host: 127.0.0.1:{port}",
        "Upgrade: websocket",
        "Connection: Upgrade",
        f"Sec-WebSocket-Key: {key}",
        "Sec-WebSocket-Version: 13",
    ]
    if token:
        headers.append(f"Authorization: Bearer {token}")
    names = {h.split(":", 1)[0].lower() for h in extra_headers}
    headers = [h for h in headers if h.split(":", 1)[0].lower() not in names] + list(extra_headers)
    s.sendall(("\r\n".join(headers) + "\r\n\r\n").encode())
    data = b""
    while b"\r\n\r\n" not in data:
        chunk = s.recv(4096)
        if not chunk:
            raise Failure(f"connection closed during the upgrade: {data!r}")
        data += chunk
    head, rest = data.split(b"\r\n\r\n", 1)
    lines = head.decode("latin-1").split("\r\n")
    status = int(lines[0].split()[1])
    fields = {l.split(":", 1)[0].strip().lower(): l.split(":", 1)[1].strip() for l in lines[1:] if ":" in l}
    if status != 101:
        # The rest is the problem body (Content-Length).
        body = rest
        length = int(fields.get("content-length", "0"))
        while len(body) < length:
            chunk = s.recv(4096)
            if not chunk:
                break
            body += chunk
        s.close()
        return status, body
    accept = base64.b64encode(hashlib.sha1(key.encode() + WS_GUID).digest()).decode()
    check(fields.get("sec-websocket-accept") == accept, f"bad Sec-WebSocket-Accept: {fields}")
    return s, rest


def frame(opcode, payload, fin=True):
    header = bytes([(0x80 if fin else 0) | opcode])
    n = len(payload)
    if n < 126:
        header += bytes([0x80 | n])
    elif n < 65536:
        header += bytes([0x80 | 126]) + struct.pack("!H", n)
    else:
        header += bytes([0x80 | 127]) + struct.pack("!Q", n)
    mask = os.urandom(4)
    masked = bytes(b ^ mask[i % 4] for i, b in enumerate(payload))
    return header + mask + masked


class WsClient:
    def __init__(self, port, token=None, name="client", query="", extra_headers=()):
        r = upgrade(port, token, query=query, extra_headers=extra_headers)
        if isinstance(r[0], int):
            raise Failure(f"{name}: upgrade refused with {r[0]}: {r[1]!r}")
        self.sock, self.buf = r
        self.name = name
        self.closed = None
        self.closing = False
        self.hello = self.recv_json()
        check(self.hello.get("type") == "hello", f"{name}: first message {self.hello}")

    def send_text(self, text):
        self.sock.sendall(frame(0x1, text.encode()))

    def send(self, obj):
        self.send_text(json.dumps(obj))

    def _read_exact(self, n, deadline):
        while len(self.buf) < n:
            left = deadline - time.monotonic()
            if left <= 0:
                raise socket.timeout(f"{self.name}: no data in time")
            self.sock.settimeout(left)
            chunk = self.sock.recv(65536)
            if not chunk:
                raise Closed(None, "EOF without a close frame")
            self.buf += chunk
        out, self.buf = self.buf[:n], self.buf[n:]
        return out

    def recv_message(self, timeout=WAIT):
        """(opcode, payload) of the next data message; answers pings; raises Closed on close."""
        deadline = time.monotonic() + timeout
        parts = []
        opcode = None
        while True:
            b0, b1 = self._read_exact(2, deadline)
            fin, op = b0 & 0x80, b0 & 0x0F
            n = b1 & 0x7F
            if n == 126:
                n = struct.unpack("!H", self._read_exact(2, deadline))[0]
            elif n == 127:
                n = struct.unpack("!Q", self._read_exact(8, deadline))[0]
            check(not (b1 & 0x80), "server frames must not be masked")
            payload = self._read_exact(n, deadline)
            if op == 0x9:  # ping
                self.sock.sendall(frame(0xA, payload))
                continue
            if op == 0xA:
                continue
            if op == 0x8:
                code = struct.unpack("!H", payload[:2])[0] if len(payload) >= 2 else None
                reason = payload[2:].decode(errors="replace")
                if not self.closing:
                    try:
                        self.sock.sendall(frame(0x8, payload[:2]))
                    except OSError:
                        pass
                self.closed = (code, reason)
                raise Closed(code, reason)
            if op != 0x0:
                opcode = op
            parts.append(payload)
            if fin:
                return opcode, b"".join(parts)

    def recv_json(self, timeout=WAIT):
        op, payload = self.recv_message(timeout)
        check(op == 0x1, f"{self.name}: expected a text frame, got opcode {op}")
        return json.loads(payload)

    def wait_for(self, pred, what, timeout=WAIT, seen=None):
        """The first message for which pred(msg) holds; others go to `seen` (if given)."""
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise Failure(f"{self.name}: timed out waiting for {what}")
            try:
                msg = self.recv_json(left)
            except socket.timeout:
                raise Failure(f"{self.name}: timed out waiting for {what}")
            if pred(msg):
                return msg
            if seen is not None:
                seen.append(msg)

    def request(self, obj, timeout=WAIT):
        """Sends a message with an id and returns the answer with that id (events are skipped)."""
        self.send(obj)
        return self.wait_for(lambda m: m.get("type") in ("result", "error", "subscribed", "unsubscribed", "pong")
                             and m.get("id") == obj.get("id"), f"the answer to {obj}", timeout)

    def close(self):
        """The closing handshake: our close frame, then the server's (events before it are dropped)."""
        self.closing = True
        try:
            self.sock.sendall(frame(0x8, struct.pack("!H", 1000)))
            deadline = time.monotonic() + 10
            while self.closed is None and time.monotonic() < deadline:
                self.recv_message(deadline - time.monotonic())
        except (Closed, OSError, Failure):
            pass
        self.sock.close()


# --------------------------------------------------------------------------------------------
# HTTP helpers


def metric(port, name, labels=""):
    status, text = http_request(port, "GET", "/api/v1/metrics")
    check(status == 200, f"/metrics answered {status}")
    total = 0.0
    for line in text.splitlines():
        if line.startswith(name + labels + " ") or (not labels and line.startswith(name + "{")):
            total += float(line.rsplit(" ", 1)[1])
    return total


def is_event(topic=None):
    return lambda m: m.get("type") == "event" and (topic is None or m.get("topic") == topic)


# --------------------------------------------------------------------------------------------
# The tests


def test_access_token_query(port, log_path):
    # Browsers cannot set Authorization on a WebSocket: the token may come as ?access_token=.
    c = WsClient(port, None, "query-token", query="?access_token=" + TOKENS["viewer"])
    check(c.hello.get("role") == "viewer", f"role from ?access_token= {c.hello}")
    c.close()
    status, body = upgrade(port, query="?access_token=" + TOKENS["viewer"] + "x")
    check(status == 401, f"wrong ?access_token= answered {status} {body!r}")
    problem = json.loads(body)
    check("access_token" not in problem.get("instance", ""), f"problem instance leaks the query: {problem}")
    status, _ = upgrade(port, query="?access_token=")
    check(status == 401, f"empty ?access_token= answered {status}")
    # Only the upgrade takes a query token: REST still wants the header.
    status, _ = http_request(port, "GET", "/api/v1/controllers?access_token=" + TOKENS["viewer"], token=None)
    check(status == 401, f"REST with ?access_token= answered {status}")
    with open(log_path) as f:
        check(TOKENS["viewer"] not in f.read(), "the token appears in the gateway log")


def test_protocol_errors(port):
    c = WsClient(port, TOKENS["viewer"], "errors")
    hello = c.hello
    check(hello["role"] == "viewer" and hello["user"] == "viewer1", f"hello {hello}")
    check(hello["client"] == "viewer1" and hello["auth"] == "token", f"hello as GET /api/v1/whoami: {hello}")
    check(hello["connection"].startswith("ws-") and hello["max_message_bytes"] > 0, f"hello {hello}")
    cases = [
        ("{not json", None, 400, "malformed-json", None),
        ('[1,2,3]', None, 400, "malformed-json", None),
        ('{"op":"publish","id":1}', 1, 422, "invalid-value", "op"),
        ('{"op":"subscribe","id":2,"topics":["controllers/+/position"],"qos":1}', 2, 422, "invalid-value", "qos"),
        ('{"op":"subscribe","id":3,"topics":["controllers/#/state"]}', 3, 422, "invalid-value", "topics[0]"),
        ('{"op":"subscribe","id":4,"topics":["a+"]}', 4, 422, "invalid-value", "topics[0]"),
        ('{"op":"ping","id":true}', None, 422, "invalid-value", "id"),
        ('{"op":"command","controller":"sim1","operation":"halt"}', None, 422, "invalid-value", "id"),
    ]
    for text, id_, status, kind, field in cases:
        c.send_text(text)
        m = c.wait_for(lambda m: m.get("type") == "error", f"an error for {text}")
        check(m["id"] == id_, f"{text}: id {m['id']} != {id_}")
        p = m["problem"]
        check(p["status"] == status and p["type"].endswith("/" + kind), f"{text}: problem {p}")
        check(field is None or p.get("field") == field, f"{text}: field {p.get('field')} != {field}")
        check(p.get("instance") == "/api/v1/ws", f"{text}: instance {p.get('instance')}")
    # A binary frame is refused, the connection stays.
    c.sock.sendall(frame(0x2, b"\x00\x01"))
    m = c.wait_for(lambda m: m.get("type") == "error", "an error for a binary frame")
    check(m["problem"]["status"] == 400, f"binary frame: {m}")
    # Still open after all that.
    pong = c.request({"op": "ping", "id": "still-there"})
    check(pong == {"type": "pong", "id": "still-there"}, f"pong {pong}")
    c.close()


def test_oversized_message_closes_with_1009(port):
    c = WsClient(port, TOKENS["viewer"], "oversized")
    limit = c.hello["max_message_bytes"]
    c.send_text('{"op":"ping","id":"' + "x" * (limit + 10) + '"}')
    try:
        c.wait_for(lambda m: False, "the close frame", timeout=WAIT)
    except Closed as e:
        check(e.code == 1009, f"close code {e.code} (expected 1009 message too big)")
        return
    raise Failure("no close after an oversized message")


def test_subscribe_and_move(port):
    c = WsClient(port, TOKENS["operator"], "watcher")
    ack = c.request({"op": "subscribe", "id": "s1",
                     "topics": ["controllers/+/position", "controllers/+/state"]})
    check(ack["type"] == "subscribed" and ack["topics"] == ["controllers/+/position", "controllers/+/state"],
          f"ack {ack}")
    # Latest-value topics deliver their current value at once: every controller's state.
    states = {}
    deadline = time.monotonic() + WAIT
    while len({"sim1", "sim2", "sim3"} & states.keys()) < 3:
        check(time.monotonic() < deadline, f"states of sim1..3, got {list(states)}")
        m = c.wait_for(is_event(), "state events")
        if m["topic"].endswith("/state"):
            states[m["data"]["id"]] = m
    for sid in ("sim1", "sim2", "sim3"):
        m = states[sid]
        check(m["topic"] == f"controllers/{sid}/state" and m["seq"] >= 1 and "time" in m, f"state event {m}")
        check(m["data"]["state"] == "connected", f"{sid} state {m['data']['state']}")

    # A move over the WebSocket: the result carries our id, position events show it running.
    start = None
    r = c.request({"op": "command", "id": 101, "controller": "sim2", "operation": "move",
                   "args": {"axes": {"X": 3000}, "mode": "relative"}})
    check(r["type"] == "result" and r["id"] == 101, f"move answer {r}")
    check(r["result"]["operation"] == "move" and r["result"]["id"] == "sim2", f"move result {r}")
    check(r["result"]["request_id"].startswith(c.hello["connection"] + ".101"), f"request id {r['result']}")
    seqs = []
    xs = []
    busy_seen = False
    deadline = time.monotonic() + WAIT
    while True:
        check(time.monotonic() < deadline, f"sim2 did not finish its move (positions {xs[-5:]})")
        m = c.wait_for(is_event("controllers/sim2/position"), "sim2 position events")
        seqs.append(m["seq"])
        x = next(a["position_um"] for a in m["data"]["axes"] if a["axis"] == "X")
        xs.append(x)
        if start is None:
            start = x
        busy_seen = busy_seen or m["data"]["busy"]
        if busy_seen and not m["data"]["busy"] and len(xs) >= 2:
            break
    check(all(b > a for a, b in zip(seqs, seqs[1:])), f"sequence numbers increase: {seqs}")
    check(len(set(round(x) for x in xs)) >= 2, f"the position changed during the move: {xs}")
    c.close()
    return


def test_commands(port):
    op = WsClient(port, TOKENS["operator"], "operator")
    cases = [
        # (message, expected type, status)
        ({"op": "command", "id": "h1", "controller": "sim1", "operation": "halt"}, "result", None),
        ({"op": "command", "id": "m1", "controller": "sim1", "operation": "move",
          "args": {"axes": {"X": 10}, "speed": 3}}, "error", 422),
        ({"op": "command", "id": "m2", "controller": "nope", "operation": "halt"}, "error", 404),
        ({"op": "command", "id": "d1", "controller": "sim2", "operation": "dac",
          "args": {"volts": 1.0}}, "error", 409),
        ({"op": "command", "id": "r1", "controller": "sim1", "operation": "command",
          "args": {"command": "W X"}}, "error", 403),
    ]
    for msg, kind, status in cases:
        a = op.request(msg)
        check(a["type"] == kind and a["id"] == msg["id"], f"{msg}: answer {a}")
        if status:
            check(a["problem"]["status"] == status, f"{msg}: problem {a['problem']}")
            check(a["problem"]["request_id"] == f"{op.hello['connection']}.{msg['id']}",
                  f"{msg}: request id {a['problem'].get('request_id')}")
    op.close()
    viewer = WsClient(port, TOKENS["viewer"], "viewer")
    a = viewer.request({"op": "command", "id": 7, "controller": "sim1", "operation": "move",
                        "args": {"axes": {"X": 1}}})
    check(a["type"] == "error" and a["problem"]["status"] == 403, f"viewer move: {a}")
    a = viewer.request({"op": "command", "id": 8, "controller": "sim1", "operation": "halt"})
    check(a["type"] == "result", f"a viewer may halt (auth.halt_role viewer by default): {a}")
    viewer.close()
    admin = WsClient(port, TOKENS["admin"], "admin")
    a = admin.request({"op": "command", "id": "raw", "controller": "sim1", "operation": "command",
                       "args": {"command": "W X"}})
    check(a["type"] == "result" and "raw_reply" in a["result"], f"admin raw command: {a}")
    # Several commands at once, answered each with its own id.
    for i in range(5):
        admin.send({"op": "command", "id": f"p{i}", "controller": "sim3", "operation": "halt"})
    got = set()
    while len(got) < 5:
        m = admin.wait_for(lambda m: m.get("type") in ("result", "error"), "five answers")
        check(m["type"] == "result", f"halt answer {m}")
        got.add(m["id"])
    check(got == {f"p{i}" for i in range(5)}, f"ids {got}")
    admin.close()


def test_error_log(port):
    # A move beyond the lower soft limit is clamped by the controller, which logs code 35 in its own
    # error log; the driver reads it when the move ends and the gateway publishes it.
    c = WsClient(port, TOKENS["admin"], "admin")
    ack = c.request({"op": "subscribe", "id": "e", "topics": ["controllers/ext1/errors"]})
    check(ack["type"] == "subscribed", f"ack {ack}")
    a = c.request({"op": "command", "id": "far", "controller": "ext1", "operation": "command",
                   "args": {"command": "M Y=-2000000"}})
    check(a["type"] == "result", f"move beyond the limit: {a}")
    m = c.wait_for(is_event("controllers/ext1/errors"), "the error log event", 30)
    check(m["data"]["codes"] == [{"code": 35, "name": "LOWER_LIMIT"}] and m["data"]["id"] == "ext1",
          f"error log event {m}")
    c.close()
    check(metric(port, "gw_controller_error_log_total", '{controller="ext1",code="35",name="LOWER_LIMIT"}') == 1,
          "gw_controller_error_log_total counts the code")
    status, body = http_request(port, "GET", "/api/v1/controllers/ext1")
    log = json.loads(body)["error_log"]
    check(status == 200 and log["count"] >= 1 and {"code": 35, "name": "LOWER_LIMIT"} in log["recent"],
          f"the state's error_log {log}")


def test_crisp_state_events(port):
    # sim4 has CRISP: a lock is watched like a move, its state changes come as state events.
    c = WsClient(port, TOKENS["operator"], "operator")
    ack = c.request({"op": "subscribe", "id": "s", "topics": ["controllers/sim4/state"]})
    check(ack["type"] == "subscribed", f"ack {ack}")
    a = c.request({"op": "command", "id": "af", "controller": "sim4", "operation": "autofocus"})
    check(a["type"] == "result" and abs(a["result"]["z_um"] - 150) < 0.1, f"autofocus: {a}")
    names = []  # the CRISP state names of the state events, in order

    def note(m):
        if is_event("controllers/sim4/state")(m) and m["data"]["crisp"]:
            if not names or names[-1] != m["data"]["crisp"]["name"]:
                names.append(m["data"]["crisp"]["name"])
        return False

    def command(id, args):
        # Events that come before the answer are noted too.
        c.send({"op": "command", "id": id, "controller": "sim4", "operation": "crisp", "args": args})
        return c.wait_for(lambda m: note(m) or (m.get("type") in ("result", "error") and m.get("id") == id),
                          f"the answer to {id}")

    a = command("lk", {"action": "lock"})
    check(a["type"] == "result" and a["result"]["crisp"]["name"] == "trying_to_lock", f"lock: {a}")
    def wait_name(name, timeout=WAIT):
        if names[-1:] != [name]:
            c.wait_for(lambda m: note(m) or names[-1:] == [name], f"a state event: {name}", timeout)

    wait_name("locked", 10)
    a = command("off", {"action": "off"})
    check(a["type"] == "result" and a["result"]["crisp"]["name"] == "idle", f"off: {a}")
    wait_name("idle")
    check(names[-3:] == ["trying_to_lock", "locked", "idle"], f"CRISP states in the events: {names}")
    c.close()


def test_resume(port):
    topic = "controllers/sim3/position"
    c = WsClient(port, TOKENS["operator"], "resume1")
    c.request({"op": "subscribe", "id": 1, "topics": [topic]})
    # Enough position events that the oldest leave the (small) latest-value replay buffer.
    seen = []
    c.send({"op": "command", "id": 2, "controller": "sim3", "operation": "move",
            "args": {"axes": {"X": 8000}, "mode": "relative", "wait": True, "timeout_ms": 50000}})
    a = c.wait_for(lambda m: m.get("id") == 2, "the move's result", seen=seen)
    check(a["type"] == "result", f"move: {a}")
    # sim3 is idle now: collect its last position events until none came for two seconds.
    while True:
        try:
            seen.append(c.recv_json(2.0))
        except socket.timeout:
            break
    last = max(m["seq"] for m in seen if m.get("topic") == topic)
    c.close()
    check(last > 12, f"{topic} has only {last} events; the test needs more than the replay buffer")

    # Resume close to the end: exactly the missed events, in order, no gap.
    r = WsClient(port, TOKENS["viewer"], "resume2")
    ack = r.request({"op": "subscribe", "id": "r", "topics": ["controllers/+/position"],
                     "resume": {topic: last - 3}})
    check(ack["resume"] == {topic: last - 3}, f"ack {ack}")
    got = []
    while len(got) < 3:
        m = r.wait_for(lambda m: m.get("topic") == topic, f"replayed events of {topic}")
        check(m["type"] == "event", f"no gap expected when resuming from {last - 3}: {m}")
        got.append(m["seq"])
    check(got == [last - 2, last - 1, last], f"replayed {got}, expected {[last - 2, last - 1, last]}")
    r.close()

    # Resume from far behind: an explicit gap, then the events still in the buffer.
    g = WsClient(port, TOKENS["viewer"], "resume3")
    g.request({"op": "subscribe", "id": "g", "topics": [topic], "resume": {topic: 1}})
    m = g.wait_for(lambda m: m.get("topic") == topic, f"the first message of {topic}")
    check(m["type"] == "gap", f"expected a gap event, got {m}")
    check(m["from"] == 2 and m["to"] >= 2 and m["missed"] == m["to"] - m["from"] + 1, f"gap {m}")
    n = g.wait_for(lambda m: m.get("topic") == topic, f"events of {topic} after the gap")
    check(n["type"] == "event" and n["seq"] == m["to"] + 1, f"after gap {m}: {n}")
    g.close()


def test_reports_stream(port, control2):
    topic = "controllers/ext2/reports"
    a = WsClient(port, TOKENS["operator"], "reports")
    a.request({"op": "subscribe", "id": 1, "topics": ["controllers/+/reports"]})
    r = a.request({"op": "command", "id": 2, "controller": "ext2", "operation": "ttl", "args": {"in0_mode": 1}})
    check(r["type"] == "result", f"ttl in0_mode 1: {r}")
    n = 60
    check(control2(f"pulse {n} 100") == "ok", "pulse")
    got = []
    while len(got) < n:
        m = a.wait_for(lambda m: m.get("topic") == topic, f"report {len(got) + 1} of {n}")
        check(m["type"] == "event", f"a stream topic with a reading client has no gaps: {m}")
        got.append(m["seq"])
    check(got == list(range(got[0], got[0] + n)), f"every report, in order: {got}")
    a.close()
    # Resume inside the replay buffer: exactly the rest of the stream, no gap.
    b = WsClient(port, TOKENS["viewer"], "reports-resume")
    mid = got[0] + 24
    b.request({"op": "subscribe", "id": 1, "topics": [topic], "resume": {topic: mid}})
    rest = []
    while len(rest) < got[-1] - mid:
        m = b.wait_for(lambda m: m.get("topic") == topic, "replayed reports")
        check(m["type"] == "event", f"no gap expected: {m}")
        rest.append(m["seq"])
    check(rest == list(range(mid + 1, got[-1] + 1)), f"replayed {rest}")
    b.close()


def test_batched_reports(port, control2):
    # ?batch_ms=N: events come in "batch" messages, at most one per N ms, each event exactly as a
    # plain connection gets it (compared with one), none lost, in order.
    for bad in ("abc", "1001", "-1", ""):
        status, body = upgrade(port, TOKENS["viewer"], query=f"?batch_ms={bad}")
        check(status == 422, f"batch_ms={bad!r}: {status} {body!r}")
        p = json.loads(body)
        check(p.get("type", "").endswith("/invalid-value") and p.get("field") == "batch_ms", f"problem {p}")
    topic = "controllers/ext2/reports"
    plain = WsClient(port, TOKENS["viewer"], "plain")
    check(plain.hello.get("batch_ms") is None, f"plain hello {plain.hello}")
    batched = WsClient(port, TOKENS["operator"], "batched", query="?batch_ms=1000")
    check(batched.hello.get("batch_ms") == 1000, f"batched hello {batched.hello}")
    for c in (plain, batched):
        c.request({"op": "subscribe", "id": 1, "topics": [topic]})
    r = batched.request({"op": "command", "id": 2, "controller": "ext2", "operation": "ttl", "args": {"in0_mode": 1}})
    check(r["type"] == "result", f"ttl in0_mode 1: {r}")
    n = 100
    started = time.monotonic()
    check(control2(f"pulse {n} 500") == "ok", "pulse")
    expected = [plain.wait_for(lambda m: m.get("topic") == topic, f"plain report {i + 1}") for i in range(n)]
    check(all(m["type"] == "event" for m in expected), "a reading plain client has no gaps")
    got, batches = [], 0
    while len(got) < n:
        m = batched.wait_for(lambda m: m.get("type") == "batch", f"a batch (have {len(got)} of {n} reports)")
        check(isinstance(m.get("events"), list) and m["events"], f"a batch holds events: {m}")
        batches += 1
        got += [e for e in m["events"] if e.get("topic") == topic]
    span = time.monotonic() - started
    check(got == expected, f"the batched events equal the plain ones: {got[:2]} vs {expected[:2]}")
    # At most one batch per second after the first (which goes at once): bounded by the time taken.
    check(batches <= 2 + int(span), f"{batches} batches for {n} reports in {span:.1f} s")
    # Answers are not batched.
    pong = batched.request({"op": "ping", "id": 3})
    check(pong.get("type") == "pong", f"ping answered alone: {pong}")
    plain.close()
    batched.close()


def test_controller_overruns(port, control2):
    # Triggers every 0.5 ms while a frame takes about 1.6 ms to go out: the controller drops most of
    # them (error 87). A report subscriber learns it in its own stream, after the frames: a notice
    # {"controller_overruns": N} with N the frames the controller dropped, apart from gateway gaps.
    topic = "controllers/ext2/reports"
    c = WsClient(port, TOKENS["operator"], "overruns", query="?batch_ms=50")
    c.request({"op": "subscribe", "id": 1, "topics": [topic]})
    r = c.request({"op": "command", "id": 2, "controller": "ext2", "operation": "ttl", "args": {"in0_mode": 1}})
    check(r["type"] == "result", f"ttl in0_mode 1: {r}")
    before = json.loads(control2("state"))
    n = 40

    def sent_and_dropped():
        now = json.loads(control2("state"))
        return now["reports_sent"] - before["reports_sent"], now["reports_dropped"] - before["reports_dropped"]

    check(control2(f"pulse {n} 2000") == "ok", "pulse")
    # The train runs on the simulator's clock: its end is awaited before the stream is judged (the
    # first overrun notice can come while edges are still due).
    wait_until("the pulse train ends", lambda: sum(sent_and_dropped()) >= n)
    sent, dropped = sent_and_dropped()
    check(sent + dropped == n and dropped > 0, f"the simulator sent {sent} and dropped {dropped} of {n}")
    frames, overruns = 0, 0
    deadline = time.monotonic() + WAIT
    while frames < sent or overruns < dropped:
        check(time.monotonic() < deadline,
              f"{frames} frames and {overruns} overruns in the stream; the controller sent {sent}, dropped {dropped}")
        m = c.wait_for(lambda m: m.get("type") == "batch", "a batch")
        for e in m["events"]:
            check(e.get("type") == "event" and e.get("topic") == topic, f"only report events: {e}")
            if "controller_overruns" in e["data"]:
                overruns += e["data"]["controller_overruns"]
            else:
                frames += 1
    check(frames == sent and overruns == dropped,
          f"{frames} frames and {overruns} overruns in the stream; the controller sent {sent}, dropped {dropped}")
    c.close()


def test_stalled_client(port):
    # The stalled client: upgrades, subscribes to everything, then asks for many large answers
    # (acks echo their topics) and never reads, so the gateway's write to it cannot complete.
    s, _ = upgrade(port, TOKENS["viewer"], rcvbuf=4096)
    topics = [f"jobs/stall/{i:02d}/" + "x" * 200 for i in range(63)] + ["#"]
    msg = frame(0x1, json.dumps({"op": "subscribe", "topics": topics}).encode())
    s.setblocking(False)
    stuffing = {"sent": 0, "cut": False, "blocked": False}

    def stuff():
        # Until the gateway cuts us: once it stops reading (its writes to us are stuck), our own
        # send buffer fills and stays full; an error here means the connection is gone.
        pending = b""
        blocked_since = None
        deadline = time.monotonic() + 3 * WAIT
        while time.monotonic() < deadline:
            if not pending:
                pending = msg
                stuffing["sent"] += 1
            try:
                n = s.send(pending)
                pending = pending[n:]
                blocked_since = None
            except BlockingIOError:
                blocked_since = blocked_since or time.monotonic()
                if time.monotonic() - blocked_since > 1:
                    stuffing["blocked"] = True
                time.sleep(0.05)
            except OSError:
                stuffing["cut"] = True
                return

    stuffer = threading.Thread(target=stuff)
    stuffer.start()
    wait_until("the stalled client's pipe to fill", lambda: stuffing["blocked"] or stuffing["cut"])

    # Meanwhile a healthy client sees events and gets answers.
    h = WsClient(port, TOKENS["operator"], "healthy")
    h.request({"op": "subscribe", "id": 1, "topics": ["controllers/+/position"]})
    seqs = []
    for round_ in range(3):
        a = h.request({"op": "command", "id": f"mv{round_}", "controller": "sim1", "operation": "move",
                       "args": {"axes": {"Y": 1500 if round_ % 2 == 0 else -1500}, "mode": "relative"}})
        check(a["type"] == "result", f"healthy move: {a}")
        m = h.wait_for(is_event("controllers/sim1/position"), "sim1 position events (healthy client)")
        seqs.append(m["seq"])
        pong = h.request({"op": "ping", "id": f"p{round_}"})
        check(pong["type"] == "pong", f"pong {pong}")
    check(seqs == sorted(seqs), f"healthy client's sequence numbers {seqs}")

    h.close()  # it would not answer keep-alive pings while we wait for the stalled one
    stuffer.join()
    check(stuffing["cut"], f"the stalled client was not disconnected ({stuffing['sent']} messages sent)")

    # The stalled client is disconnected (its data drains, then EOF or reset).
    s.setblocking(True)
    s.settimeout(WAIT)
    drained = 0
    deadline = time.monotonic() + 3 * WAIT
    ended = False
    while time.monotonic() < deadline:
        try:
            chunk = s.recv(1 << 20)
        except socket.timeout:
            break
        except ConnectionResetError:
            ended = True
            break
        if not chunk:
            ended = True
            break
        drained += len(chunk)
    s.close()
    check(ended, f"the stalled client was not disconnected ({drained} bytes drained)")
    check(metric(port, "gw_websocket_disconnects_total", '{reason="too_slow"}') >= 1,
          "gw_websocket_disconnects_total{reason=\"too_slow\"} did not count it")
    # Others are still served.
    h = WsClient(port, TOKENS["viewer"], "after")
    pong = h.request({"op": "ping", "id": "after"})
    check(pong["type"] == "pong", f"pong {pong}")
    h.close()


def test_unplug(port, control):
    c = WsClient(port, TOKENS["viewer"], "unplug")
    c.request({"op": "subscribe", "id": 1, "topics": ["controllers/ext1/state"]})
    m = c.wait_for(is_event("controllers/ext1/state"), "ext1 state")
    check(m["data"]["state"] == "connected", f"ext1 state before unplug {m['data']['state']}")
    check(control("unplug") == "ok", "unplug")
    try:
        m = c.wait_for(lambda m: m.get("topic") == "controllers/ext1/state" and m.get("type") == "event"
                       and m["data"]["state"] != "connected", "a not-connected state for ext1")
        check(m["data"]["state"] in ("disconnected", "unreachable", "connecting"), f"ext1 state {m['data']}")
        # And back.
        check(control("replug") == "ok", "replug")
        c.wait_for(lambda m: m.get("topic") == "controllers/ext1/state" and m.get("type") == "event"
                   and m["data"]["state"] == "connected", "ext1 connected again")
    finally:
        control("replug")
    c.close()


def test_metrics(port):
    check(metric(port, "gw_websocket_connections_total") >= 5, "gw_websocket_connections_total")
    check(metric(port, "gw_websocket_messages_received_total", '{op="invalid"}') >= 1,
          "gw_websocket_messages_received_total{op=\"invalid\"}")
    check(metric(port, "gw_websocket_gap_events_total") >= 1, "gw_websocket_gap_events_total")


def test_going_away(gw, port):
    c = WsClient(port, TOKENS["viewer"], "shutdown")
    c.request({"op": "subscribe", "id": 1, "topics": ["controllers/+/state"]})
    gw.terminate()
    try:
        c.wait_for(lambda m: False, "the close frame")
    except Closed as e:
        check(e.code == 1001, f"close code on shutdown {e.code} {e.reason!r} (expected 1001 going away)")
        return
    raise Failure("no close frame on shutdown")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    ap.add_argument("--sim", required=True)
    args = ap.parse_args()

    fx = Fixture("gw-ws-test-")
    run = fx.run
    try:
        ext1 = fx.start_sim(args.sim, "ext1", "plain", time_scale=20)
        control = ext1.control
        ext2 = fx.start_sim(args.sim, "ext2", "full", report=True)
        control2 = ext2.control

        port = free_port()
        config = {
            # read_timeout is the WebSocket idle and write timeout: short, so the stalled client is cut
            # within seconds; healthy clients answer the keep-alive pings.
            "http": {"listen_address": "127.0.0.1", "port": port,
                     "limits": {"read_timeout_ms": 4000, "max_websocket_message_bytes": 32768}},
            "controllers": [{"id": "ext1", "port": ext1.link, "baud": 115200, "poll_ms": 50,
                             "command_timeout_ms": 1000},
                            {"id": "ext2", "port": ext2.link, "report_port": ext2.report_link, "baud": 115200}],
            "simulate": {"count": 4, "time_scale": 1, "directory": os.path.join(fx.tmp, "sim")},
            "auth": auth_tokens(),
            "logging": {"level": "info"},
        }
        gw = fx.start_gateway(args.gateway, config)
        log_path = fx.log_path

        run("upgrade without a token is refused", lambda: check(upgrade(port)[0] == 401, "no 401"))
        run("?access_token= on the upgrade: viewer accepted, wrong one 401", test_access_token_query, port,
            log_path)
        run("protocol errors answered, connection kept", test_protocol_errors, port)
        run("oversized message closes with 1009", test_oversized_message_closes_with_1009, port)
        run("subscribe with wildcards, events while a move runs", test_subscribe_and_move, port)
        run("commands over the WebSocket", test_commands, port)
        run("the controller's error log: a clamped move comes as code 35", test_error_log, port)
        run("CRISP state changes come as state events", test_crisp_state_events, port)
        run("resume: replay and gap", test_resume, port)
        run("reports: every frame in order; resume replays the rest", test_reports_stream, port, control2)
        run("batched connection: batch messages, same events, none lost", test_batched_reports, port, control2)
        run("frames the controller dropped come as a notice in the report stream", test_controller_overruns,
            port, control2)
        run("stalled client: healthy one unaffected, stalled one disconnected", test_stalled_client, port)
        run("controller unplugged while watched", test_unplug, port, control)
        run("metrics", test_metrics, port)
        run("SIGTERM closes sessions with 1001 going away", test_going_away, gw, port)
        fx.expect_exit_0()
        fx.finish_log(80)
    finally:
        fx.cleanup()

    return fx.report()


if __name__ == "__main__":
    sys.exit(main())
