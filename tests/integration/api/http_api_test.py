#!/usr/bin/python3
"""End-to-end test of the REST API: starts the real asi-gateway (four simulated controllers
in-process plus one external ms2000-sim with a control socket for unplug/timeouts) on a free
loopback port, talks to it with real HTTP clients, and checks every endpoint, every error kind,
auth roles, request ids and limits. It validates openapi/openapi.yaml structurally (every $ref
resolves, every operation has responses, every schema compiles as JSON Schema 2020-12, every
example matches its schema) and validates every real response body against the schema the
document gives for its path, method, status and content type.

Run by ctest with Debian's /usr/bin/python3 (python3-yaml, python3-jsonschema).
The gateway, sims, config and run/report harness come from gateway_fixture.py (shared).
Exit code 0 when every check passed; the failures are listed otherwise.
"""

import argparse
import gzip
import http.client
import json
import os
import re
import socket
import subprocess
import sys
import threading

import jsonschema
import yaml

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gateway_fixture import TOKENS, WAIT, Failure, Fixture, auth_tokens, check, free_port, wait_until  # noqa: E402


# --------------------------------------------------------------------------------------------
# The OpenAPI document


def resolve_pointer(doc, ref):
    check(ref.startswith("#/"), f"only local $refs are used: {ref}")
    node = doc
    for part in ref[2:].split("/"):
        part = part.replace("~1", "/").replace("~0", "~")
        check(isinstance(node, dict) and part in node, f"$ref {ref} does not resolve")
        node = node[part]
    return node


def walk(node, path=""):
    if isinstance(node, dict):
        yield path, node
        for k, v in node.items():
            yield from walk(v, f"{path}/{k}")
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from walk(v, f"{path}/{i}")


class Contract:
    def __init__(self, text):
        self.doc = yaml.safe_load(text)
        self.resolver = jsonschema.RefResolver(base_uri="", referrer=self.doc)
        self.covered = set()  # (template, method, status) seen in real responses

    def validator(self, schema):
        return jsonschema.Draft202012Validator(schema, resolver=self.resolver)

    def deref(self, node):
        while isinstance(node, dict) and "$ref" in node and len(node) == 1:
            node = resolve_pointer(self.doc, node["$ref"])
        return node

    def check_structure(self):
        d = self.doc
        check(d.get("openapi", "").startswith("3.1"), "openapi must be 3.1.x")
        check("paths" in d and d["paths"], "no paths")
        for where, node in walk(d):
            if "$ref" in node and isinstance(node["$ref"], str):
                resolve_pointer(d, node["$ref"])
        methods = {"get", "put", "post", "delete", "patch", "head", "options"}
        for p, item in d["paths"].items():
            for m, op in item.items():
                if m not in methods:
                    continue
                check(op.get("responses"), f"{m.upper()} {p} has no responses")
                check(op.get("operationId"), f"{m.upper()} {p} has no operationId")
        for name, schema in d["components"]["schemas"].items():
            jsonschema.Draft202012Validator.check_schema(schema)
        # Every example matches the schema next to it.
        n = 0
        for where, node in walk(d):
            if "schema" in node and isinstance(node["schema"], dict):
                examples = []
                if "example" in node:
                    examples.append(node["example"])
                for ex in (node.get("examples") or {}).values():
                    examples.append(self.deref(ex)["value"])
                for ex in examples:
                    errors = list(self.validator(node["schema"]).iter_errors(ex))
                    check(not errors, f"example at {where} does not match its schema: {errors[:1]}")
                    n += 1
        check(n >= 10, f"only {n} examples were checked")

    def template_for(self, path):
        for template in self.doc["paths"]:
            pattern = "^" + re.sub(r"\{[^}]+\}", "[^/]+", template) + "$"
            if re.match(pattern, path):
                return template
        return None

    def validate_response(self, method, path, status, content_type, body):
        template = self.template_for(path)
        check(template is not None, f"{path} is not in the document")
        op = self.doc["paths"][template].get(method.lower())
        if op is None and status == 405:
            # A method the path does not have: the generic problem.
            self.covered.add((template, method, status))
            errors = list(self.validator({"$ref": "#/components/schemas/Problem"}).iter_errors(json.loads(body)))
            check(not errors, f"{method} {path} 405: {[e.message for e in errors[:3]]}")
            return
        check(op is not None, f"{method} {template} is not in the document")
        responses = op["responses"]
        check(str(status) in responses, f"{method} {template}: status {status} is not documented")
        self.covered.add((template, method, status))
        response = self.deref(responses[str(status)])
        media = (content_type or "").split(";")[0].strip()
        content = response.get("content", {})
        if not content:  # a documented response without a body (304, HEAD)
            check(not body, f"{method} {template} {status}: a body where none is documented: {body[:200]!r}")
            return
        check(media in content, f"{method} {template} {status}: content type {media} is not documented")
        schema = content[media].get("schema")
        if schema is None:
            return
        value = body
        if media.endswith("json"):
            value = json.loads(body)
        errors = list(self.validator(schema).iter_errors(value))
        check(not errors, f"{method} {path} {status}: body does not match the schema: "
                          f"{[e.message for e in errors[:3]]}\nbody: {body[:400]!r}")


# --------------------------------------------------------------------------------------------
# HTTP


class Response:
    def __init__(self, status, headers, raw):
        self.status = status
        self.headers = headers
        self.raw = raw
        self.body = raw.decode("utf-8", "replace")

    def json(self):
        return json.loads(self.body)

    def header(self, name):
        for k, v in self.headers:
            if k.lower() == name.lower():
                return v
        return None


