#!/usr/bin/python3
"""The dashboard's job views in a real headless browser (Debian's chromium over the Chrome DevTools
Protocol, cdp.py) against the real asi-gateway with three simulated controllers in-process (time
scale 20: sim1 the full build with the ARRAY module, sim2 plain, sim3 planar).

Checks:
- an array job filled in on the form (#/jobs/new), dry-run (the estimate, the firmware path and the
  bounding box on the XY map shown), then submitted, opens its page and runs to succeeded with every
  well of the plate map done and the progress bar at 100 % (the REST job agrees);
- a validation error of the gateway (422, field spec.grid.columns) shows next to that input, and one
  whose field names no input (spec.steps[0]) at the top of the form;
- pause, resume and cancel clicked on a job's page change its state (the REST state agrees), and the
  buttons follow the state;
- a job with advance "next": when the REST job has progress.waiting_for (issue 14's API addition) the
  page says "waiting for Next"; either way its Next button shows and a click advances the job;
- the list filtered by controller and by state shows what GET /api/v1/jobs does, and a job submitted
  elsewhere appears in it live;
- no console errors other than the 422s the validation check asks for.
With --screenshot-dir, writes plate-job.png (a running plate job), new-job.png (a dry run) and
jobs-list.png there.

Run by ctest with Debian's /usr/bin/python3 (python3-websockets). Skipped (exit 77) without chromium.
"""

import asyncio
import http.client
import json
import os
import sys
import time

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "integration", "api"))
import browser_checks  # noqa: E402
from browser_checks import lease_404, whoami_404  # noqa: E402
from cdp import Browser, find_chromium  # noqa: E402
from gateway_fixture import check, free_port, http_request, wait_until  # noqa: E402


def rest(port, method, path, body=None):
    status, text = http_request(port, method, path, body, token=None)
    return status, (json.loads(text) if text else None)


def job(port, job_id):
    status, j = rest(port, "GET", f"/api/v1/jobs/{job_id}")
    check(status == 200, f"GET job {job_id}: {status} {j}")
    return j


def submit(port, body):
    status, j = rest(port, "POST", "/api/v1/jobs", body)
    check(status == 201, f"POST job: {status} {j}")
    return j["id"]


async def wait_rest(what, fn, timeout=60):
    return await asyncio.to_thread(wait_until, what, fn, timeout)


async def set_value(b, selector, value):
    """Sets an input or select like a person would (the page hears input and change)."""
    await b.evaluate(f"(() => {{ const e = document.querySelector({json.dumps(selector)});"
                     f" e.value = {json.dumps(value)}; e.dispatchEvent(new Event('input', {{bubbles: true}}));"
                     " e.dispatchEvent(new Event('change', {bubbles: true})); })()")


async def open_form(b, port, controller):
    await b.navigate(f"http://127.0.0.1:{port}/#/jobs/new")
    await b.wait_for("the new job form", "document.body.dataset.live === 'yes' && "
                     "document.querySelector('#job-form [name=controller]')")
    await set_value(b, "#job-form [name=controller]", controller)


def field_error(field):
    return f"document.querySelector('.field[data-field=\"{field}\"] .field-error')?.textContent"


def upload_gcode(port, name, text):
    """An uploaded program's id (POST /api/v1/gcode/files with a text body)."""
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
    conn.request("POST", f"/api/v1/gcode/files?name={name}", body=text.encode(), headers={"Content-Type": "text/plain"})
    r = conn.getresponse()
    body = r.read().decode()
    conn.close()
    check(r.status == 201, f"upload {name}: {r.status} {body}")
    return json.loads(body)["id"]


