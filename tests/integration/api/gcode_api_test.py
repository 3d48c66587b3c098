#!/usr/bin/python3
"""End-to-end test of the G-code routes and the `gcode` subcommands: the real asi-gateway (no
controllers: planning needs none) with a temporary store, real HTTP clients, every response
validated against openapi/openapi.yaml (the Contract of http_api_test.py).

HTTP: plans of posted programs (moves, arcs, dwells, TTL, bounds; the same bytes as the CLI prints),
options as query parameters (scaling, moves=false, unknown and bad values naming the parameter),
422 invalid-gcode with line and column, uploads (list, get, plan, preview, delete, 404 unknown-file,
roles, the body limit: G-code bodies over http.limits.max_body_bytes accepted up to gcode.max_file_mb,
413 beyond), previews (well-formed SVG with the three styles, +Y up, views).
CLI: `gcode plan` exit 2 with the error JSON, bad --set exit 2 with a message, stdin, --summary,
`gcode preview`, and a generated 100 000-line program planned in bounded memory (the child's max RSS
from wait4, compared with a 10 000-line program: it must not grow with the program).

Run by ctest with Debian's /usr/bin/python3 (python3-yaml, python3-jsonschema).
Exit code 0 when every check passed; the failures are listed otherwise.
"""

import argparse
import json
import os
import subprocess
import sys
import xml.etree.ElementTree as ET


sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gateway_fixture import TOKENS, Fixture, auth_tokens, check, free_port  # noqa: E402
from http_api_test import Client, Contract  # noqa: E402
from ws_api_test import WsClient  # noqa: E402

OP = TOKENS["operator"]
VIEW = TOKENS["viewer"]
MAX_BODY = 256 * 1024   # http.limits.max_body_bytes of this test's gateway
MAX_FILE_MB = 2         # gcode.max_file_mb
SVG = "{http://www.w3.org/2000/svg}"

PROGRAM = """%
(a square with a rounded corner, a dwell and the laser on for two sides)
G21 G90
G00 X1 Y1
M03
G01 X5 F120
G02 X7 Y-1 I0 J-2
G01 Y-3
M05
G04 P250
G00 X0 Y0
%
"""

BAD_PROGRAM = "G21 G90\nG00 X1\nG28 X0\n"  # G28 is not in the Tracer subset: line 3, column 1


def post_program(c, path, program, token=VIEW, status=200, validate=True):
    r = c.request("POST", path, token=token, raw_body=program.encode(),
                  headers={"Content-Type": "text/plain"}, validate=validate)
    check(r.status == status, f"POST {path}: expected {status}, got {r.status}: {r.body[:300]}")
    return r


# --------------------------------------------------------------------------------------------
# HTTP


def test_plan(c):
    r = post_program(c, "/api/v1/gcode/plan", PROGRAM)
    check(r.header("Content-Type") == "application/json", f"content type {r.header('Content-Type')}")
    plan = r.json()
    kinds = [m["kind"] for m in plan["moves"]]
    check(kinds == ["rapid", "ttl", "linear", "arc", "linear", "ttl", "dwell", "rapid"], f"kinds {kinds}")
    arc = plan["moves"][3]
    check(arc["line"] == 7 and arc["plane"] == "XY" and arc["direction"] == "cw", f"arc {arc}")
    check(arc["center"] == [5, -1, 0] and arc["end"] == [7, -1, 0], f"arc geometry {arc}")
    check(abs(arc["feed_mm_s"] - 2) < 1e-9, f"F120 mm/min is 2 mm/s: {arc}")
    check(plan["moves"][6] == {"line": 10, "kind": "dwell", "dwell_ms": 250}, f"dwell {plan['moves'][6]}")
    check(plan["moves"][1]["ttl"] == "on" and plan["moves"][5]["ttl"] == "off", "ttl switches")
    # A quarter circle of radius 2 at 1 um chord error needs more than 20 segments; lines are 1 each.
    check(plan["segments"] > 4 + 20, f"segments {plan['segments']}")
    check(plan["bounds"]["min"] == [0, -3, 0], f"bounds min {plan['bounds']}")
    check(abs(plan["bounds"]["max"][0] - 7) < 1e-6 and plan["bounds"]["max"][1] == 1, f"bounds max {plan['bounds']}")
    # 0.25 s dwell + 4 mm at 2 mm/s + the arc and the rest: more than 2.25 s
    check(plan["estimated_s"] > 2.25, f"estimated_s {plan['estimated_s']}")


