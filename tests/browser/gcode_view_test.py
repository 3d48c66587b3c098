#!/usr/bin/python3
"""The dashboard's G-code view and API docs page in a real headless browser (Debian's chromium over
the Chrome DevTools Protocol, cdp.py) against the real asi-gateway with one simulated controller
(in-process, time scale 2).

Checks: a program (a rectangle with an arc, the TTL output on along part of it) uploaded through the
page's file input shows in the file list, with the gateway's preview on the map and the plan summary
whose bounds match the REST plan; a dry run from the page shows the estimate; Run starts a gcode job
whose traced path grows while it runs and that ends succeeded (page and REST agree); every traced
point lies on the preview's drawn path (the image's own coordinates mapped to the map), the TTL-on
stretches on its red (TTL) path, in their own colour; a pasted program with an error shows it with
its line; Delete (two clicks) removes the upload; a pasted program runs, and the view finds the
running job again (its program, its trace from then on) after the user left it and came back; the API docs page renders every path and every
operation of the OpenAPI document, its schemas, and the GcodeOptions $ref resolved into query
parameters; no console errors other than the 422s the bad program causes by design.
With --screenshot-dir, writes gcode-trace.png (the trace part way, over the preview) and api-docs.png
there.

Run by ctest with Debian's /usr/bin/python3 (python3-websockets, python3-yaml). Skipped (exit 77)
without chromium.
"""

import asyncio
import http.client
import json
import math
import os
import re
import sys
import time

import yaml

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "integration", "api"))
import browser_checks  # noqa: E402
from cdp import Browser, find_chromium  # noqa: E402
from gateway_fixture import check, free_port, http_request, wait_until  # noqa: E402

# A 4 x 5 mm rectangle from (1, 1) with its upper right corner rounded (a quarter circle of radius 2):
# the TTL output is on along the bottom edge, the right edge and the arc (lines 4-6), off for the rest.
PROGRAM = """G21 G90
G00 X1 Y1
M03
G01 X5 Y1 F240
G01 X5 Y4
G03 X3 Y6 I-2 J0
M05
G01 X1 Y6
G01 X1 Y1
G00 X0 Y0
"""
# A 4 mm square at 2 mm/s with the TTL output on along it: about 4 s at time scale 2.
SQUARE = "G21 G90\nG00 X0.5 Y0.5\nM03\nG01 X4.5 F120\nY4.5\nX0.5\nY0.5\nM05\nG00 X0 Y0\n"
BAD_PROGRAM = "G21\nG00 X1\nG28 X0\n"
TOLERANCE_PX = 4.0  # traced point to the preview's path, in map pixels (about 40 um here)


def rest(port, method, path, body=None):
    status, text = http_request(port, method, path, body, token=None)
    return status, (json.loads(text) if text and text.lstrip().startswith("{") else text)


def rest_text(port, method, path, text=None):
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
    conn.request(method, path, body=text, headers={"Content-Type": "text/plain"} if text is not None else {})
    r = conn.getresponse()
    out = r.read().decode()
    conn.close()
    return r.status, out


def svg_paths(svg_text):
    """The preview's drawn paths: [(class, [(x, y), ...]), ...] in the SVG's own pixels, and its size."""
    size = re.search(r'<svg[^>]*\bwidth="([\d.]+)"[^>]*\bheight="([\d.]+)"', svg_text)
    paths = []
    for m in re.finditer(r'<path class="(\w+)" d="([^"]+)"', svg_text):
        nums = [float(v) for v in re.findall(r"-?[\d.]+", m.group(2))]
        paths.append((m.group(1), list(zip(nums[0::2], nums[1::2]))))
    return (float(size.group(1)), float(size.group(2))), paths


def distance_to_segment(p, a, b):
    ax, ay = a
    bx, by = b
    dx, dy = bx - ax, by - ay
    length2 = dx * dx + dy * dy
    t = 0.0 if length2 == 0 else max(0.0, min(1.0, ((p[0] - ax) * dx + (p[1] - ay) * dy) / length2))
    return math.hypot(p[0] - (ax + t * dx), p[1] - (ay + t * dy))


