#!/usr/bin/python3
"""What a web page of another site may do to a gateway through a browser on the same host, and what
an unauthenticated client may cost it (issue 34), end to end: the real asi-gateway without tokens
(every caller is admin, the default of ./scripts/run) on loopback, with one simulated controller.

Each check sends what a browser would send for a page of another origin:
  - a "simple" cross-site POST (Content-Type: text/plain, a JSON body) of a raw command: 415, and 403
    cross-origin when the browser names the page's origin; nothing reaches the controller;
  - a cross-site POST of a G-code program (text, streamed to the store): 403 from its header;
  - a cross-origin WebSocket upgrade: 403; the gateway's own origin and http.allowed_origins: 101;
  - a request whose Host is a DNS-rebinding name: 421; loopback names and http.allowed_hosts served;
  - a HALT from anywhere is served (stopping a stage is safe whoever asks);
  - 300 invented HTTP methods add no metric series beyond one `other`.

Run by ctest with Debian's /usr/bin/python3. Exit code 0 when every check passed.
"""

import argparse
import http.client
import json
import os
import sys

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gateway_fixture import WAIT, Failure, Fixture, check, free_port, run_main  # noqa: E402
from http_api_test import Client, Contract  # noqa: E402
from ws_api_test import WsClient, upgrade  # noqa: E402

EVIL = "https://evil.example"
ALLOWED_ORIGIN = "https://lab-notebook.example:8443"
ALLOWED_HOST = "gateway.lab.example"
PROBLEMS = "https://asi-gateway.dev/problems/"


def raw_request(port, method, path, headers, body=b""):
    """(status, headers dict lower-case, body text) with exactly these headers (Host included)."""
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=WAIT)
    try:
        conn.putrequest(method, path, skip_host=True, skip_accept_encoding=True)
        for k, v in headers.items():
            conn.putheader(k, v)
        if body:
            conn.putheader("Content-Length", str(len(body)))
        conn.endheaders(body or None)
        r = conn.getresponse()
        return r.status, {k.lower(): v for k, v in r.getheaders()}, r.read().decode("utf-8", "replace")
    finally:
        conn.close()


def problem_type(body):
    try:
        return json.loads(body).get("type", "").removeprefix(PROBLEMS)
    except ValueError:
        return f"(not JSON: {body[:200]!r})"


def x_reply(c):
    """The controller's answer to W X, asked as a script would."""
    r = c.request("POST", "/api/v1/controllers/sim1/command", {"command": "W X"})
    check(r.status == 200, f"W X: {r.status} {r.body[:300]}")
    return r.json()["raw_reply"]


def test_cross_site_simple_post(c, port):
    host = f"127.0.0.1:{port}"
    before = x_reply(c)
    body = json.dumps({"command": "H X=1234"}).encode()  # HERE: the X position becomes 123.4 um
    # What a form or fetch(..., {mode: "no-cors"}) of another site sends: no preflight is asked for.
    status, _, text = raw_request(port, "POST", "/api/v1/controllers/sim1/command",
                                  {"Host": host, "Content-Type": "text/plain;charset=UTF-8", "Origin": EVIL}, body)
    check(status == 403 and problem_type(text) == "cross-origin", f"text/plain from {EVIL}: {status} {text[:300]}")
    # The same body without Origin (an older browser, a script with the wrong type): 415, still refused.
    status, _, text = raw_request(port, "POST", "/api/v1/controllers/sim1/command",
                                  {"Host": host, "Content-Type": "text/plain"}, body)
    check(status == 415 and problem_type(text) == "unsupported-media-type", f"text/plain: {status} {text[:300]}")
    status, _, text = raw_request(port, "POST", "/api/v1/controllers/sim1/command",
                                  {"Host": host, "Content-Type": "application/x-www-form-urlencoded"}, body)
    check(status == 415, f"a form post: {status} {text[:300]}")
    check(x_reply(c) == before, f"a refused cross-site request reached the controller: {before} -> {x_reply(c)}")
    # The gateway's own page, and a script without Origin, are served.
    for headers in ({"Origin": f"http://{host}"}, {}):
        status, _, text = raw_request(port, "POST", "/api/v1/controllers/sim1/command",
                                      {"Host": host, "Content-Type": "application/json; charset=utf-8", **headers},
                                      json.dumps({"command": "W X"}).encode())
        check(status == 200, f"application/json with {headers or 'no Origin'}: {status} {text[:300]}")
    # An allowed origin from the config.
    status, _, text = raw_request(port, "POST", "/api/v1/controllers/sim1/command",
                                  {"Host": host, "Content-Type": "application/json", "Origin": ALLOWED_ORIGIN},
                                  json.dumps({"command": "W X"}).encode())
    check(status == 200, f"from http.allowed_origins: {status} {text[:300]}")
    # Reads from another origin are the browser's business (no CORS headers: the page cannot read them).
    status, headers, _ = raw_request(port, "GET", "/api/v1/controllers", {"Host": host, "Origin": EVIL})
    check(status == 200 and "access-control-allow-origin" not in headers, f"GET from {EVIL}: {status} {headers}")