async def test_gcode_from_form(b, port):
    file_id = upload_gcode(port, "form-square.ngc", "G21 G90\nG00 X1 Y1\nG01 X2 F600\nG01 Y2\nG01 X1\nM2\n")
    await open_form(b, port, "sim1")  # the controller with a report port: the run records
    await b.click("#job-form [data-type=gcode]")
    await b.wait_for("the uploaded program offered", "[...document.querySelectorAll(\"[name='spec.file'] option\")]"
                     f".some(o => o.value === {json.dumps(file_id)})")
    await set_value(b, "[name='spec.file']", file_id)
    await b.click("[name='spec.record']")  # the run records its triggers' positions
    await b.click("#dry-run")
    await b.wait_for("the dry run's estimate", "document.querySelector('.plan-estimate dd')?.textContent")
    path = await b.evaluate("document.querySelector('.plan-path dd').textContent")
    check(path == "host", f"a G-code trace runs host-driven: path {path!r}")
    summary = await b.evaluate("document.querySelector('.plan-summary').textContent")
    check("records each trigger" in summary, f"the plan says it records: {summary!r}")
    await b.click("#submit-job")
    job_id = await b.wait_for("the job's page", "/^#\\/jobs\\/j-/.test(location.hash) && location.hash.slice(7)")
    await b.wait_for("succeeded on the page", "document.getElementById('job-state')?.dataset.state === 'succeeded'",
                     timeout=90)
    j = job(port, job_id)
    check(j["type"] == "gcode" and j["state"] == "succeeded" and j["spec"]["file"] == file_id,
          f"REST job {j['type']} {j['state']} {j['spec']}")
    check(j["spec"].get("record") is True, f"the form asked to record: {j['spec']}")
    # The run's recording in the job's events, a link to its page, which links back to the job.
    rid = await b.wait_for("the recording's end in the events",
                           "[...document.querySelectorAll('tr[data-event=recording]')]"
                           ".find(r => r.textContent.includes('stopped'))?.querySelector('a')?.dataset.recording")
    await b.click(f"a[data-recording='{rid}']")
    await b.wait_for("the recording's page", f"location.hash === '#/recordings/{rid}'")
    back = await b.wait_for("the link to its job", "document.getElementById('rec-job')?.getAttribute('href')")
    check(back == f"#/jobs/{job_id}", f"the recording names its job: {back}")


async def test_array_from_form(b, port, shots):
    await open_form(b, port, "sim1")
    await b.click("#job-form [data-type=array]")
    await set_value(b, "[name='spec.plate']", "24")
    await set_value(b, "[name='spec.a1.X']", "-20000")
    await set_value(b, "[name='spec.a1.Y']", "15000")
    await set_value(b, "[name='spec.dwell_ms']", "150")
    await b.click("#dry-run")
    estimate = await b.wait_for("the dry run's estimate", "document.querySelector('.plan-estimate dd')?.textContent")
    check(estimate.endswith(" s") or "min" in estimate, f"estimate {estimate!r}")
    path = await b.evaluate("document.querySelector('.plan-path dd').textContent")
    check(path == "firmware", f"sim1 has the ARRAY module: path {path!r}")
    box = await b.evaluate("(() => { const r = document.querySelector('.dry-run [data-overlay=bbox]');"
                           " return r && [+r.getAttribute('width'), +r.getAttribute('height')]; })()")
    check(box and box[0] > 2 and box[1] > 2, f"bounding box on the XY map: {box}")
    bounds = await b.evaluate("document.querySelector('.plan-bounds dd').textContent")
    check("-20000" in bounds and "15000" in bounds, f"bounds {bounds!r}")
    frame = await b.evaluate("document.querySelector('.dry-run .xy-limits').getAttribute('visibility')")
    check(frame == "visible", f"soft limits frame {frame}")
    check(not await b.evaluate("document.getElementById('submit-job').disabled"), "Submit disabled after the dry run")
    if shots:
        await b.screenshot(os.path.join(shots, "new-job.png"))
    await b.click("#submit-job")
    job_id = await b.wait_for("the job's page", "/^#\\/jobs\\/j-/.test(location.hash) && location.hash.slice(7)")
    await b.wait_for("the plate map", "document.querySelectorAll('.plate-map .well').length === 24")
    if shots:
        await b.wait_for("a few wells done", "document.querySelectorAll('.well.done').length >= 5", timeout=60)
        await b.click(".well.done")
        await b.wait_for("the well's detail", "!!document.querySelector('.well-measured')")
        await b.evaluate("window.scrollTo(0, 0)")
        await b.screenshot(os.path.join(shots, "plate-job.png"))
    await b.wait_for("succeeded on the page", "document.getElementById('job-state')?.dataset.state === 'succeeded'",
                     timeout=90)
    j = job(port, job_id)
    check(j["state"] == "succeeded" and j["progress"]["percent"] == 100, f"REST job {j['state']} {j['progress']}")
    await b.wait_for("every well done", "document.querySelectorAll('.plate-map .well.done').length === 24")
    pct = await b.evaluate("document.querySelector('.job-progress .progress').dataset.percent")
    check(pct == "100.0", f"progress bar at {pct}")
    counts = await b.evaluate("document.querySelector('.plate-card h3 .meta').textContent")
    check(counts == "24 of 24 wells done", f"plate counts {counts!r}")
    # A click on a done well shows its step: target and measured position.
    await b.click(".plate-map [data-well=B3]")
    detail = await b.wait_for("B3's detail", "document.querySelector('.well-detail[data-well=B3]')?.textContent")
    check("target X" in detail and "measured X" in detail, f"well detail {detail!r}")


