#!/usr/bin/python3
"""End-to-end test of the HTTP server's defences (issue 12, points 4 and 5): the real asi-gateway
(no controllers) on a free loopback port, raw sockets and http.client.

Slow clients: ~300 slowloris connections (a request header one byte per second, never finished;
a connection the gateway closes is opened again) from one loopback address, then from 300
different ones (127.0.x.y: Linux routes all of 127/8 to lo), while a normal client on 127.0.0.1
makes requests on fresh connections: each must be answered, 200, within one second (the issue's
requirement, and the only tight wall-clock bound here). A lone slow header is closed by the header
deadline (http.limits.header_timeout_ms, 5 s; checked against 15 s, half the read timeout it must
beat), an idle keep-alive connection is not.

Bodies: 100-continue is answered only for an accepted request; a G-code upload over the planner's
capacity, without a token or with a role too low, with a bad query or too big is refused from its
headers alone (the body is never sent); the held requests then send their bodies and get their
plans; a chunked body streams like one with Content-Length. Twelve parallel 24 MiB uploads leave the gateway's peak RSS (VmHWM) within 64 MiB of what it
was before. Requests whose bodies would exceed http.limits.max_buffered_body_mb in all are refused
with 503 body-budget-exhausted (Retry-After) until the budget is free again.

Every problem body is validated against openapi/openapi.yaml (the Contract of http_api_test.py).
Bounded: every loop has a deadline, the slowloris stops by itself. Standard library plus Debian's
python3-yaml and python3-jsonschema (for the Contract). Exit code 0 when every check passed.
"""

import argparse
import http.client
import json
import os
import select
import socket
import sys
import threading
import time

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gateway_fixture import (TOKENS, WAIT, Fixture, auth_tokens, check, free_port, vm_kib,  # noqa: E402
                             wait_until)
from http_api_test import Contract  # noqa: E402

VIEW = TOKENS["viewer"]
OP = TOKENS["operator"]
SLOW_CONNECTIONS = 300
SLOW_SECONDS = 20          # at most, each slowloris phase: longer than the header deadline (5 s)
ANSWER_WITHIN = 1.0        # the requirement for a normal client during the slowloris
PLANNER_SLOTS = 8          # gcode_worker's max_pending
MAX_BODY = 768 * 1024      # http.limits.max_body_bytes
BODY_BUDGET_MB = 2         # http.limits.max_buffered_body_mb
UPLOAD_MB = 24
UPLOADS = 12
PROBLEM = "https://asi-gateway.dev/problems/"


# --------------------------------------------------------------------------------------------
# Helpers


class Slowloris:
    """`count` connections from `addresses` (cycled), each sending a request header one byte per
    second that never ends. A connection the gateway closes (or answers) is opened again a second
    later, so the pressure lasts until `seconds` have passed or stop() is called. Its own thread."""

    HEADER = b"GET /api/v1/health HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: " + b"a" * 100000

    def __init__(self, port, addresses, count=SLOW_CONNECTIONS, seconds=SLOW_SECONDS):
        self.port = port
        self.addresses = addresses
        self.count = count
        self.seconds = seconds
        self.slots = [None] * count       # [socket, bytes sent] or None
        self.reopen_at = [0.0] * count
        self.opened = 0
        self.answered_503 = 0             # closed with a (503) answer
        self.closed = 0                   # closed without an answer
        self.max_open = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def start(self):
        self._thread.start()
        return self

    def stop(self):
        self._stop.set()
        self._thread.join(timeout=WAIT)
        for s in self.slots:
            if s:
                s[0].close()

    def _open(self, i):
        s = socket.socket()
        try:
            s.bind((self.addresses[i % len(self.addresses)], 0))
            s.settimeout(2)
            s.connect(("127.0.0.1", self.port))
            s.setblocking(False)
        except OSError:
            s.close()
            self.reopen_at[i] = time.monotonic() + 1
            return
        self.slots[i] = [s, 0]
        self.opened += 1

    def _drop(self, i, answered):
        self.slots[i][0].close()
        self.slots[i] = None
        self.reopen_at[i] = time.monotonic() + 1
        if answered:
            self.answered_503 += 1
        else:
            self.closed += 1

    def _run(self):
        deadline = time.monotonic() + self.seconds
        while not self._stop.is_set() and time.monotonic() < deadline:
            now = time.monotonic()
            for i in range(self.count):
                if self.slots[i] is None and now >= self.reopen_at[i]:
                    self._open(i)
            open_ = [i for i in range(self.count) if self.slots[i]]
            self.max_open = max(self.max_open, len(open_))
            readable, _, _ = select.select([self.slots[i][0] for i in open_], [], [], 0)
            readable = set(readable)
            for i in open_:
                s, sent = self.slots[i]
                if s in readable:
                    try:
                        data = s.recv(65536)
                    except OSError:
                        data = b""
                    self._drop(i, data.startswith(b"HTTP/1.1 503"))
                    continue
                try:
                    s.send(self.HEADER[sent:sent + 1])
                    self.slots[i][1] += 1
                except OSError:
                    self._drop(i, False)
            self._stop.wait(1.0)