def test_plan_options(c):
    base = post_program(c, "/api/v1/gcode/plan", PROGRAM).json()
    scaled = post_program(c, "/api/v1/gcode/plan?xyz_scale=2&speed_scale=0.5", PROGRAM).json()
    check(scaled["moves"][2]["end"] == [10, 2, 0], f"xyz_scale=2: {scaled['moves'][2]}")
    check(abs(scaled["moves"][2]["feed_mm_s"] - 1) < 1e-9, f"speed_scale=0.5: {scaled['moves'][2]}")
    # A twice longer path at half the feed: four times the motion; the dwell and the host's cost per
    # segment (serial round trips, STATUS polling) do not scale, so a bit less than four times overall.
    check(scaled["estimated_s"] > base["estimated_s"] * 2.5, "a twice longer path at half the feed")
    s = post_program(c, "/api/v1/gcode/plan?moves=false", PROGRAM).json()
    check("moves" not in s and s["move_count"] == 8 and s["lines"] == 12, f"summary {s}")
    check(s["segments"] == base["segments"] and s["estimated_s"] == base["estimated_s"], "summary totals")
    for query, field in [("bogus=1", "bogus"), ("xyz_scale=-1", "xyz_scale"), ("z_mode=sideways", "z_mode"),
                         ("moves=maybe", "moves"), ("view=XY", "view")]:
        p = c.problem("POST", "/api/v1/gcode/plan?" + query, 422, "invalid-value", token=VIEW,
                      raw_body=PROGRAM.encode())
        check(p.get("field") == field, f"{query}: field {p.get('field')} ({p['detail']})")


def test_program_error(c):
    r = post_program(c, "/api/v1/gcode/plan", BAD_PROGRAM, status=422)
    check(r.header("Content-Type") == "application/problem+json", "problem content type")
    p = r.json()
    check(p["type"] == "https://asi-gateway.dev/problems/invalid-gcode", f"type {p['type']}")
    check(p["line"] == 3 and p["column"] == 1 and "G28" in p["message"], f"error place {p}")
    # The same program through the preview: the same error.
    r = post_program(c, "/api/v1/gcode/preview.svg", BAD_PROGRAM, status=422)
    check(r.json()["line"] == 3, f"preview error {r.body}")


def test_preview(c):
    program = PROGRAM.replace("G04 P250\n", "G04 P250\nG01 X9\n")  # a feed move with the TTL off
    r = post_program(c, "/api/v1/gcode/preview.svg", program)
    check(r.header("Content-Type") == "image/svg+xml", f"content type {r.header('Content-Type')}")
    root = ET.fromstring(r.body)  # well-formed
    check(root.tag == SVG + "svg", f"root {root.tag}")
    paths = {}
    for p in root.iter(SVG + "path"):
        paths.setdefault(p.get("class"), []).append(p.get("d"))
    check(set(paths) == {"feed", "rapid", "ttl"}, f"path classes {sorted(paths)}")
    check("stroke-dasharray" in r.body, "rapid moves dashed")
    # The first TTL stretch starts at (1, 1) and goes right: x grows, y stays; the arc goes down (+y).
    pts = [tuple(map(float, p.split())) for p in paths["ttl"][0][1:].replace("L", "M").split("M") if p]
    check(pts[1][0] > pts[0][0] and pts[1][1] == pts[0][1], f"ttl path {pts[:3]}")
    check(pts[-1][1] > pts[0][1], "Y-3 is below Y1 on the page (+Y up)")
    r = post_program(c, "/api/v1/gcode/preview.svg?view=ZX&width_px=300", PROGRAM)
    check('width="300"' in r.body or 'height="300"' in r.body, "width_px")
    c.problem("POST", "/api/v1/gcode/preview.svg?view=XZ", 422, "invalid-value", token=VIEW,
              raw_body=PROGRAM.encode())
    c.problem("GET", "/api/v1/gcode/preview.svg", 405, "method-not-allowed", token=VIEW)