async def test_validation(b, port):
    await open_form(b, port, "sim2")
    await b.click("#job-form [data-type=array]")
    await b.click("#r-layout-grid")
    await set_value(b, "[name='spec.grid.columns']", "0")
    await b.click("#dry-run")
    err = await b.wait_for("the error next to Columns", field_error("spec.grid.columns"))
    check("column" in err.lower() or "1" in err, f"columns error {err!r}")
    top = await b.evaluate("document.querySelector('.form-error').textContent")
    check("marked below" in top, f"top of the form: {top!r}")
    check(await b.evaluate("document.getElementById('submit-job').disabled"), "Submit enabled after a refusal")
    # Beyond the soft limit (110 mm): the gateway names the step (spec.steps[0]), no input: at the top.
    await set_value(b, "[name='spec.grid.columns']", "2")
    check(not await b.evaluate(field_error("spec.grid.columns")), "the error stayed after an edit")
    await set_value(b, "[name='spec.a1.X']", "200000")
    await b.click("#dry-run")
    top = await b.wait_for("the step error at the top", "document.querySelector('.form-error').textContent")
    check("spec.steps[0]" in top, f"top error {top!r}")


async def open_job(b, port, job_id):
    await b.navigate(f"http://127.0.0.1:{port}/#/jobs/{job_id}")
    await b.wait_for("the job page", f"document.querySelector('.job-page h2')?.textContent.includes('{job_id}')")


def shown_actions():
    return ("[...document.querySelectorAll('.job-actions button')].filter(b => !b.hidden)"
            ".map(b => b.dataset.action).join(',')")


async def test_pause_resume_cancel(b, port):
    job_id = submit(port, {"controller": "sim2", "type": "array",
                           "spec": {"plate": "24", "a1": {"X": 0, "Y": 0}, "dwell_ms": 400, "mode": "host"}})
    await open_job(b, port, job_id)
    await b.wait_for("running with pause and cancel", f"{shown_actions()} === 'pause,cancel'")
    await b.click("[data-action=pause]")
    await wait_rest("paused (REST)", lambda: job(port, job_id)["state"] == "paused")
    await b.wait_for("paused on the page with resume and cancel",
                     f"document.getElementById('job-state').dataset.state === 'paused' && {shown_actions()} === 'resume,cancel'")
    done = job(port, job_id)["progress"]["steps_done"]
    await b.click("[data-action=resume]")
    await wait_rest("running again (REST)", lambda: job(port, job_id)["progress"]["steps_done"] > done)
    await b.wait_for("running on the page", "document.getElementById('job-state').dataset.state === 'running'")
    await b.wait_for("the pause button back", f"{shown_actions()} === 'pause,cancel'")
    await b.click("[data-action=cancel]")
    await wait_rest("cancelled (REST)", lambda: job(port, job_id)["state"] == "cancelled")
    await b.wait_for("cancelled on the page, no actions",
                     f"document.getElementById('job-state').dataset.state === 'cancelled' && {shown_actions()} === ''")
    err = await b.evaluate("document.querySelector('.action-error').textContent")
    check(err == "", f"action error {err!r}")


async def test_next(b, port):
    job_id = submit(port, {"controller": "sim2", "type": "array",
                           "spec": {"plate": "6", "a1": {"X": 0, "Y": 0}, "advance": "next", "mode": "host"}})
    await wait_rest("the first well done", lambda: job(port, job_id)["progress"]["steps_done"] >= 1)
    await open_job(b, port, job_id)
    progress = job(port, job_id)["progress"]
    if "waiting_for" in progress:
        await wait_rest("waiting for next (REST)", lambda: job(port, job_id)["progress"]["waiting_for"] == "next")
        text = await b.wait_for("'waiting for Next' on the page",
                                "(() => { const w = document.querySelector('.job-waiting');"
                                " return !w.hidden && w.textContent; })()")
        check("waiting for next" in text.lower(), f"waiting text {text!r}")
        print("       (the API has progress.waiting_for: checked 'waiting for Next')", flush=True)
    else:
        print("       (the API has no progress.waiting_for yet: the waiting text is not checked)", flush=True)
    await b.wait_for("the Next button", f"{shown_actions()} === 'pause,next,cancel'")
    done = job(port, job_id)["progress"]["steps_done"]
    await b.click("[data-action=next]")
    await wait_rest("the next well (REST)", lambda: job(port, job_id)["progress"]["steps_done"] > done)
    await b.wait_for("the page shows it", f"document.querySelectorAll('.well.done').length === {done + 1}")
    status, _ = rest(port, "POST", f"/api/v1/jobs/{job_id}/cancel", {})
    check(status == 200, f"cancel: {status}")


def js_ids(ids):
    """A JavaScript string literal of JSON.stringify(ids)."""
    return json.dumps(json.dumps(ids, separators=(",", ":")))