def timed_request(port, path, token=VIEW):
    """(status, seconds) of one GET on a fresh connection from 127.0.0.1."""
    t0 = time.monotonic()
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=WAIT, source_address=("127.0.0.1", 0))
    try:
        conn.request("GET", path, headers={"Authorization": f"Bearer {token}"})
        r = conn.getresponse()
        r.read()
        return r.status, time.monotonic() - t0
    finally:
        conn.close()


def read_response(s, timeout=WAIT):
    """(status, headers dict with lower-case names, body bytes) of one response on raw socket `s`;
    a 100 Continue has no body."""
    s.settimeout(timeout)
    data = b""
    while b"\r\n\r\n" not in data:
        chunk = s.recv(65536)
        check(chunk, f"the connection closed before a response head: {data[:200]!r}")
        data += chunk
    head, _, rest = data.partition(b"\r\n\r\n")
    lines = head.decode("latin-1").split("\r\n")
    status = int(lines[0].split()[1])
    headers = {}
    for line in lines[1:]:
        k, _, v = line.partition(":")
        headers[k.strip().lower()] = v.strip()
    if status == 100:
        return status, headers, rest  # rest: the start of the final response, if any
    length = int(headers.get("content-length", "0"))
    while len(rest) < length:
        chunk = s.recv(65536)
        check(chunk, "the connection closed inside a response body")
        rest += chunk
    return status, headers, rest[:length]


def send_head(port, method, path, token, length, expect=True, source="127.0.0.1", media=None):
    """A raw connection that has sent the headers of a request with a body of `length` bytes (not
    the body). With `expect`, Expect: 100-continue."""
    s = socket.socket()
    s.bind((source, 0))
    s.settimeout(WAIT)
    s.connect(("127.0.0.1", port))
    head = f"{method} {path} HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: {length}\r\n"
    # G-code programs are text; every other body is JSON.
    media = media or ("text/plain" if "/gcode" in path else "application/json")
    head += f"Content-Type: {media}\r\n"
    if token:
        head += f"Authorization: Bearer {token}\r\n"
    if expect:
        head += "Expect: 100-continue\r\n"
    s.sendall((head + "\r\n").encode())
    return s


def expect_problem(contract, s, method, path, status, kind, what):
    """The next response on `s` is problem `kind` with `status`, validated against the contract."""
    got, headers, body = read_response(s)
    check(got == status, f"{what}: expected {status} {kind}, got {got}: {body[:200]!r}")
    check(headers.get("content-type") == "application/problem+json", f"{what}: {headers.get('content-type')}")
    p = json.loads(body)
    check(p["type"] == PROBLEM + kind, f"{what}: problem type {p['type']}")
    contract.validate_response(method, path.split("?")[0], got, headers.get("content-type"), body.decode())
    return headers, p


def program(lines):
    return "".join(f"G01 X{i % 10} Y{(i // 10) % 10} F600\n" for i in range(1, lines + 1)).encode()


# --------------------------------------------------------------------------------------------
# Slow clients