def distance_to_paths(p, polylines):
    return min((distance_to_segment(p, a, b) for line in polylines for a, b in zip(line, line[1:])),
               default=math.inf)


def parse_points(text):
    return [tuple(float(v) for v in pair.split(",")) for pair in (text or "").split()]


async def set_file_input(b, selector, path):
    doc = await b.call("DOM.getDocument", depth=0)
    node = await b.call("DOM.querySelector", nodeId=doc["root"]["nodeId"], selector=selector)
    check(node.get("nodeId"), f"no element {selector}")
    await b.call("DOM.setFileInputFiles", files=[path], nodeId=node["nodeId"])


async def test_upload_preview(b, fx, port, state):
    path = os.path.join(fx.tmp, "rounded-rect.ngc")
    with open(path, "w") as f:
        f.write(PROGRAM)
    await b.navigate(f"http://127.0.0.1:{port}/#/gcode")
    await b.wait_for("the G-code view, live", "document.body.dataset.live === 'yes' && !!document.getElementById('gcode')")
    await set_file_input(b, "#gcode-file", path)
    await b.wait_for("the upload chosen and planned", "document.getElementById('gcode').dataset.plan === 'ready'")
    row = await b.wait_for("the upload listed and selected",
                           "document.querySelector('#gcode-files tr.selected')?.dataset.file")
    status, listing = rest(port, "GET", "/api/v1/gcode/files")
    check(status == 200, f"GET files: {status}")
    mine = [f for f in listing["files"] if f["id"] == row]
    check(mine and mine[0]["name"] == "rounded-rect.ngc" and mine[0]["lines"] == PROGRAM.count("\n"),
          f"the selected row {row} is not the upload: {listing}")
    state["file"] = row

    status, plan = rest(port, "POST", f"/api/v1/gcode/files/{row}/plan")
    check(status == 200, f"REST plan: {status} {plan}")
    shown = await b.evaluate("Object.fromEntries([...document.querySelectorAll('#gcode-summary dd')]"
                             ".map(d => [d.dataset.key, d.textContent]))")
    for i, axis in enumerate("XY"):
        lo, hi = plan["bounds"]["min"][i], plan["bounds"]["max"][i]
        check(shown.get(f"{axis} range") == f"{lo:.3f} mm … {hi:.3f} mm",
              f"{axis} range on the page {shown.get(f'{axis} range')!r}, REST bounds {lo}..{hi}")
    check(shown.get("Segments") == str(plan["segments"]), f"segments {shown.get('Segments')} vs {plan['segments']}")
    check(shown.get("Moves") == str(len(plan["moves"])), f"moves {shown.get('Moves')} vs {len(plan['moves'])}")
    check(re.fullmatch(r"\d+\.\d s", shown.get("Estimated", "")), f"estimate {shown.get('Estimated')!r}")
    image = await b.evaluate("(() => { const i = document.querySelector('#gcode image.gcode-preview');"
                             " return i && {href: i.getAttribute('href').slice(0, 40), w: +i.getAttribute('width'),"
                             " h: +i.getAttribute('height')}; })()")
    check(image and image["href"].startswith("data:image/svg+xml") and image["w"] > 100 and image["h"] > 100,
          f"the preview image on the map: {image}")


async def test_dry_run(b, port, state):
    await b.evaluate("document.getElementById('gcode-controller').value = 'sim1'")
    await b.click("#gcode-dry-run")
    shown = await b.wait_for("the dry run's estimate", "document.querySelector('#gcode-estimate [data-estimate]')"
                             "?.dataset.estimate")
    status, dry = rest(port, "POST", "/api/v1/jobs?dry_run=true",
                       {"controller": "sim1", "type": "gcode", "spec": {"file": state["file"]}})
    check(status == 200, f"REST dry run: {status} {dry}")
    check(abs(float(shown) - dry["plan"]["estimated_s"]) < 0.5, f"estimate {shown} vs REST {dry['plan']['estimated_s']}")
    check(not await b.evaluate("document.getElementById('gcode-run').disabled"), "Run is still disabled")