def test_files(c):
    c.problem("POST", "/api/v1/gcode/files", 403, "forbidden", token=VIEW, raw_body=PROGRAM.encode())
    r = post_program(c, "/api/v1/gcode/files?name=square.ngc", PROGRAM, token=OP, status=201)
    f = r.json()
    check(f["name"] == "square.ngc" and f["bytes"] == len(PROGRAM.encode()) and f["lines"] == 12, f"file {f}")
    check(r.header("Location") == "/api/v1/gcode/files/" + f["id"], f"Location {r.header('Location')}")
    r2 = post_program(c, "/api/v1/gcode/files", BAD_PROGRAM, token=OP, status=201)  # stored unchecked
    bad = r2.json()
    check(bad["name"] == "untitled", f"default name {bad}")

    listed = c.request("GET", "/api/v1/gcode/files", token=VIEW).json()["files"]
    check([x["id"] for x in listed] == [bad["id"], f["id"]], f"list newest first: {listed}")
    check(c.request("GET", "/api/v1/gcode/files/" + f["id"], token=VIEW).json() == f, "get = upload answer")

    inline = post_program(c, "/api/v1/gcode/plan", PROGRAM).body
    stored = c.request("POST", f"/api/v1/gcode/files/{f['id']}/plan", token=VIEW)
    check(stored.status == 200 and stored.body == inline, "the stored program plans as the posted one")
    r = c.request("POST", f"/api/v1/gcode/files/{bad['id']}/plan", token=VIEW)
    check(r.status == 422 and r.json()["line"] == 3, f"plan of the bad upload: {r.status} {r.body[:200]}")
    r = c.request("POST", f"/api/v1/gcode/files/{f['id']}/plan?moves=false", token=VIEW)
    check(r.status == 200 and r.json()["move_count"] == 8, f"summary of a file: {r.body[:200]}")
    r = c.request("GET", f"/api/v1/gcode/files/{f['id']}/preview.svg?view=XY", token=VIEW)
    check(r.status == 200 and ET.fromstring(r.body).tag == SVG + "svg", f"file preview {r.status}")

    c.problem("DELETE", "/api/v1/gcode/files/" + f["id"], 403, "forbidden", token=VIEW)
    r = c.request("DELETE", "/api/v1/gcode/files/" + f["id"], token=OP, validate=False)  # 204: no body
    check(r.status == 204 and r.body == "", f"delete: {r.status} {r.body}")
    for method, path in [("GET", f["id"]), ("DELETE", f["id"]), ("POST", f["id"] + "/plan"),
                         ("GET", f["id"] + "/preview.svg"), ("GET", "g-nope"), ("GET", "..%2F..%2Fetc")]:
        c.problem(method, "/api/v1/gcode/files/" + path, 404, "unknown-file", token=OP)
    listed = c.request("GET", "/api/v1/gcode/files", token=VIEW).json()["files"]
    check([x["id"] for x in listed] == [bad["id"]], f"after delete: {listed}")
    c.problem("GET", "/api/v1/gcode/files?name=x", 422, "invalid-value", token=VIEW)
    c.problem("PUT", "/api/v1/gcode/files", 405, "method-not-allowed", token=OP)
    c.problem("POST", "/api/v1/gcode/files?name=a%0Ab", 422, "invalid-value", token=OP, raw_body=b"G00 X1\n")


def test_websocket_check(c, port):
    """An uploaded program checked over the WebSocket: the REST summary, the REST errors."""
    f = post_program(c, "/api/v1/gcode/files?name=square.ngc", PROGRAM, token=OP, status=201).json()
    bad = post_program(c, "/api/v1/gcode/files?name=bad.ngc", BAD_PROGRAM, token=OP, status=201).json()
    ws = WsClient(port, VIEW, "gcode")
    try:
        rest = c.request("POST", f"/api/v1/gcode/files/{f['id']}/plan?moves=false&xyz_scale=0.5", token=VIEW)
        ans = ws.request({"op": "gcode", "id": "g1", "action": "check", "file": f["id"],
                          "options": {"xyz_scale": 0.5}})
        check(ans["type"] == "result" and ans["result"] == rest.json(), f"check {ans} against REST {rest.body}")
        err = ws.request({"op": "gcode", "id": "g2", "action": "check", "file": bad["id"]})
        p = err.get("problem", {})
        check(err["type"] == "error" and p.get("type", "").endswith("/invalid-gcode") and p.get("line") == 3
              and p.get("column") == 1 and "G28" in p.get("message", ""), f"bad program: {err}")
        err = ws.request({"op": "gcode", "id": "g3", "action": "check", "file": f["id"],
                          "options": {"moves": True}})
        check(err["type"] == "error" and err["problem"]["field"] == "options.moves", f"moves option: {err}")
        err = ws.request({"op": "gcode", "id": "g4", "action": "check", "file": "g-00000000000000000000000000"})
        check(err["type"] == "error" and err["problem"]["status"] == 404, f"unknown file: {err}")
    finally:
        ws.close()