def normal_client_during(port, slow, what, requests=10):
    """Makes `requests` requests while `slow` runs; each must be a 200 within ANSWER_WITHIN."""
    time.sleep(2)  # the slow connections are open and have started their headers
    times = []
    for i in range(requests):
        status, seconds = timed_request(port, "/api/v1/controllers")
        times.append(seconds)
        check(status == 200, f"{what}: request {i} got {status} after {seconds:.3f} s "
                             f"(slowloris: {slow.max_open} open at most, {slow.answered_503} answered 503)")
        check(seconds < ANSWER_WITHIN, f"{what}: request {i} took {seconds:.3f} s")
        time.sleep(0.8)
    times.sort()
    print(f"       {what}: {requests} requests, median {times[len(times) // 2] * 1e3:.1f} ms, "
          f"max {times[-1] * 1e3:.1f} ms; slowloris: {slow.opened} connections opened, "
          f"{slow.max_open} open at most, {slow.answered_503} answered 503, {slow.closed} closed by the gateway")


def test_slowloris_one_address(port):
    slow = Slowloris(port, ["127.0.0.2"]).start()
    try:
        normal_client_during(port, slow, "one address")
    finally:
        slow.stop()
    # The address limit answered the excess at once instead of letting it wait.
    check(slow.answered_503 > 0, "connections over the address limit should get 503")


def test_slowloris_many_addresses(port):
    addresses = [f"127.0.{1 + i // 250}.{1 + i % 250}" for i in range(SLOW_CONNECTIONS)]
    slow = Slowloris(port, addresses).start()
    try:
        normal_client_during(port, slow, f"{len(addresses)} addresses")
    finally:
        slow.stop()


def test_header_deadline(port):
    # A header that never ends is closed by the header deadline (5 s by default), long before the
    # read timeout (30 s by default); an idle keep-alive connection is not (it waits for its next
    # request up to the read timeout).
    idle = http.client.HTTPConnection("127.0.0.1", port, timeout=WAIT)
    idle.request("GET", "/api/v1/health")
    check(idle.getresponse().read(), "keep-alive request")
    slow = socket.create_connection(("127.0.0.1", port), timeout=WAIT)
    t0 = time.monotonic()
    closed_after = None
    for byte in b"GET /api/v1/health HTTP/1.1\r\nHost: x\r\nX-Slow: " + b"a" * 60:
        try:
            slow.send(bytes([byte]))
        except OSError:
            closed_after = time.monotonic() - t0
            break
        r, _, _ = select.select([slow], [], [], 0.5)
        if r:
            try:
                data = slow.recv(4096)
            except ConnectionResetError:
                data = b""  # closed with bytes of ours unread: a reset, which is a close too
            check(data == b"", "a slow header gets no answer, it is closed")
            closed_after = time.monotonic() - t0
            break
    slow.close()
    check(closed_after is not None and closed_after < 15, f"a slow header was not closed within 15 s: {closed_after}")
    print(f"       a slow header was closed after {closed_after:.1f} s")
    idle.request("GET", "/api/v1/health")
    r = idle.getresponse()
    check(r.status == 200 and r.read(), "the idle keep-alive connection still serves requests")
    idle.close()


# --------------------------------------------------------------------------------------------
# Bodies