async def test_run_and_trace(b, port, state, screenshot=None):
    await b.click("#gcode-run")
    await b.wait_for("the job started", "document.getElementById('gcode').dataset.jobState")
    counts = []
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        s = await b.evaluate("(() => { const g = document.getElementById('gcode');"
                             " const bar = document.querySelector('#gcode-progress [role=progressbar]');"
                             " return [g.dataset.jobState, +(g.dataset.traced || 0), +(bar?.getAttribute('aria-valuenow') || 0)]; })()")
        counts.append(s[:2])
        if s[0] in ("succeeded", "failed", "cancelled", "interrupted"):
            break
        if screenshot and s[0] == "running" and s[2] >= 60:
            await b.screenshot(screenshot)  # the trace part way over the preview
            print(f"screenshot: {screenshot}")
            screenshot = None
        await asyncio.sleep(0.1)
    final, traced = counts[-1]
    progress = await b.evaluate("document.getElementById('gcode-progress').textContent")
    check(final == "succeeded", f"the job ended {final}: {progress}")
    running = sorted({n for st, n in counts if st == "running"})
    check(len(running) >= 5, f"the traced path did not grow while running: point counts seen {running}")
    check(traced >= 15, f"only {traced} traced points")
    job_id = await b.evaluate("document.getElementById('gcode-job-link').textContent")
    status, job = rest(port, "GET", f"/api/v1/jobs/{job_id}")
    check(status == 200 and job["state"] == "succeeded" and job["type"] == "gcode", f"REST job: {status} {job}")
    line = await b.evaluate("document.getElementById('gcode-line').textContent")
    last_line = PROGRAM.count("\n")
    check(line == f"line {last_line} of {last_line}", f"progress line {line!r}")
    link = await b.evaluate("document.getElementById('gcode-job-link').getAttribute('href')")
    check(link == f"#/jobs/{job_id}", f"job link {link}")
    state["job"] = job_id


async def test_trace_on_path(b, port, state):
    status, svg_text = rest_text(port, "GET", f"/api/v1/gcode/files/{state['file']}/preview.svg?width_px=400")
    check(status == 200, f"preview.svg: {status}")
    (sw, sh), paths = svg_paths(svg_text)
    check(paths and any(c == "ttl" for c, _ in paths), f"the preview has no TTL path: {svg_text[:400]}")
    geo = await b.evaluate("(() => { const i = document.querySelector('#gcode image.gcode-preview');"
                           " return ['x', 'y', 'width', 'height'].map(k => +i.getAttribute(k)); })()")
    x0, y0, w, h = geo
    check(abs(w / h - sw / sh) < 0.01, f"the image is stretched: {w}x{h} for an SVG of {sw}x{sh}")
    to_map = [[(x0 + px * w / sw, y0 + py * h / sh) for px, py in pts] for _, pts in paths]
    ttl_lines = [line for (c, _), line in zip(paths, to_map) if c == "ttl"]
    overlays = await b.evaluate("[...document.querySelectorAll('#gcode polyline.xy-traced')]"
                                ".map(p => [p.classList.contains('ttl-on'), p.getAttribute('points')])")
    check(any(on for on, _ in overlays) and any(not on for on, _ in overlays),
          f"the trace has no TTL-on and TTL-off stretches: {[on for on, _ in overlays]}")
    worst = 0.0
    for on, text in overlays:
        for p in parse_points(text):
            d = distance_to_paths(p, to_map)
            worst = max(worst, d)
            check(d <= TOLERANCE_PX, f"traced point {p} is {d:.1f} px from the preview's path")
            if on:
                dt = distance_to_paths(p, ttl_lines)
                check(dt <= TOLERANCE_PX, f"TTL-on traced point {p} is {dt:.1f} px from the TTL path (stretches: {overlays})")
    print(f"       traced points within {worst:.2f} px of the preview's path "
          f"({sum(len(parse_points(t)) for _, t in overlays)} points, {len(overlays)} stretches)")