def list_rows():
    return ("[...document.querySelectorAll('table.jobs tbody tr')]"
            ".map(r => [r.dataset.job, r.dataset.controller, r.dataset.state])")


async def test_list(b, port, shots):
    await b.navigate(f"http://127.0.0.1:{port}/#/jobs")
    await b.wait_for("the job list", "document.querySelectorAll('table.jobs tbody tr').length >= 3")
    _, page = rest(port, "GET", "/api/v1/jobs?limit=25")
    rows = await b.evaluate(list_rows())
    check([r[0] for r in rows] == [j["id"] for j in page["jobs"]], f"rows {rows} vs REST {page['jobs']}")
    await set_value(b, "#job-filter-controller", "sim2")
    _, page = rest(port, "GET", "/api/v1/jobs?controller=sim2&limit=25")
    want = [j["id"] for j in page["jobs"]]
    await b.wait_for("sim2's jobs only", f"JSON.stringify({list_rows()}.map(r => r[0])) === {js_ids(want)}")
    check(len(want) >= 2, f"sim2 has {len(want)} jobs")
    await set_value(b, "#job-filter-state", "cancelled")
    _, page = rest(port, "GET", "/api/v1/jobs?controller=sim2&state=cancelled&limit=25")
    want = [j["id"] for j in page["jobs"]]
    check(want, "no cancelled sim2 job")
    await b.wait_for("sim2's cancelled jobs", f"JSON.stringify({list_rows()}.map(r => r[0])) === {js_ids(want)}")
    await set_value(b, "#job-filter-state", "")
    await set_value(b, "#job-filter-controller", "")
    await b.wait_for("every job again", f"{list_rows()}.length === {len(rest(port, 'GET', '/api/v1/jobs?limit=25')[1]['jobs'])}")
    # Live: a job submitted elsewhere shows at the top, and runs to succeeded, without a reload.
    started = time.monotonic()
    job_id = submit(port, {"controller": "sim3", "type": "array",
                           "spec": {"plate": "6", "a1": {"X": 0, "Y": 0}, "mode": "host"}})
    await b.wait_for("the new job at the top", f"{list_rows()}[0]?.[0] === '{job_id}'", timeout=5)
    check(time.monotonic() - started < 5, "the new job came from the slow refresh, not live")
    await b.wait_for("it succeeds in the list", f"{list_rows()}[0][2] === 'succeeded'", timeout=60)
    pct = await b.evaluate("document.querySelector('table.jobs tbody tr .progress').dataset.percent")
    check(pct == "100.0", f"list progress {pct}")
    if shots:
        await b.screenshot(os.path.join(shots, "jobs-list.png"))


def unexpected_console(entries, allowed_422):
    def validation_422(text, url):
        nonlocal allowed_422
        if allowed_422 and "/api/v1/jobs?dry_run=true" in url and "422" in text:
            allowed_422 -= 1  # the validation check's refusals, by design
            return True
        return False

    return browser_checks.unexpected_console(entries, lease_404, whoami_404, validation_422)


async def main_async(args, fx):
    port = free_port()
    config = {
        "http": {"listen_address": "127.0.0.1", "port": port},
        "simulate": {"count": 3, "time_scale": 20, "directory": os.path.join(fx.tmp, "sim")},
        "storage": {"path": os.path.join(fx.tmp, "store")},
        "logging": {"level": "info"},
    }
    fx.start_gateway(args.gateway, config)
    shots = args.screenshot_dir
    if shots:
        os.makedirs(shots, exist_ok=True)
    b = Browser(find_chromium(), os.path.join(fx.tmp, "profile"), free_port())
    try:
        await b.connect()
        checks = browser_checks.Checks(fx, b, timed=True)
        run = checks.run
        await run("an array job from the form: dry run, submit, runs to succeeded", test_array_from_form, b, port, shots)
        await run("a G-code job from the form: an uploaded program, dry run, submit, succeeded", test_gcode_from_form,
                  b, port)
        await run("validation errors next to their field", test_validation, b, port)
        await run("pause, resume and cancel from the buttons", test_pause_resume_cancel, b, port)
        await run("advance next: waiting for Next, the Next button", test_next, b, port)
        await run("the list: filters, live", test_list, b, port, shots)
        checks.console_check(unexpected_console(b.console, 2))
    finally:
        await b.close()


def main():
    ap = browser_checks.parser(
        sim_unused="unused (the controllers are simulated in the gateway); accepted like the other browser tests")
    ap.add_argument("--screenshot-dir", help="write plate-job.png, new-job.png and jobs-list.png here")
    return browser_checks.main(ap.parse_args(), main_async, "gw-jobs-browser-test-")


if __name__ == "__main__":
    sys.exit(main())