def test_refusals_before_the_body(port, contract):
    body = program(20000)
    plan_path = "/api/v1/gcode/plan?moves=false"
    held = []
    try:
        # The planner's capacity is taken from the headers: each held request gets 100 Continue and
        # keeps its slot while its body has not come.
        for i in range(PLANNER_SLOTS):
            s = send_head(port, "POST", plan_path, VIEW, len(body))
            held.append(s)
            status, _, _ = read_response(s)
            check(status == 100, f"held request {i}: expected 100 Continue, got {status}")
        s = send_head(port, "POST", plan_path, VIEW, len(body))
        headers, _ = expect_problem(contract, s, "POST", plan_path, 503, "planner-busy", "over the planner's capacity")
        check(headers.get("retry-after"), "planner-busy has Retry-After")
        check(headers.get("connection") == "close", "a refused body closes the connection")
        s.close()
        # Auth, role, query and size are decided from the headers too.
        cases = [("/api/v1/gcode/plan", None, len(body), 401, "unauthorized"),
                 ("/api/v1/gcode/files?name=a.ngc", VIEW, len(body), 403, "forbidden"),
                 ("/api/v1/gcode/plan?no_such_option=1", VIEW, len(body), 422, "invalid-value"),
                 ("/api/v1/gcode/files?name=a%0Ab", OP, len(body), 422, "invalid-value"),
                 ("/api/v1/gcode/plan", VIEW, 64 * 1024 * 1024 + 1, 413, "payload-too-large")]
        for path, token, length, status, kind in cases:
            s = send_head(port, "POST", path, token, length)
            expect_problem(contract, s, "POST", path, status, kind, f"POST {path} ({kind})")
            s.close()
        # Now the held bodies: each is planned.
        for s in held:
            s.sendall(body)
        for i, s in enumerate(held):
            status, headers, text = read_response(s)
            check(status == 200, f"held request {i}: {status} {text[:200]!r}")
            plan = json.loads(text)
            check(plan["move_count"] == 20000, f"held request {i}: {plan.get('move_count')} moves")
    finally:
        for s in held:
            s.close()
    # Without Expect the body follows the headers at once; a streamed upload is stored whole.
    r = http.client.HTTPConnection("127.0.0.1", port, timeout=WAIT)
    r.request("POST", "/api/v1/gcode/files?name=s.ngc", body=body, headers={"Authorization": f"Bearer {OP}"})
    res = r.getresponse()
    info = json.loads(res.read())
    check(res.status == 201 and info["bytes"] == len(body) and info["lines"] == 20000, f"upload: {info}")
    r.request("DELETE", "/api/v1/gcode/files/" + info["id"], headers={"Authorization": f"Bearer {OP}"})
    deleted = r.getresponse()
    deleted.read()
    check(deleted.status == 204, "delete")
    # A chunked body streams the same way, whatever its chunks' sizes.
    pieces = (body[i:i + 70001] for i in range(0, len(body), 70001))
    r.request("POST", "/api/v1/gcode/plan?moves=false", body=pieces, encode_chunked=True,
              headers={"Authorization": f"Bearer {VIEW}"})
    res = r.getresponse()
    plan = json.loads(res.read())
    check(res.status == 200 and plan["move_count"] == 20000, f"chunked plan: {res.status} {plan}")
    r.close()