async def test_bad_program(b, port):
    await b.evaluate(f"document.getElementById('gcode-text').value = {json.dumps(BAD_PROGRAM)}")
    await b.click("#gcode-check")
    await b.wait_for("the plan error", "document.getElementById('gcode').dataset.plan === 'error'")
    err = await b.evaluate("(() => { const e = document.getElementById('gcode-error');"
                           " return !e.hidden && [e.dataset.line, e.textContent]; })()")
    check(err and err[0] == "3" and "Line 3, column 1" in err[1] and "G28" in err[1] and "G28 X0" in err[1],
          f"the error shown: {err}")
    check(await b.evaluate("document.getElementById('gcode-dry-run').disabled"), "dry run enabled for a bad program")


async def test_delete(b, port, state):
    sel = f"#gcode-files tr[data-file='{state['file']}'] button.danger"
    await b.click(sel)
    armed = await b.evaluate(f"document.querySelector(\"{sel}\").textContent")
    check(armed == "Really delete?", f"first click: {armed!r}")
    await b.click(sel)
    await b.wait_for("the row gone", f"!document.querySelector(\"#gcode-files tr[data-file='{state['file']}']\")")
    status, _ = rest(port, "GET", f"/api/v1/gcode/files/{state['file']}")
    check(status == 404, f"GET the deleted file: {status}")


async def test_docs(b, port):
    status, text = rest_text(port, "GET", "/api/v1/openapi.yaml")
    check(status == 200, f"openapi.yaml without a token: {status}")
    doc = yaml.safe_load(text)
    methods = {"get", "put", "post", "patch", "delete", "head", "options"}
    ops = sorted((p, m) for p, item in doc["paths"].items() for m in item if m in methods)
    await b.navigate(f"http://127.0.0.1:{port}/dashboard/docs.html")
    await b.wait_for("the docs rendered", "document.body.dataset.docs")
    text = await b.evaluate("document.getElementById('docs').textContent.slice(0, 300)")
    check(await b.evaluate("document.body.dataset.docs") == "ready", f"docs: {text}")
    shown = await b.evaluate("[...document.querySelectorAll('section.op')].map(s => [s.dataset.path, s.dataset.method])")
    check(sorted(map(tuple, shown)) == ops, f"operations shown {len(shown)}, in the document {len(ops)}: "
          f"missing {sorted(set(ops) - set(map(tuple, shown)))[:5]}")
    paths = await b.evaluate("new Set([...document.querySelectorAll('section.op')].map(s => s.dataset.path)).size")
    check(paths == len(doc["paths"]), f"{paths} paths shown, {len(doc['paths'])} in the document")
    toc = await b.evaluate("document.querySelectorAll('#docs-toc a[href^=\"#op-\"]').length")
    check(toc == len(ops), f"{toc} operations in the table of contents")
    schemas = await b.evaluate("document.querySelectorAll('section.schema').length")
    check(schemas == len(doc["components"]["schemas"]), f"{schemas} schemas shown of {len(doc['components']['schemas'])}")
    # GcodeOptions ($ref to a parameter whose object schema is sent as one query parameter per property).
    params = await b.evaluate("[...document.querySelectorAll('#op-planGcode table.params td.prop-name code')]"
                              ".map(c => c.textContent)")
    check("xyz_scale" in params and "moves" in params and "arc_tolerance_mm" in params, f"planGcode parameters {params}")
    broken = await b.evaluate("[...document.querySelectorAll('a[href^=\"#\"]')].map(a => a.getAttribute('href').slice(1))"
                              ".filter(id => id && !document.getElementById(id))")
    check(not broken, f"in-page links to nothing: {broken[:5]}")
    body = await b.evaluate("document.getElementById('docs').textContent")
    check("undefined" not in body and "[object Object]" not in body, "the docs show undefined or [object Object]")
    role = await b.evaluate("document.querySelector('#op-uploadGcodeFile .role')?.textContent")
    check(role == "operator", f"uploadGcodeFile role {role!r}")