def test_cross_site_program_upload(c, port):
    host = f"127.0.0.1:{port}"
    program = b"G21 G90\nG0 X1 Y1\nM2\n"
    # A G-code program is text, which a page of another site may post without a preflight; its body
    # is streamed to the store, so the header alone must refuse it.
    for path in ("/api/v1/gcode/files?name=evil.ngc", "/api/v1/gcode/plan", "/api/v1/gcode/preview.svg"):
        status, _, text = raw_request(port, "POST", path,
                                      {"Host": host, "Content-Type": "text/plain", "Origin": EVIL}, program)
        check(status == 403 and problem_type(text) == "cross-origin", f"{path} from {EVIL}: {status} {text[:300]}")
    r = c.request("GET", "/api/v1/gcode/files")
    check(r.status == 200, f"files: {r.status} {r.body[:300]}")
    check(all(f.get("name") != "evil.ngc" for f in r.json()["files"]), f"a cross-site upload was stored: {r.body[:300]}")
    # The gateway's own page, and a script without Origin, may upload.
    for headers in ({"Origin": f"http://{host}"}, {}):
        status, _, text = raw_request(port, "POST", "/api/v1/gcode/files?name=own.ngc",
                                      {"Host": host, "Content-Type": "text/plain", **headers}, program)
        check(status == 201, f"an upload with {headers or 'no Origin'}: {status} {text[:300]}")
        r = c.request("DELETE", f"/api/v1/gcode/files/{json.loads(text)['id']}")
        check(r.status == 204, f"delete: {r.status} {r.body[:300]}")


def test_cross_origin_websocket(port):
    r = upgrade(port, extra_headers=(f"Origin: {EVIL}",))
    check(isinstance(r[0], int) and r[0] == 403 and problem_type(r[1].decode()) == "cross-origin",
          f"a cross-origin upgrade: {r[0]} {r[1]!r}")
    for origin in (f"http://127.0.0.1:{port}", ALLOWED_ORIGIN):
        ws = WsClient(port, name=origin, extra_headers=(f"Origin: {origin}",))
        answer = ws.request({"op": "command", "id": 1, "controller": "sim1", "operation": "command",
                             "args": {"command": "W X"}})
        check(answer.get("type") == "result", f"a command over an upgrade from {origin}: {answer}")
        ws.close()


def test_foreign_host(c, port):
    for host in ("evil.example", f"evil.example:{port}", "192.168.1.20:8080"):
        status, _, text = raw_request(port, "GET", "/api/v1/controllers", {"Host": host})
        check(status == 421 and problem_type(text) == "misdirected-request", f"Host {host}: {status} {text[:300]}")
    status, _, text = raw_request(port, "GET", "/", {"Host": "evil.example"})
    check(status == 421, f"the dashboard for Host evil.example: {status}")
    r = upgrade(port, extra_headers=("Host: evil.example",))
    check(isinstance(r[0], int) and r[0] == 421, f"an upgrade for Host evil.example: {r[0]}")
    for host in (f"localhost:{port}", f"127.0.0.1:{port}", f"[::1]:{port}", "LOCALHOST", ALLOWED_HOST,
                 f"{ALLOWED_HOST}:{port}"):
        status, _, text = raw_request(port, "GET", "/api/v1/controllers", {"Host": host})
        check(status == 200, f"Host {host}: {status} {text[:300]}")


def test_halt_from_anywhere(c, port):
    status, _, text = raw_request(port, "POST", "/api/v1/controllers/sim1/halt",
                                  {"Host": "evil.example", "Origin": EVIL, "Content-Type": "text/plain"})
    check(status == 200, f"HALT from {EVIL} for Host evil.example: {status} {text[:300]}")
    status, _, text = raw_request(port, "POST", "/api/v1/halt", {"Host": "evil.example", "Origin": EVIL})
    check(status == 200, f"HALT ALL from {EVIL}: {status} {text[:300]}")
    r = c.request("GET", "/api/v1/controllers/sim1")
    check(r.json().get("halted"), f"sim1 not halted after the HALT: {r.body[:300]}")


def metric_series(c):
    r = c.request("GET", "/api/v1/metrics", validate=False)
    check(r.status == 200, f"metrics: {r.status}")
    return [line for line in r.body.splitlines() if line.startswith("gw_http_requests_total{")]


def test_invented_methods_add_no_series(c, port):
    before = metric_series(c)
    for i in range(300):
        status, _, _ = raw_request(port, f"JUNK{i}", "/api/v1/health", {"Host": f"127.0.0.1:{port}"})
        check(status in (400, 404, 405, 501), f"JUNK{i}: {status}")
    after = metric_series(c)
    check(len(after) <= len(before) + 2, f"{len(after) - len(before)} new series: {after[-5:]}")
    check(not any("JUNK" in line for line in after), "an invented method became a label")
    check(any('method="other"' in line for line in after), f"no method=\"other\" series: {after}")


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--gateway", required=True)
    p.add_argument("--openapi", required=True)
    args = p.parse_args()
    with open(args.openapi) as f:
        contract = Contract(f.read())
    fx = Fixture("asi-browser-test-")
    try:
        port = free_port()
        fx.start_gateway(args.gateway, {
            "http": {"listen_address": "127.0.0.1", "port": port, "allowed_origins": [ALLOWED_ORIGIN],
                     "allowed_hosts": [ALLOWED_HOST]},
            "simulate": {"count": 1, "directory": os.path.join(fx.tmp, "sims")}})
        c = Client(port, contract)
        fx.run("a cross-site simple POST is refused (403, 415)", test_cross_site_simple_post, c, port)
        fx.run("a cross-site G-code upload, plan or preview is refused (403)", test_cross_site_program_upload, c, port)
        fx.run("a cross-origin WebSocket upgrade is refused", test_cross_origin_websocket, port)
        fx.run("a foreign Host is refused without tokens (421)", test_foreign_host, c, port)
        fx.run("300 invented methods add no metric series", test_invented_methods_add_no_series, c, port)
        fx.run("a HALT from anywhere is served", test_halt_from_anywhere, c, port)
        fx.finish_log(60)
        return fx.report()
    except Failure:
        raise
    finally:
        fx.cleanup()


if __name__ == "__main__":
    run_main(main)