def test_parallel_uploads_bounded_memory(port, pid):
    body = b"G01 X1 Y1 F600\n" * (UPLOAD_MB * 1024 * 1024 // 15)
    rss_before = vm_kib(pid, "VmRSS")
    results = [None] * UPLOADS

    def upload(i):
        # As curl sends a big body: Expect: 100-continue, the body only after 100 Continue.
        path = f"/api/v1/gcode/files?name=big{i}.ngc"
        s = send_head(port, "POST", path, OP, len(body))
        try:
            status, _, text = read_response(s, timeout=300)
            if status == 100:
                s.sendall(body)
                status, _, text = read_response(s, timeout=300)
            results[i] = (status, json.loads(text))
        finally:
            s.close()

    threads = [threading.Thread(target=upload, args=(i,)) for i in range(UPLOADS)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=600)
    peak = vm_kib(pid, "VmHWM")
    stored = [r[1] for r in results if r and r[0] == 201]
    refused = [r for r in results if r and r[0] == 503]
    print(f"       {UPLOADS} parallel {UPLOAD_MB} MiB uploads: {len(stored)} stored, {len(refused)} planner-busy; "
          f"RSS before {rss_before // 1024} MiB, peak (VmHWM) after {peak // 1024} MiB")
    for r in results:
        check(r and (r[0] == 201 or (r[0] == 503 and r[1]["type"] == PROBLEM + "planner-busy")),
              f"an upload got {r and r[0]}: {str(r and r[1])[:200]}")
    check(len(stored) >= PLANNER_SLOTS,
          f"only {len(stored)} uploads were stored; refused: {[r[1].get('type') for r in refused]}")
    for info in stored:
        check(info["bytes"] == len(body), f"stored {info['bytes']} bytes of {len(body)}")
    check(peak - rss_before < 64 * 1024, f"peak RSS grew by {(peak - rss_before) // 1024} MiB")
    for info in stored:
        conn = http.client.HTTPConnection("127.0.0.1", port, timeout=WAIT)
        conn.request("DELETE", "/api/v1/gcode/files/" + info["id"], headers={"Authorization": f"Bearer {OP}"})
        conn.getresponse().read()
        conn.close()


def test_body_budget(port, contract):
    # Two held 700 kB bodies fill most of the 2 MiB budget; a third is refused from its headers.
    length = 700 * 1000
    path = "/api/v1/jobs"
    held = []
    try:
        for i in range(2):
            s = send_head(port, "POST", path, OP, length)
            held.append(s)
            status, _, _ = read_response(s)
            check(status == 100, f"held body {i}: expected 100 Continue, got {status}")
        s = send_head(port, "POST", path, OP, length)
        headers, p = expect_problem(contract, s, "POST", path, 503, "body-budget-exhausted", "over the body budget")
        check(headers.get("retry-after"), "body-budget-exhausted has Retry-After")
        s.close()
        # A body that is sent is answered (here: not JSON), and frees its share.
        held[0].sendall(b"x" * length)
        expect_problem(contract, held[0], "POST", path, 400, "malformed-json", "a held body sent")
    finally:
        for s in held:
            s.close()

    def accepted():
        s = send_head(port, "POST", path, OP, length)
        try:
            return read_response(s)[0] == 100
        finally:
            s.close()

    wait_until("the body budget is free again", accepted)


def test_unadmitted_bodies_cost_nothing(port, contract):
    # Bodies that would be refused anyway are refused from their headers (no 100 Continue, nothing
    # reserved, the connection closed): no token, a role too low, a JSON body that is not typed JSON,
    # a method the route does not take, a route that does not exist. Held open together, they leave
    # the whole budget to the clients that are admitted.
    length = 700 * 1000
    cases = [("POST", "/api/v1/jobs", None, "application/json", 401, "unauthorized"),
             ("POST", "/api/v1/jobs", VIEW, "application/json", 403, "forbidden"),
             ("POST", "/api/v1/jobs", OP, "text/plain", 415, "unsupported-media-type"),
             ("PUT", "/api/v1/jobs", OP, "application/json", 405, "method-not-allowed"),
             ("POST", "/api/v1/no-such-route", OP, "application/json", 404, "not-found")]
    refused = []
    try:
        for method, path, token, media, status, kind in cases:
            s = send_head(port, method, path, token, length, media=media)
            refused.append(s)
            got, headers, body = read_response(s)
            check(got == status, f"{method} {path} ({kind}): expected {status} from the header, got {got}: "
                                 f"{body[:200]!r}")
            check(json.loads(body)["type"] == PROBLEM + kind, f"{method} {path}: {body[:200]!r}")
            check(headers.get("connection") == "close", f"{method} {path}: the connection stays open")
        held = []
        for i in range(2):
            s = send_head(port, "POST", "/api/v1/jobs", OP, length)
            held.append(s)
            status, _, _ = read_response(s)
            check(status == 100, f"an operator's body {i} beside the refused ones: {status}")
        for s in held:
            s.close()
    finally:
        for s in refused:
            s.close()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    ap.add_argument("--openapi", required=True)
    args = ap.parse_args()
    with open(args.openapi) as f:
        contract = Contract(f.read())

    # Under AddressSanitizer freed memory waits in a quarantine and would look like growth.
    env = os.environ.get("ASAN_OPTIONS", "")
    os.environ["ASAN_OPTIONS"] = ":".join(filter(None, [env, "quarantine_size_mb=0"]))
    fx = Fixture("gw-http-limits-")
    try:
        port = free_port()
        config = {"http": {"port": port,
                           "limits": {"max_body_bytes": MAX_BODY, "max_buffered_body_mb": BODY_BUDGET_MB}},
                  "simulate": {"count": 0},
                  "storage": {"path": os.path.join(fx.tmp, "store")},
                  "auth": auth_tokens()}
        gw = fx.start_gateway(args.gateway, config)
        fx.run("slowloris from one address", test_slowloris_one_address, port)
        fx.run("slowloris from 300 addresses", test_slowloris_many_addresses, port)
        fx.run("header deadline", test_header_deadline, port)
        fx.run("refusals before the body", test_refusals_before_the_body, port, contract)
        fx.run("parallel uploads in bounded memory", test_parallel_uploads_bounded_memory, port, gw.pid)
        fx.run("body budget", test_body_budget, port, contract)
        fx.run("bodies that would be refused cost nothing", test_unadmitted_bodies_cost_nothing, port, contract)
        fx.gateway.terminate()
        fx.expect_exit_0()
        fx.finish_log(60)
    finally:
        fx.cleanup()
    return fx.report()


if __name__ == "__main__":
    sys.exit(main())