def big_program(lines):
    """A program of `lines` lines: lines, arcs, dwells and TTL switches in turn."""
    out = ["G21 G90 G01 F600"]
    for i in range(lines - 1):
        k = i % 8
        y = (i // 8) * 0.01
        if k == 0:
            out.append(f"G01 X10 Y{y:.3f}")
        elif k == 1:
            out.append("M03")
        elif k == 2:
            out.append(f"G02 X10 Y{y + 2:.3f} I0 J1")
        elif k == 3:
            out.append("M05")
        elif k == 4:
            out.append(f"G01 X0 Y{y + 2:.3f}")
        elif k == 5:
            out.append("G04 P1")
        elif k == 6:
            out.append(f"G00 X0 Y{y:.3f}")
        else:
            out.append(f"G01 X5 Y{y:.3f}")
    return "\n".join(out) + "\n"


def test_body_limits(c):
    # Over http.limits.max_body_bytes but under gcode.max_file_mb: accepted on the G-code routes only.
    program = big_program(40000)
    size = len(program)
    check(MAX_BODY < size < MAX_FILE_MB * 1024 * 1024, f"test program size {size}")
    r = post_program(c, "/api/v1/gcode/files?name=big.ngc", program, token=OP, status=201)
    check(r.json()["bytes"] == size and r.json()["lines"] == 40000, f"big upload {r.json()}")
    r = post_program(c, "/api/v1/gcode/plan?moves=false", program)
    check(r.json()["move_count"] > 30000, f"big plan {r.json()}")
    c.problem("POST", "/api/v1/jobs", 413, "payload-too-large", token=OP, raw_body=b"{" + b" " * size + b"}",
              headers={"Content-Type": "application/json"})
    too_big = b"G04 P1\n" * (MAX_FILE_MB * 1024 * 1024 // 7 + 10)
    c.problem("POST", "/api/v1/gcode/files", 413, "payload-too-large", token=OP, raw_body=too_big)
    c.request("DELETE", "/api/v1/gcode/files/" + r.json().get("id", "x"), token=OP, validate=False)


# --------------------------------------------------------------------------------------------
# The command line


def run_cli(gateway, args, stdin=None):
    """(exit code, stdout, stderr) of `asi-gateway gcode ...`."""
    p = subprocess.run([gateway, "gcode", *args], input=stdin, capture_output=True, timeout=300,
                       stdin=None if stdin is not None else subprocess.DEVNULL)
    return p.returncode, p.stdout.decode(), p.stderr.decode()


def rss_kib(gateway, args, tmp):
    """Exit code and max RSS (KiB) of one run whose stdout goes to /dev/null. Measured by GNU time: a
    child forked (or vforked) from this Python process would count Python's own RSS too (Linux keeps
    the pre-exec high-water mark in ru_maxrss)."""
    report = os.path.join(tmp, "time.txt")
    # Under AddressSanitizer freed memory waits in a quarantine (256 MB) and would look like growth.
    env = dict(os.environ)
    env["ASAN_OPTIONS"] = ":".join(filter(None, [env.get("ASAN_OPTIONS", ""), "quarantine_size_mb=0"]))
    with open(os.devnull, "wb") as null:
        code = subprocess.run(["/usr/bin/time", "-f", "%M", "-o", report, gateway, "gcode", *args],
                              stdout=null, stderr=subprocess.DEVNULL, env=env).returncode
    with open(report) as f:
        return code, int(f.read().split()[-1])


def test_cli(gateway, c, tmp):
    good = os.path.join(tmp, "square.ngc")
    bad = os.path.join(tmp, "bad.ngc")
    with open(good, "w") as f:
        f.write(PROGRAM)
    with open(bad, "w") as f:
        f.write(BAD_PROGRAM)
    code, out, err = run_cli(gateway, ["plan", good])
    check(code == 0, f"plan exit {code}: {err}")
    http_plan = post_program(c, "/api/v1/gcode/plan", PROGRAM).body
    check(out.strip() == http_plan, "the CLI prints what the API answers")
    check(c.contract.validator({"$ref": "#/components/schemas/GcodePlan"}).is_valid(json.loads(out)), "CLI plan schema")

    code, out, err = run_cli(gateway, ["plan", bad])
    check(code == 2, f"bad program exit {code}")
    e = json.loads(out)
    check(c.contract.validator({"$ref": "#/components/schemas/GcodeError"}).is_valid(e), f"error schema {e}")
    check(e["error"]["line"] == 3 and e["error"]["column"] == 1, f"error {e}")

    code, out, err = run_cli(gateway, ["plan", good, "--set", "xyz_scale=zero"])
    check(code == 2 and "xyz_scale" in err and out == "", f"bad --set: {code} {err!r} {out[:80]!r}")
    code, out, err = run_cli(gateway, ["plan", good, "--set", "nonsense"])
    check(code == 2 and "NAME=VALUE" in err, f"--set without '=': {code} {err!r}")
    code, out, err = run_cli(gateway, ["plan", os.path.join(tmp, "missing.ngc")])
    check(code == 2 and "missing.ngc" in err, f"missing file: {code} {err!r}")

    code, out, err = run_cli(gateway, ["plan", "-", "--set", "xyz_scale=2"], stdin=PROGRAM.encode())
    check(code == 0 and json.loads(out)["moves"][2]["end"] == [10, 2, 0], f"stdin: {code} {err}")
    code, out, err = run_cli(gateway, ["plan", "-"], stdin=BAD_PROGRAM.encode())
    check(code == 2 and json.loads(out)["error"]["line"] == 3, f"stdin error: {code} {out!r}")
    code, out, err = run_cli(gateway, ["plan", "--summary", good])
    check(code == 0 and json.loads(out)["move_count"] == 8, f"--summary: {code} {out!r}")
    code, out, err = run_cli(gateway, ["preview", good, "--set", "view=ZX"])
    check(code == 0 and ET.fromstring(out).tag == SVG + "svg", f"preview: {code} {err}")
    code, out, err = run_cli(gateway, ["preview", bad])
    check(code == 2 and json.loads(err)["error"]["line"] == 3, f"preview error: {code} {err!r}")


def sanitized(gateway):
    """True for a build with AddressSanitizer (scripts/test --sanitize)."""
    with open(gateway, "rb") as f:
        return b"__asan_init" in f.read()


def test_cli_bounded_memory(gateway, tmp):
    small = os.path.join(tmp, "small.ngc")
    large = os.path.join(tmp, "large.ngc")
    with open(small, "w") as f:
        f.write(big_program(10000))
    with open(large, "w") as f:
        f.write(big_program(100000))
    check(os.path.exists("/usr/bin/time"), "/usr/bin/time (Debian package time) is needed")
    code_s, rss_s = rss_kib(gateway, ["plan", small], tmp)
    code_l, rss_l = rss_kib(gateway, ["plan", large], tmp)
    check(code_s == 0 and code_l == 0, f"exit codes {code_s} {code_l}")
    print(f"       max RSS: 10k lines {rss_s} KiB, 100k lines {rss_l} KiB")
    # Ten times the program, (nearly) the same memory: nothing grows with the program.
    check(rss_l < rss_s + 2048, f"100k lines used {rss_l} KiB, 10k lines {rss_s} KiB")
    if not sanitized(gateway):  # ASan's shadow memory and runtime alone take ~230 MB
        check(rss_l < 32 * 1024, f"100k lines used {rss_l} KiB")
    # And the output is complete: the last move is the program's last line.
    code, out, err = run_cli(gateway, ["plan", large])
    plan = json.loads(out)
    check(code == 0 and plan["moves"][-1]["line"] == 100000, f"last move {plan['moves'][-1]}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    ap.add_argument("--openapi", required=True)
    args = ap.parse_args()
    with open(args.openapi) as f:
        contract = Contract(f.read())

    fx = Fixture("gw-gcode-api-")
    try:
        fx.run("openapi document", contract.check_structure)
        port = free_port()
        config = {"http": {"port": port, "limits": {"max_body_bytes": MAX_BODY}},
                  "storage": {"path": os.path.join(fx.tmp, "store")},
                  "gcode": {"max_file_mb": MAX_FILE_MB},
                  "auth": auth_tokens()}
        fx.start_gateway(args.gateway, config)
        c = Client(port, contract)
        fx.run("plan", test_plan, c)
        fx.run("plan options", test_plan_options, c)
        fx.run("program error", test_program_error, c)
        fx.run("preview", test_preview, c)
        fx.run("uploaded files", test_files, c)
        fx.run("check over the WebSocket", test_websocket_check, c, port)
        fx.run("body limits", test_body_limits, c)
        fx.run("cli", test_cli, args.gateway, c, fx.tmp)
        fx.run("cli bounded memory", test_cli_bounded_memory, args.gateway, fx.tmp)
        fx.gateway.terminate()
        fx.expect_exit_0()
        fx.finish_log(40)
    finally:
        fx.cleanup()
    return fx.report()


if __name__ == "__main__":
    sys.exit(main())