async def test_pasted_run_reattach(b, port):
    await b.evaluate(f"document.getElementById('gcode-text').value = {json.dumps(SQUARE)}")
    await b.click("#gcode-check")
    await b.wait_for("the pasted program planned", "document.getElementById('gcode').dataset.plan === 'ready'")
    await b.click("#gcode-dry-run")
    await b.wait_for("the dry run", "!document.getElementById('gcode-run').disabled")
    await b.click("#gcode-run")
    await b.wait_for("tracing", "document.getElementById('gcode').dataset.jobState === 'running' && "
                     "+document.getElementById('gcode').dataset.traced >= 2")
    job_id = await b.evaluate("document.getElementById('gcode-job-link').textContent")
    await b.evaluate("location.hash = '#/'")
    await b.wait_for("the overview", "!!document.getElementById('cards')")
    await b.evaluate("location.hash = '#/gcode'")
    await b.wait_for("the running job found again", "document.getElementById('gcode-job-link')?.textContent === "
                     f"{json.dumps(job_id)} && document.getElementById('gcode').dataset.plan === 'ready'")
    text = await b.evaluate("document.getElementById('gcode-text').value")
    check(text == SQUARE, f"the job's program is not shown again: {text!r}")
    final = await b.wait_for("the job ended", "(() => { const s = document.getElementById('gcode').dataset.jobState;"
                             " return ['succeeded', 'failed', 'cancelled'].includes(s) && s; })()")
    traced = await b.evaluate("+document.getElementById('gcode').dataset.traced")
    check(final == "succeeded" and traced >= 3, f"after coming back: {final}, {traced} traced points")
    status, job = rest(port, "GET", f"/api/v1/jobs/{job_id}")
    check(status == 200 and job["state"] == "succeeded" and job["spec"].get("program") == SQUARE, f"REST job: {job}")


def unexpected_console(entries):
    def lease_or_whoami_404(text, url):  # a free controller's lease; /whoami on a gateway without it yet
        return "status of 404" in text and (url.endswith("/lease") or url.endswith("/whoami"))

    def bad_program_422(text, url):  # the bad program, by design
        return "status of 422" in text and re.search(r"/api/v1/gcode/(plan|preview\.svg)", url)

    return browser_checks.unexpected_console(entries, lease_or_whoami_404, bad_program_422)


async def main_async(args, fx):
    if args.screenshot_dir:
        os.makedirs(args.screenshot_dir, exist_ok=True)
    chromium = find_chromium()
    port = free_port()
    config = {
        "http": {"listen_address": "127.0.0.1", "port": port},
        "simulate": {"count": 1, "time_scale": 2, "directory": os.path.join(fx.tmp, "sim")},
        "storage": {"path": os.path.join(fx.tmp, "store")},
        "logging": {"level": "info"},
    }
    fx.start_gateway(args.gateway, config)
    b = Browser(chromium, os.path.join(fx.tmp, "profile"), free_port())
    state = {}
    try:
        await b.connect()
        checks = browser_checks.Checks(fx, b, also_catch=(KeyError,))
        run = checks.run
        started = time.monotonic()
        if await run("upload from the page: listed, preview and summary match the REST plan",
                     test_upload_preview, b, fx, port, state):
            await run("a dry run from the page shows the estimate", test_dry_run, b, port, state)
            shot = os.path.join(args.screenshot_dir, "gcode-trace.png") if args.screenshot_dir else None
            if await run("Run: the trace grows while it runs and the job ends succeeded", test_run_and_trace, b, port,
                         state, shot):
                await run("the trace lies on the preview's path, TTL-on on the TTL path", test_trace_on_path, b, port, state)
            await run("a program error shows with its line", test_bad_program, b, port)
            await run("delete an upload (two clicks)", test_delete, b, port, state)
            await run("a pasted program runs; the view finds its job again after leaving", test_pasted_run_reattach,
                      b, port)
        await run("the API docs page renders every path of openapi.yaml", test_docs, b, port)
        if args.screenshot_dir:
            out = os.path.join(args.screenshot_dir, "api-docs.png")
            await b.screenshot(out)
            print(f"screenshot: {out}")
        checks.console_check(unexpected_console(b.console))
        print(f"browser part: {time.monotonic() - started:.1f} s")
    finally:
        await b.close()


def main():
    ap = browser_checks.parser(
        sim_unused="unused (the controller is simulated in-process); accepted like the other browser tests")
    ap.add_argument("--screenshot-dir", help="write gcode-trace.png and api-docs.png here")
    return browser_checks.main(ap.parse_args(), main_async, "gw-gcode-browser-")


if __name__ == "__main__":
    sys.exit(main())