class Client:
    def __init__(self, port, contract):
        self.port = port
        self.contract = contract

    def request(self, method, path, body=None, token=None, headers=None, validate=True, raw_body=None):
        h = dict(headers or {})
        if token:
            h["Authorization"] = f"Bearer {token}"
        data = raw_body
        if body is not None:
            data = json.dumps(body).encode()
            h["Content-Type"] = "application/json"
        conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=WAIT)
        try:
            conn.request(method, path, body=data, headers=h)
            r = conn.getresponse()
            res = Response(r.status, r.getheaders(), r.read())
        finally:
            conn.close()
        check(res.header("X-Request-Id"), f"{method} {path}: no X-Request-Id in the response")
        if validate:
            self.contract.validate_response(method, path.split("?")[0], res.status,
                                            res.header("Content-Type"), res.body)
        return res

    def problem(self, method, path, status, kind, **kw):
        r = self.request(method, path, **kw)
        check(r.status == status, f"{method} {path}: expected {status}, got {r.status}: {r.body[:300]}")
        check(r.header("Content-Type") == "application/problem+json",
              f"{method} {path}: problem content type is {r.header('Content-Type')}")
        p = r.json()
        check(p["type"] == "https://asi-gateway.dev/problems/" + kind,
              f"{method} {path}: expected problem type {kind}, got {p['type']}")
        check(p["status"] == status, "problem status differs from the HTTP status")
        check(p.get("request_id") == r.header("X-Request-Id"), "problem request_id differs from the header")
        return p


# --------------------------------------------------------------------------------------------
# The tests


def test_public_endpoints(c):
    r = c.request("GET", "/api/v1/health")
    check(r.status == 200 and r.json()["status"] == "ok" and r.json()["version"], f"health: {r.status} {r.body}")
    r = c.request("GET", "/api/v1/ready")
    check(r.status == 200 and r.json()["ready"] is True, f"ready: {r.status} {r.body}")
    ids = [x["id"] for x in r.json()["controllers"]]
    check(ids == ["ext1", "sim1", "sim2", "sim3", "sim4"], f"ready lists {ids}")
    for path in ("/api/v1/openapi.yaml", "/openapi.yaml"):
        r = c.request("GET", path)
        check(r.status == 200, f"{path}: {r.status}")
        check(yaml.safe_load(r.body) == c.contract.doc, f"{path} differs from openapi/openapi.yaml")


DASHBOARD_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "api", "dashboard")
MEDIA_TYPES = {".html": "text/html", ".js": "text/javascript", ".css": "text/css", ".svg": "image/svg+xml"}
# The third-party modules, served from node_modules under these names (api/CMakeLists.txt).
VENDOR_FILES = {"vendor/uplot.min.js": "text/javascript", "vendor/uplot.min.css": "text/css",
                "vendor/js-yaml.min.js": "text/javascript", "vendor/mqtt.esm.js": "text/javascript"}


def dashboard_files():
    """Every file the gateway embeds, by name under /dashboard/, with its media type."""
    files = {name: MEDIA_TYPES[os.path.splitext(name)[1]] for name in os.listdir(DASHBOARD_DIR)
             if os.path.splitext(name)[1] in MEDIA_TYPES}
    files.update(VENDOR_FILES)
    return files


def test_dashboard_assets(c):
    r = c.request("GET", "/")
    check(r.status == 200, f"GET /: {r.status} {r.body[:200]}")
    check(r.header("Content-Type") == "text/html; charset=utf-8", f"GET / type {r.header('Content-Type')}")
    csp = r.header("Content-Security-Policy") or ""
    check("default-src 'self'" in csp and "script-src 'self'" in csp and "unsafe-inline" not in csp,
          f"GET / CSP: {csp!r}")
    check(r.header("Cache-Control") == "no-cache", f"GET / Cache-Control {r.header('Cache-Control')}")
    etag = r.header("ETag") or ""
    check(re.fullmatch(r'"[0-9a-f]{32}"', etag), f"GET / ETag {etag!r} is not a strong hash tag")
    html = r.body
    # No inline script or style (the CSP would block them), nothing from another origin.
    check(not re.search(r"<script(?![^>]*\bsrc=)[^>]*>", html), "index.html has an inline script")
    check(not re.search(r"\sstyle=|\son[a-z]+=", html), "index.html has inline style or handler attributes")
    check("http://" not in html and "https://" not in html, "index.html names another origin")
    files = dashboard_files()
    referenced = set(re.findall(r'(?:src|href)="/dashboard/([^"]+)"', html))
    check(referenced and referenced <= set(files), f"index.html references {referenced}")
    tags = {}
    for name, media in files.items():
        r = c.request("GET", "/dashboard/" + name)
        check(r.status == 200, f"/dashboard/{name}: {r.status}")
        check((r.header("Content-Type") or "").split(";")[0] == media, f"{name} type {r.header('Content-Type')}")
        check(r.header("Content-Security-Policy") == csp, f"{name} has another CSP")
        tags[name] = r.header("ETag")
        if name.endswith(".js") and not name.startswith("vendor/"):
            # Every module it imports (statically or on demand) is served too, from this origin.
            for imported in re.findall(r'(?:from |import\()"([^"]+)"', r.body):
                check(imported.startswith("./") and imported[2:] in files, f"{name} imports {imported}")
    check(len(set(tags.values())) == len(tags), f"two files share an ETag: {tags}")
    # Revalidation: 304 without a body for the current tag (weak comparison), 200 for another.
    for match in (etag, "W/" + etag, f'"0000", {etag}', "*"):
        r = c.request("GET", "/", headers={"If-None-Match": match})
        check(r.status == 304 and r.body == "" and r.header("ETag") == etag, f"If-None-Match {match}: {r.status}")
    r = c.request("GET", "/dashboard/app.js", headers={"If-None-Match": etag})
    check(r.status == 200, f"app.js with index.html's ETag: {r.status}")
    # HEAD: the headers of GET, no body.
    r = c.request("HEAD", "/")
    check(r.status == 200 and r.body == "" and r.header("Content-Length") == str(len(html.encode())),
          f"HEAD /: {r.status} length {r.header('Content-Length')} body {r.body[:50]!r}")
    check(r.header("ETag") == etag, "HEAD / ETag differs from GET")
    r = c.request("HEAD", "/dashboard/nope.js")
    check(r.status == 404 and r.body == "", f"HEAD of an unknown file: {r.status}")
    # Client mistakes: problems, never a 500.
    for method, path in (("POST", "/"), ("DELETE", "/dashboard/app.js"), ("PUT", "/dashboard/style.css")):
        r = c.request(method, path, validate=True)
        c.problem(method, path, 405, "method-not-allowed")
        check(r.header("Allow") == "GET, HEAD", f"{method} {path} Allow {r.header('Allow')}")
    c.problem("GET", "/dashboard/nope.js", 404, "not-found")
    # The page's folder names the page: a redirect to "/", where it is served.
    for method, path in (("GET", "/dashboard/"), ("GET", "/dashboard"), ("HEAD", "/dashboard/")):
        r = c.request(method, path, validate=path.endswith("/"))
        check(r.status == 301 and r.header("Location") == "/", f"{method} {path}: {r.status} {r.header('Location')}")
    c.problem("GET", "/dashboard/sub/app.js", 404, "not-found", validate=False)
    c.problem("GET", "/dashboard/..%2Fapi", 404, "not-found")
    c.problem("GET", "/dashboard/vendor/", 404, "not-found", validate=False)
    c.problem("GET", "/dashboard/vendor/../app.js", 404, "not-found", validate=False)
    test_dashboard_gzip(c, tags)


def test_dashboard_gzip(c, tags):
    """gzip for clients that accept it: the same bytes, their own ETag, Vary; never for q=0."""
    plain = c.request("GET", "/dashboard/vendor/uplot.min.js")
    check(plain.header("Content-Encoding") is None, "gzip sent to a client that did not ask")
    check(plain.header("Vary") == "Accept-Encoding", f"no Vary on a file with a gzip copy: {plain.header('Vary')}")
    # Content codings are case-insensitive (RFC 9110 8.4.1).
    for accept in ("gzip", "br, gzip;q=0.5", "deflate, *", "GZIP"):
        r = c.request("GET", "/dashboard/vendor/uplot.min.js", headers={"Accept-Encoding": accept})
        check(r.status == 200 and r.header("Content-Encoding") == "gzip", f"Accept-Encoding {accept}: "
              f"{r.status} {r.header('Content-Encoding')}")
        check(gzip.decompress(r.raw) == plain.raw, f"Accept-Encoding {accept}: not the file's bytes")
        check(len(r.raw) < len(plain.raw) // 2, f"gzip saves little: {len(r.raw)} of {len(plain.raw)}")
        check(r.header("Content-Length") == str(len(r.raw)), "gzip Content-Length")
        gz_tag = r.header("ETag")
        check(gz_tag == tags["vendor/uplot.min.js"][:-1] + '-gz"', f"gzip ETag {gz_tag}")
    for accept in ("gzip;q=0", "identity", "gzip; q=0.000, br", "deflate", "gzip;q=0, *", "*;q=0"):
        r = c.request("GET", "/dashboard/vendor/uplot.min.js", headers={"Accept-Encoding": accept})
        check(r.header("Content-Encoding") is None and r.raw == plain.raw, f"Accept-Encoding {accept} got gzip")
    r = c.request("GET", "/dashboard/vendor/uplot.min.js", headers={"Accept-Encoding": "gzip",
                                                                    "If-None-Match": gz_tag})
    check(r.status == 304 and r.header("ETag") == gz_tag, f"304 for the gzip tag: {r.status}")
    r = c.request("GET", "/dashboard/vendor/uplot.min.js", headers={"If-None-Match": gz_tag})
    check(r.status == 200, f"the gzip tag matched the plain representation: {r.status}")
    gzipped = c.request("GET", "/dashboard/vendor/uplot.min.js", headers={"Accept-Encoding": "gzip"})
    r = c.request("HEAD", "/dashboard/vendor/uplot.min.js", headers={"Accept-Encoding": "gzip"})
    check(r.header("Content-Encoding") == "gzip" and r.header("Content-Length") == str(len(gzipped.raw)),
          f"HEAD with gzip: {r.header('Content-Length')}")


def test_controllers(c):
    r = c.request("GET", "/api/v1/controllers", token=TOKENS["viewer"])
    check(r.status == 200, f"list: {r.status}")
    by_id = {x["id"]: x for x in r.json()["controllers"]}
    check(set(by_id) == {"ext1", "sim1", "sim2", "sim3", "sim4"}, f"ids {sorted(by_id)}")
    full = by_id["sim1"]["identity"]["modules"]
    check({"array", "ring_buffer", "scan", "ttl_report"} <= set(full), f"sim1 modules {full}")
    check(by_id["sim1"]["report_port"] == "open", f"sim1 report port {by_id['sim1']['report_port']}")
    planar = by_id["sim3"]["identity"]["modules"]
    check({"planar_correction", "dac_out", "led_dimmer"} <= set(planar), f"sim3 modules {planar}")
    focus = by_id["sim4"]["identity"]["modules"]
    check({"crisp", "autofocus"} <= set(focus), f"sim4 modules {focus}")
    check(by_id["sim1"]["crisp"] is None, f"sim1 has no CRISP: {by_id['sim1']['crisp']}")
    wait_until("sim4's CRISP state polled", lambda: c.request("GET", "/api/v1/controllers/sim4",
                                                               token=TOKENS["viewer"]).json()["crisp"] is not None)
    r = c.request("GET", "/api/v1/controllers/sim2", token=TOKENS["viewer"])
    check(r.status == 200 and r.json()["id"] == "sim2", f"get sim2: {r.status}")
    check([a["axis"] for a in r.json()["axes"]] == ["X", "Y", "Z"], "sim2 axes")
    c.problem("GET", "/api/v1/controllers/nope", 404, "unknown-controller", token=TOKENS["viewer"])


def test_operations(c):
    t = TOKENS["operator"]
    base = "/api/v1/controllers/sim1"
    r = c.request("POST", base + "/move", {"axes": {"X": 1500.0, "Y": -200}, "wait": True}, token=t)
    check(r.status == 200, f"move: {r.status} {r.body}")
    pos = {p["axis"]: p["position_um"] for p in r.json()["positions"]}
    check(r.json()["waited"] and abs(pos["X"] - 1500) < 1 and abs(pos["Y"] + 200) < 1, f"move positions {pos}")
    r = c.request("POST", base + "/move", {"axes": {"X": -500}, "mode": "relative", "wait": True,
                                          "timeout_ms": 30000}, token=t)
    check(r.status == 200, f"relative move: {r.status} {r.body}")
    pos = {p["axis"]: p["position_um"] for p in r.json()["positions"]}
    check(abs(pos["X"] - 1000) < 1, f"relative move ended at {pos}")
    # The snapshot follows (polling).
    wait_until("sim1 X near 1000 in GET", lambda: abs(
        c.request("GET", base, token=t).json()["axes"][0]["position_um"] - 1000) < 1)
    # zero, here and home are refused while the stage moves (409 busy): wait for the snapshot.
    not_busy = lambda: not c.request("GET", base, token=t).json()["busy"]  # noqa: E731
    wait_until("sim1 stopped", not_busy)
    for op, body in [("halt", None), ("halt", {}), ("zero", {}), ("here", {"axes": {"X": 10}}),
                     ("speed", {"axes": {"X": 2.5}}), ("ttl", {"in0_mode": 1, "out0_mode": 0}),
                     ("home", {"axes": ["X"]}), ("halt", {})]:
        r = c.request("POST", f"{base}/{op}", body, token=t)
        check(r.status == 200, f"{op}: {r.status} {r.body}")
        check(r.json()["operation"] == op and r.json()["id"] == "sim1", f"{op}: {r.body}")
    wait_until("sim1 stopped after home and halt", not_busy)
    r = c.request("POST", "/api/v1/controllers/sim3/dac", {"volts": 2.5}, token=t)
    check(r.status == 200, f"dac on sim3: {r.status} {r.body}")
    r = c.request("POST", "/api/v1/controllers/sim3/led", {"percent": 40, "channel": "X"}, token=t)
    check(r.status == 200, f"led on sim3: {r.status} {r.body}")
    r = c.request("POST", base + "/halt", token=t)  # no body at all
    check(r.status == 200, f"halt without body: {r.status}")


def test_focus(c):
    """CRISP and AUTOFOCUS on sim4 (the "crisp" preset: the sample is in focus at Z = 150 um)."""
    t = TOKENS["operator"]
    base = "/api/v1/controllers/sim4"

    def crisp(body):
        r = c.request("POST", base + "/crisp", body, token=t)
        check(r.status == 200, f"crisp {body}: {r.status} {r.body}")
        check(r.json()["operation"] == "crisp", f"crisp {body}: {r.body}")
        return r.json()["crisp"]

    r = c.request("POST", base + "/move", {"axes": {"Z": 0}, "wait": True}, token=t)
    check(r.status == 200, f"Z to 0: {r.status} {r.body}")
    got = crisp({"action": "unlock"})
    # 150 um below focus: beyond the focus error's range, which saturates.
    check(got["name"] == "ready" and got["focus_error"] == -32767, f"ready 150 um below focus: {got}")
    check(got["sum"] > 0 and got["snr"] is not None, f"readings with the LED on: {got}")
    got = crisp({"action": "lock", "wait": True, "timeout_ms": 20000})
    check(got["state"] == "E" and got["name"] == "error", f"too far from focus to lock: {got}")
    wait_until("the error state in GET", lambda: c.request("GET", base, token=t).json()["crisp"]
               == {"state": "E", "name": "error"})
    r = c.request("POST", base + "/autofocus", {"timeout_ms": 30000}, token=t)
    check(r.status == 200 and abs(r.json()["z_um"] - 150) < 0.1, f"autofocus: {r.status} {r.body}")
    got = crisp({"lock_offset": 500, "action": "lock", "wait": True, "save": True})
    # The servo may still be moving Z the 500 nm to the new set point.
    check(got["name"] == "locked" and got["lock_offset"] == 500 and -525 <= got["focus_error"] <= 25,
          f"locked with an offset: {got}")
    r = c.request("POST", base + "/move", {"axes": {"Z": 0}, "mode": "relative", "wait": True}, token=t)
    z = {p["axis"]: p["position_um"] for p in r.json()["positions"]}["Z"]
    check(abs(z - 150.5) < 0.1, f"the lock holds Z 500 nm above focus: {z}")
    wait_until("locked in GET", lambda: c.request("GET", base, token=t).json()["crisp"]["name"] == "locked")
    got = crisp({})
    check(got["name"] == "locked" and abs(got["focus_error"]) <= 25, f"a read changes nothing: {got}")
    got = crisp({"action": "off", "lock_offset": 0})
    check(got["name"] == "idle" and got["sum"] == 0 and got["lock_offset"] == 0, f"LED off: {got}")

    c.problem("POST", "/api/v1/controllers/sim1/crisp", 409, "missing-module", body={}, token=t)
    c.problem("POST", "/api/v1/controllers/sim1/autofocus", 409, "missing-module", body={}, token=t)
    for body, field in [({"action": "focus"}, "action"), ({"wait": True}, "wait"),
                        ({"lock_offset": 1e9}, "lock_offset"), ({"lock_offset": "up"}, "lock_offset"),
                        ({"timeout_ms": 0}, "timeout_ms"), ({"now": True}, "now")]:
        p = c.problem("POST", base + "/crisp", 422, "invalid-value", body=body, token=t)
        check(p.get("field") == field, f"{body}: field {p.get('field')}")
    c.problem("POST", base + "/crisp", 403, "forbidden", body={}, token=TOKENS["viewer"])


def test_raw_command(c):
    base = "/api/v1/controllers/sim2/command"
    r = c.request("POST", base, {"command": "W X Y"}, token=TOKENS["admin"])
    check(r.status == 200, f"command: {r.status} {r.body}")
    j = r.json()
    check(j["reply"]["kind"] == "ack" and j["raw_reply"].startswith(":A"), f"W X Y reply {j}")
    r = c.request("POST", base, {"command": "NOSUCH"}, token=TOKENS["admin"])
    check(r.status == 200 and r.json()["reply"]["kind"] == "error", f"unknown command: {r.body}")
    check(r.json()["reply"]["error_code"] == -1, f"unknown command code: {r.body}")
    p = c.problem("POST", base, 422, "invalid-value", body={"command": "W X\nY"}, token=TOKENS["admin"])
    p = c.problem("POST", base, 403, "forbidden", body={"command": "W X"}, token=TOKENS["operator"])


def upper_limit_x(c, cid):
    r = c.request("GET", f"/api/v1/controllers/{cid}", token=TOKENS["viewer"])
    x = [a for a in r.json()["axes"] if a["axis"] == "X"][0]
    return x["soft_limits_um"]["upper"]


def test_reset_needs_force(c):
    # Commands that reset or recalibrate the controller are refused unless the caller insists...
    base = "/api/v1/controllers/sim2/command"
    admin = TOKENS["admin"]
    for command in ("~", "RESET", "SS X", "UM X=-10000", "CNTS X=1000"):
        p = c.problem("POST", base, 422, "invalid-value", body={"command": command}, token=admin)
        check(p.get("field") == "force", f"{command}: field {p.get('field')}: {p}")
    for command in ("SS Z", "UM X?", "CNTS X?"):  # saving, and reading, need no insisting
        r = c.request("POST", base, {"command": command}, token=admin)
        check(r.status == 200, f"{command}: {r.status} {r.body[:200]}")
    c.problem("POST", base, 422, "invalid-value", body={"command": "~", "force": "yes"}, token=admin)
    # ... and then the controller is identified again: what identification reads is read again. A
    # soft limit set before the reset (read back at once) is the power-up one after it.
    powered_up = upper_limit_x(c, "sim2")
    r = c.request("POST", base, {"command": "SU X=50"}, token=admin)
    check(r.status == 200, f"SU X=50: {r.status} {r.body[:200]}")
    wait_until("the new upper limit read back", lambda: upper_limit_x(c, "sim2") == 50000)
    r = c.request("POST", base, {"command": "~", "force": True}, token=admin)
    check(r.status == 200, f"a forced RESET: {r.status} {r.body[:200]}")
    wait_until("sim2 identified again with its power-up limit",
               lambda: upper_limit_x(c, "sim2") == powered_up and
               c.request("GET", "/api/v1/controllers/sim2", token=TOKENS["viewer"]).json()["state"] == "connected")


def test_errors(c):
    t = TOKENS["operator"]
    base = "/api/v1/controllers/sim1"
    c.problem("POST", base + "/move", 400, "malformed-json", raw_body=b'{"axes": ', token=t,
              headers={"Content-Type": "application/json"})
    p = c.problem("POST", base + "/move", 422, "invalid-value", body={"axes": {"X": 1}, "speed": 3}, token=t)
    check(p.get("field") == "speed", f"unknown field problem names {p.get('field')}")
    p = c.problem("POST", base + "/move", 422, "invalid-value", body={"axes": {"X": "far"}}, token=t)
    check(p.get("field") == "axes.X", f"wrong type names {p.get('field')}")
    p = c.problem("POST", base + "/move", 422, "invalid-value", body={"axes": {"X": 5e6}}, token=t)
    check(p.get("field") == "axes.X", f"out of range names {p.get('field')}")
    c.problem("POST", base + "/move", 422, "invalid-value", body={"axes": {"Q": 1}}, token=t)
    c.problem("POST", base + "/move", 422, "invalid-value", body=[1, 2], token=t)
    c.problem("POST", base + "/speed", 422, "invalid-value", body={"axes": {"X": 500}}, token=t)
    # A HALT's body is not even read: nothing may stand in the way of an emergency stop.
    r = c.request("POST", base + "/halt", body={"now": True}, token=t)
    check(r.status == 200, f"a HALT with a body it does not know: {r.status} {r.body[:200]}")
    c.problem("POST", base + "/ttl", 422, "invalid-value", body={"in0_mode": 99}, token=t)
    c.problem("POST", "/api/v1/controllers/sim2/dac", 409, "missing-module", body={"volts": 1}, token=t)
    c.problem("POST", "/api/v1/controllers/sim1/led", 409, "missing-module", body={"percent": 1}, token=t)
    c.problem("POST", "/api/v1/controllers/nope/halt", 404, "unknown-controller", token=t)
    c.problem("GET", "/api/v1/nothing", 404, "not-found", token=t, validate=False)
    c.problem("GET", "/api/v1/controllers/sim1/frobnicate", 404, "not-found", token=t, validate=False)
    c.problem("GET", base + "/halt", 405, "method-not-allowed", token=t)
    c.problem("DELETE", base, 405, "method-not-allowed", token=t)
    c.problem("POST", "/api/v1/health", 405, "method-not-allowed")
    big = b'{"axes": {"X": 1}, "pad": "' + b"x" * 20000 + b'"}'
    c.problem("POST", base + "/move", 413, "payload-too-large", raw_body=big, token=t,
              headers={"Content-Type": "application/json"})
    c.problem("GET", "/api/v1/controllers", 431, "header-too-large", token=TOKENS["viewer"],
              headers={"X-Padding": "p" * 9000}, validate=False)


def test_auth(c):
    c.problem("GET", "/api/v1/controllers", 401, "unauthorized")
    c.problem("GET", "/api/v1/controllers", 401, "unauthorized", token="not-a-token-0123456789")
    c.problem("GET", "/api/v1/controllers", 401, "unauthorized", headers={"Authorization": "Basic abc"})
    c.problem("GET", "/api/v1/metrics", 401, "unauthorized")
    c.problem("POST", "/api/v1/controllers/sim1/move", 403, "forbidden", body={"axes": {"X": 1}},
              token=TOKENS["viewer"])
    # The emergency stop is every token holder's (auth.halt_role, viewer by default).
    r = c.request("POST", "/api/v1/controllers/sim1/halt", token=TOKENS["viewer"])
    check(r.status == 200, f"a viewer may halt: {r.status} {r.body[:200]}")
    c.problem("POST", "/api/v1/controllers/sim1/command", 403, "forbidden", body={"command": "W X"},
              token=TOKENS["viewer"])
    r = c.request("GET", "/api/v1/controllers", token=TOKENS["admin"])
    check(r.status == 200, "admin may read")
    r = c.request("POST", "/api/v1/controllers/sim1/halt", token=TOKENS["admin"])
    check(r.status == 200, "admin may operate")
    r = c.request("GET", "/api/v1/health")
    check(r.status == 200, "health is public")


def test_whoami(c):
    for role, token in TOKENS.items():
        r = c.request("GET", "/api/v1/whoami", token=token)
        check(r.status == 200 and r.json() == {"client": role + "1", "role": role, "auth": "token"},
              f"whoami as {role}: {r.status} {r.body}")
    c.problem("GET", "/api/v1/whoami", 401, "unauthorized")
    c.problem("GET", "/api/v1/whoami", 401, "unauthorized", token="not-a-token-0123456789")
    c.problem("POST", "/api/v1/whoami", 405, "method-not-allowed", token=TOKENS["viewer"])


def test_whoami_without_tokens(gateway, tmp, contract):
    """A gateway without tokens (loopback only): every client is admin, with or without a token."""
    port = free_port()
    cfg = os.path.join(tmp, "open.json")
    with open(cfg, "w") as f:
        json.dump({"http": {"listen_address": "127.0.0.1", "port": port}, "simulate": {"count": 0},
                   "storage": {"path": os.path.join(tmp, "open-store")}}, f)
    log = open(os.path.join(tmp, "open.log"), "w")
    p = subprocess.Popen([gateway, "--config", cfg], stdout=log, stderr=subprocess.STDOUT)
    try:
        c = Client(port, contract)

        def up():
            check(p.poll() is None, f"the gateway without tokens exited with {p.returncode}")
            try:
                return c.request("GET", "/api/v1/health").status == 200
            except OSError:
                return False

        wait_until("the gateway without tokens", up)
        for token in (None, "any-token-at-all-0123"):
            r = c.request("GET", "/api/v1/whoami", token=token)
            check(r.status == 200 and r.json() == {"client": None, "role": "admin", "auth": "none"},
                  f"whoami without tokens ({token}): {r.status} {r.body}")
    finally:
        p.terminate()
        try:
            p.wait(timeout=WAIT)
        except subprocess.TimeoutExpired:
            p.kill()
        log.close()


def test_request_ids(c):
    r = c.request("POST", "/api/v1/controllers/sim2/halt", token=TOKENS["operator"],
                  headers={"X-Request-Id": "client-id-42"})
    check(r.header("X-Request-Id") == "client-id-42", f"request id not honoured: {r.header('X-Request-Id')}")
    check(r.json()["request_id"] == "client-id-42", "result request_id")
    p = c.problem("POST", "/api/v1/controllers/sim2/dac", 409, "missing-module", body={"volts": 1},
                  token=TOKENS["operator"], headers={"X-Request-Id": "client-id-43"})
    check(p["request_id"] == "client-id-43", "problem request_id")
    a = c.request("GET", "/api/v1/health").header("X-Request-Id")
    b = c.request("GET", "/api/v1/health").header("X-Request-Id")
    check(a != b and len(a) >= 8, f"generated ids {a} {b}")
    bad = c.request("GET", "/api/v1/health", headers={"X-Request-Id": "has space"}).header("X-Request-Id")
    check(bad != "has space", "an invalid request id must be replaced")


def test_unplug_and_timeout(c, control):
    t = TOKENS["operator"]
    base = "/api/v1/controllers/ext1"
    wait_until("ext1 connected", lambda: c.request("GET", base, token=t).json()["state"] == "connected")
    # 504: the controller does not answer (the simulator drops the reply; ext1 does not poll).
    check(control("drop-next") == "ok", "drop-next")
    p = c.problem("POST", base + "/zero", 504, "timeout", token=t)
    wait_until("ext1 answers again", lambda: c.request("POST", base + "/halt", token=t).status == 200)
    # 503: unplugged while clients watch.
    check(control("unplug") == "ok", "unplug")
    wait_until("ext1 not connected", lambda: c.request("GET", base, token=t).json()["state"] != "connected")
    c.problem("POST", base + "/halt", 503, "not-connected", token=t)
    r = c.request("GET", "/api/v1/ready")
    check(r.status == 503 and r.json()["ready"] is False, f"ready while unplugged: {r.status}")
    # The other controllers are not affected.
    r = c.request("POST", "/api/v1/controllers/sim2/halt", token=t)
    check(r.status == 200, f"sim2 while ext1 is unplugged: {r.status}")
    check(control("replug") == "ok", "replug")
    wait_until("ext1 connected again", lambda: c.request("GET", base, token=t).json()["state"] == "connected")
    wait_until("ready again", lambda: c.request("GET", "/api/v1/ready").status == 200)


def test_slow_operation_does_not_block_others(c):
    """A move waiting for arrival holds its request open; everything else keeps answering."""
    t = TOKENS["operator"]
    base = "/api/v1/controllers/sim1"
    check(c.request("POST", base + "/speed", {"axes": {"X": 0.1}}, token=t).status == 200, "slow speed")
    result = {}

    def slow_move():
        result["r"] = c.request("POST", base + "/move", {"axes": {"X": 100000}, "wait": True,
                                                        "timeout_ms": 600000}, token=t)

    mover = threading.Thread(target=slow_move)
    mover.start()
    try:
        wait_until("sim1 busy", lambda: c.request("GET", base, token=t).json()["busy"])
        for _ in range(10):
            check(c.request("GET", "/api/v1/health").status == 200, "health during the move")
            check(c.request("GET", "/api/v1/controllers/sim2", token=t).status == 200, "sim2 during the move")
            check(c.request("POST", "/api/v1/controllers/sim2/halt", token=t).status == 200,
                  "sim2 halt during the move")
        p = c.problem("POST", base + "/zero", 409, "busy", token=t)
        check("moving" in p["detail"], f"busy detail: {p['detail']}")
        check(mover.is_alive(), "the move should still be waiting (0.1 mm/s over 100 mm)")
    finally:
        c.request("POST", base + "/halt", token=t)
        mover.join(WAIT)
    check(not mover.is_alive(), "HALT must end the waiting move")
    r = result["r"]
    check(r.status == 200 and r.json()["waited"], f"the halted move answers: {r.status} {r.body[:200]}")
    x = r.json()["positions"][0]["position_um"]
    check(x < 100000, f"halted before arriving: X={x}")
    check(c.request("POST", base + "/speed", {"axes": {"X": 5}}, token=t).status == 200, "speed back")


def parse_metrics(text):
    out = {}
    for line in text.splitlines():
        if not line or line.startswith("#"):
            continue
        name, value = line.rsplit(" ", 1)
        out[name] = float(value)
    return out


def test_metrics(c):
    r = c.request("GET", "/api/v1/metrics", token=TOKENS["viewer"])
    check(r.status == 200 and r.header("Content-Type").startswith("text/plain"), f"metrics: {r.status}")
    m = parse_metrics(r.body)
    for needed in ['gw_controller_command_duration_seconds_count{controller="sim1"}',
                   'gw_controller_commands_total{controller="sim1",origin="user"}',
                   'gw_controller_command_timeouts_total{controller="ext1"}',
                   'gw_controller_reconnects_total{controller="ext1"}',
                   'gw_controller_connected{controller="sim2"}',
                   'gw_http_requests_total{method="POST",route="/api/v1/controllers/{id}/move",status="200"}',
                   'gw_events_published_total', 'gw_event_subscribers']:
        key = needed
        if needed.startswith("gw_http_requests_total"):
            key = 'gw_http_requests_total{route="/api/v1/controllers/{id}/move",method="POST",status="200"}'
        check(key in m, f"metric {key} missing")
    check(m['gw_controller_command_timeouts_total{controller="ext1"}'] >= 1, "timeouts counted")
    check(m['gw_controller_reconnects_total{controller="ext1"}'] >= 1, "reconnects counted")
    check(m['gw_controller_connected{controller="sim2"}'] == 1, "sim2 connected gauge")
    check(any(k.startswith('gw_http_requests_total{route="/api/v1/controllers/{id}/move",method="POST",status="422"')
              for k in m), "422s counted by route")
    # Prometheus text format: every sample line is "name{labels} value".
    for line in r.body.splitlines():
        if line and not line.startswith("#"):
            check(re.match(r'^[a-zA-Z_:][a-zA-Z0-9_:]*(\{.*\})? [-+0-9.eEInfNa]+$', line), f"bad line {line!r}")


def ws_handshake(port, path, token=None):
    """The status line and headers of a raw WebSocket upgrade request."""
    s = socket.create_connection(("127.0.0.1", port), timeout=WAIT)
    try:
        auth = f"Authorization: Bearer {token}\r\n" if token else ""
        s.sendall((f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                   f"Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n{auth}\r\n")
                  .encode())
        data = b""
        while b"\r\n\r\n" not in data:
            chunk = s.recv(4096)
            if not chunk:
                break
            data += chunk
        return data.decode("latin-1")
    finally:
        s.close()


def test_websocket_route(c):
    # Without upgrade headers /api/v1/ws is not a REST route.
    c.problem("GET", "/api/v1/ws", 404, "not-found", token=TOKENS["viewer"], validate=False)
    # The upgrade is authenticated by the HTTP session before the WebSocket session takes over.
    head = ws_handshake(c.port, "/api/v1/ws")
    check(head.startswith("HTTP/1.1 401"), f"upgrade without a token: {head[:80]!r}")
    head = ws_handshake(c.port, "/api/v1/elsewhere", TOKENS["viewer"])
    check(head.startswith("HTTP/1.1 404"), f"upgrade elsewhere: {head[:80]!r}")
    head = ws_handshake(c.port, "/api/v1/ws", TOKENS["viewer"])
    # 101 once the WebSocket session is built in, 501 (documented) before.
    check(head.startswith("HTTP/1.1 101") or head.startswith("HTTP/1.1 501"), f"upgrade: {head[:80]!r}")


def test_limits(c, port, max_connections):
    # Read timeout: a client that sends half a request is disconnected.
    s = socket.create_connection(("127.0.0.1", port), timeout=WAIT)
    s.sendall(b"GET /api/v1/health HTTP/1.1\r\nHost: x\r\n")
    data = s.recv(4096)
    check(data == b"", f"a stalled request should be closed, got {data[:80]!r}")
    s.close()
    # Connection limit: with max_connections open, one more is answered 503 and closed.
    held = []
    try:
        for _ in range(max_connections):
            held.append(socket.create_connection(("127.0.0.1", port), timeout=WAIT))
        extra = socket.create_connection(("127.0.0.1", port), timeout=WAIT)
        data = b""
        while True:
            chunk = extra.recv(4096)
            if not chunk:
                break
            data += chunk
        extra.close()
        check(data.startswith(b"HTTP/1.1 503"), f"over the limit: {data[:120]!r}")
        check(b"too-many-connections" in data, "problem type too-many-connections")
    finally:
        for h in held:
            h.close()
    wait_until("connections free again", lambda: c.request("GET", "/api/v1/health").status == 200)
    # Keep-alive: two requests on one connection.
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=WAIT)
    for _ in range(2):
        conn.request("GET", "/api/v1/health")
        r = conn.getresponse()
        r.read()
        check(r.status == 200, "keep-alive request")
    conn.close()


def test_refuses_public_address_without_tokens(gateway, tmp):
    cfg = os.path.join(tmp, "public.json")
    with open(cfg, "w") as f:
        json.dump({"http": {"listen_address": "0.0.0.0", "port": free_port()}, "simulate": {"count": 0}}, f)
    p = subprocess.run([gateway, "--config", cfg], capture_output=True, text=True, timeout=WAIT)
    check(p.returncode != 0, "binding 0.0.0.0 without tokens must be refused")
    check("token" in (p.stderr + p.stdout).lower(), f"the refusal should mention tokens: {p.stderr}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    ap.add_argument("--sim", required=True)
    ap.add_argument("--openapi", required=True)
    args = ap.parse_args()

    contract = Contract(open(args.openapi).read())
    fx = Fixture("gw-api-test-")
    run = fx.run

    run("openapi document structure", contract.check_structure)

    try:
        ext1 = fx.start_sim(args.sim, "ext1", "plain", time_scale=20)
        control = ext1.control

        port = free_port()
        max_connections = 6
        config = {
            "http": {"listen_address": "127.0.0.1", "port": port,
                     "limits": {"max_body_bytes": 8192, "max_header_bytes": 4096,
                                "read_timeout_ms": 4000, "max_connections": max_connections}},
            "controllers": [{"id": "ext1", "port": ext1.link, "baud": 115200, "poll_ms": 0,
                             "command_timeout_ms": 500}],
            "simulate": {"count": 4, "time_scale": 20, "directory": os.path.join(fx.tmp, "sim")},
            "auth": auth_tokens(),
            "logging": {"level": "info"},
        }
        gw = fx.start_gateway(args.gateway, config)
        c = Client(port, contract)
        wait_until("gateway ready", lambda: c.request("GET", "/api/v1/ready", validate=False).status == 200)

        run("public endpoints", test_public_endpoints, c)
        run("dashboard assets", test_dashboard_assets, c)
        run("controllers", test_controllers, c)
        run("typed operations", test_operations, c)
        run("CRISP and autofocus", test_focus, c)
        run("raw command", test_raw_command, c)
        run("a reset or recalibration needs force, then identifies again", test_reset_needs_force, c)
        run("a slow operation does not block others", test_slow_operation_does_not_block_others, c)
        run("error kinds", test_errors, c)
        run("auth roles", test_auth, c)
        run("whoami", test_whoami, c)
        run("whoami without tokens", test_whoami_without_tokens, args.gateway, fx.tmp, contract)
        run("request ids", test_request_ids, c)
        run("unplug (503) and timeout (504)", test_unplug_and_timeout, c, control)
        run("metrics", test_metrics, c)
        run("websocket route", test_websocket_route, c)
        run("limits", test_limits, c, port, max_connections)
        run("public address without tokens refused", test_refuses_public_address_without_tokens, args.gateway,
            fx.tmp)

        # Graceful stop: SIGTERM closes an idle keep-alive connection and exits 0.
        idle = http.client.HTTPConnection("127.0.0.1", port, timeout=WAIT)
        idle.request("GET", "/api/v1/health")
        idle.getresponse().read()
        gw.terminate()
        try:
            closed = idle.sock.recv(1) == b""
        except OSError:
            closed = True
        idle.close()
        try:
            gw.wait(timeout=WAIT)
        except subprocess.TimeoutExpired:
            pass
        if not closed:
            fx.failures.append(("SIGTERM closes connections", Failure("an idle connection stayed open")))
        fx.expect_exit_0()
        fx.finish_log(60)
    finally:
        fx.cleanup()

    return fx.report(f"; {len(contract.covered)} (path, method, status) combinations validated against the schema")


if __name__ == "__main__":
    sys.exit(main())
