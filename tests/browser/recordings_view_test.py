#!/usr/bin/python3
"""The dashboard's position recordings (#/recordings, #/recordings/<id>) in a real headless browser
(Debian's chromium over the Chrome DevTools Protocol, cdp.py) against the real asi-gateway with tokens,
an external ms2000-sim with a report port (ext1, preset full; its control socket pulses IN0) and one
without (ext2, preset plain).

Recordings made over REST first: 300 frames (500 Hz, --pulse-rate), 150 with X at 1000 µm and 150 at 2000 µm, and
one whose triggers come faster than the report port (loss markers). Checks: the list shows them newest
first with controller, state, frames, losses and rate, and its filters work; the recording view shows
the summary and metadata, its chart holds every frame (300 points, no decimation needed) in one series
per axis, and the other's chart marks exactly its losses; the CSV downloaded through the page (with
the token, saved by the browser) is the REST download byte for byte; the start form offers only the
controller with a report port, puts the gateway's 422 next to the field it names, starts a recording
that the view follows live (frames drawn while it still records; beyond 4000 frames drawn as at most
4000 points per axis, every frame counted, the same when read again from the store), stops it and
deletes it (asked twice); a viewer sees no start form and no Stop or Delete; no console errors other
than the 422 the form causes by design. With --screenshot, writes the 300-frame recording's view there.

Run by ctest with Debian's /usr/bin/python3 (python3-websockets). Skipped (exit 77) without chromium.
"""

import asyncio
import json
import os
import sys

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "integration", "api"))
import browser_checks  # noqa: E402
from cdp import Browser, find_chromium  # noqa: E402
from gateway_fixture import TOKENS, auth_tokens, check, free_port, http_request, wait_until  # noqa: E402

ROWS = "Array.from(document.querySelectorAll('#rec-rows tr'))"
CHART = "document.querySelector('.recording-chart')"


def rest(port, method, path, body=None, token=TOKENS["operator"]):
    status, text = http_request(port, method, path, body, token=token)
    return status, (json.loads(text) if text and text.lstrip().startswith("{") else text)


def recording(port, rid):
    status, body = rest(port, "GET", f"/api/v1/recordings/{rid}", token=TOKENS["viewer"])
    check(status == 200, f"GET recording {rid}: {status} {body}")
    return body


def sim_state(sim):
    return json.loads(sim.control("state"))


def pulse(sim, n, rate_hz):
    """n edges on IN0 at rate_hz, waited for to the last edge."""
    edges = sim_state(sim)["ttl_edges"]
    check(sim.control(f"pulse {n} {rate_hz}") == "ok", "pulse")
    wait_until(f"{n} edges", lambda: sim_state(sim)["ttl_edges"] - edges >= n)


def move_x(port, x_um):
    status, body = rest(port, "POST", "/api/v1/controllers/ext1/move", {"axes": {"X": x_um}, "wait": True})
    check(status == 200, f"move X to {x_um}: {status} {body}")


def record_steps(port, sim, rate_hz):
    """300 frames at rate_hz: 150 with X at 1000 µm, then 150 at 2000 µm. Its id."""
    move_x(port, 1000)
    status, rec = rest(port, "POST", "/api/v1/controllers/ext1/recordings",
                       {"name": "two steps", "metadata": {"camera": "cam0", "exposure_ms": 2}})
    check(status == 201, f"start: {status} {rec}")
    pulse(sim, 150, rate_hz)
    wait_until("150 frames", lambda: recording(port, rec["id"])["frames"] >= 150)
    move_x(port, 2000)
    pulse(sim, 150, rate_hz)
    wait_until("300 frames", lambda: recording(port, rec["id"])["frames"] >= 300)
    status, done = rest(port, "POST", f"/api/v1/recordings/{rec['id']}/stop")
    check(status == 200 and done["frames"] == 300 and done["losses"] == 0, f"stop: {status} {done}")
    return rec["id"]


def record_losses(port, sim):
    """Triggers every 0.5 ms, faster than the report port: the controller drops some (overrun
    markers). Its id."""
    status, rec = rest(port, "POST", "/api/v1/controllers/ext1/recordings", {"name": "too fast"})
    check(status == 201, f"start: {status} {rec}")
    before = sim_state(sim)
    check(sim.control("pulse 40 2000") == "ok", "pulse")

    def sent_dropped():
        now = sim_state(sim)
        return now["reports_sent"] - before["reports_sent"], now["reports_dropped"] - before["reports_dropped"]
    wait_until("the pulse train ends", lambda: sum(sent_dropped()) >= 40)
    sent, dropped = sent_dropped()
    check(dropped > 0, "the simulator dropped no frame")
    wait_until("every frame and marker stored",
               lambda: (lambda r: r["frames"] >= sent and r["losses"] >= dropped)(recording(port, rec["id"])))
    status, done = rest(port, "POST", f"/api/v1/recordings/{rec['id']}/stop")
    check(status == 200 and done["losses"] == dropped, f"stop: {status} {done}")
    return rec["id"]


async def sign_in(b, port, token, hash_path):
    """Opens #<hash_path> with `token` as the page's token (kept in sessionStorage, set on a page of
    the same origin first so that the dashboard starts with it)."""
    await b.navigate(f"http://127.0.0.1:{port}/api/v1/health")
    await b.wait_for("a page of the gateway's origin", "location.pathname === '/api/v1/health'")
    await b.evaluate(f"sessionStorage.setItem('asi-gateway.token', {json.dumps(token)})")
    await b.navigate(f"http://127.0.0.1:{port}/#{hash_path}")
    await b.wait_for("the dashboard, live",
                     "document.body.dataset.live === 'yes' && document.body.dataset.role !== 'unknown'")


async def list_rows(b):
    return await b.evaluate(f"{ROWS}.map(r => ({{id: r.dataset.recording,"
                            " cells: Array.from(r.cells).map(c => c.textContent)}))")


async def set_value(b, selector, value):
    await b.evaluate(f"{{ const e = document.querySelector({json.dumps(selector)}); e.value = {json.dumps(value)};"
                     " e.dispatchEvent(new Event('input')); e.dispatchEvent(new Event('change')); }")


async def figure(b, key):
    return await b.evaluate(f"document.querySelector('[data-figure={key}]')?.textContent")


async def test_list(b, port, steps, lossy):
    await sign_in(b, port, TOKENS["operator"], "/recordings")
    # The router marks the link when it mounts the view, which may come after the page is live.
    await b.wait_for("the Recordings nav link, marked",
                     "!!document.querySelector('nav a[data-nav=recordings]')?.classList.contains('active')")
    await b.wait_for("two rows", f"{ROWS}.length === 2")
    rows = await list_rows(b)
    check([r["id"] for r in rows] == [lossy, steps], f"newest first: {rows}")
    name, controller, state, frames, losses, started, rate = rows[1]["cells"]
    check(name == "two steps" and controller == "ext1" and state == "stopped" and frames == "300" and losses == "0",
          f"the 300-frame row: {rows[1]}")
    check(rate.endswith("frames/s") and started != "–", f"rate and start shown: {rows[1]}")
    lossy_rec = recording(port, lossy)
    check(rows[0]["cells"][4] == str(lossy_rec["losses"]), f"the lossy row's losses: {rows[0]} vs {lossy_rec}")
    await set_value(b, "#rec-filter-controller", "ext2")
    await b.wait_for("no ext2 recordings",
                     f"{ROWS}.length === 0 && !document.querySelector('.recordings-page .empty').hidden")
    await set_value(b, "#rec-filter-controller", "")
    await set_value(b, "#rec-filter-state", "failed")
    await b.wait_for("no failed ones", f"{ROWS}.length === 0")
    await set_value(b, "#rec-filter-state", "stopped")
    await b.wait_for("both stopped ones", f"{ROWS}.length === 2")


async def test_view(b, port, steps):
    await b.click(f"tr[data-recording='{steps}'] a")
    await b.wait_for("the recording view", f"location.hash === '#/recordings/{steps}' && !!{CHART}")
    await b.wait_for("its summary", "document.querySelector('[data-figure=frames]')?.textContent === '300'")
    check(await b.evaluate("document.getElementById('rec-state').textContent") == "stopped", "state stopped")
    check(await figure(b, "losses") == "0", "no losses")
    check((await figure(b, "rate")).endswith("frames/s"), f"rate: {await figure(b, 'rate')}")
    check(await figure(b, "stopped") != "–", "stop time shown")
    meta = await b.evaluate("document.querySelector('.rec-metadata').textContent")
    check("camera" in meta and "cam0" in meta and "exposure_ms" in meta, f"metadata: {meta!r}")
    await b.wait_for("300 frames drawn", f"{CHART}.dataset.points === '300' && {CHART}.dataset.frames === '300'")
    series = await b.evaluate(f"{CHART}.dataset.series")
    check(series == "X,Y,Z", f"one series per axis: {series!r}")
    legend = await b.evaluate(f"Array.from({CHART}.querySelectorAll('.u-legend .u-series'))"
                              ".map(s => s.textContent.trim())")
    check([s for s in legend if "µm" in s] == ["X (µm)", "Y (µm)", "Z (µm)"], f"legend: {legend}")
    check(await b.evaluate(f"{CHART}.dataset.losses") == "0", "no loss markers")
    check(await b.evaluate("!!document.querySelector('.recording-chart canvas')"), "a uPlot canvas")
    shown = await b.evaluate("['rec-stop', 'rec-delete'].map(id => document.getElementById(id).hidden)")
    check(shown == [True, False], f"Stop hidden, Delete shown once it ended: {shown}")


async def test_losses_marked(b, port, lossy):
    rec = recording(port, lossy)
    await b.evaluate(f"location.hash = '#/recordings/{lossy}'")
    # Loss rows may come after the last frame (overruns are counted after the frame they follow), in a
    # later chunk of the stream and a later redraw: wait until the view has read every stored row and
    # the chart has drawn all it read, then count its markers.
    view = f"document.querySelector('[data-recording-view=\"{lossy}\"]')"
    rows = rec["frames"] + rec["losses"]
    await b.wait_for("every row read and drawn",
                     f"{view}?.dataset.rows === '{rows}' && {CHART}.dataset.frames === '{rec['frames']}'"
                     f" && Number({CHART}.dataset.frames) + Number({CHART}.dataset.losses) === {rows}")
    marked = await b.evaluate(f"{CHART}.dataset.losses")
    check(marked == str(rec["losses"]), f"{marked} markers drawn, the recording has {rec['losses']}")
    caption = await b.evaluate("document.querySelector('.recording-chart-caption').textContent")
    check(f"{rec['losses']} loss marker" in caption, f"caption: {caption!r}")
    check(await figure(b, "losses") == str(rec["losses"]), "losses in the summary")


async def test_csv_download(b, port, steps, downloads):
    status, expected = http_request(port, "GET", f"/api/v1/recordings/{steps}/frames?format=csv",
                                    token=TOKENS["viewer"])
    check(status == 200 and expected.count("\n") == 301, f"REST CSV: {status}, {expected.count(chr(10))} lines")
    await b.evaluate(f"location.hash = '#/recordings/{steps}'")
    await b.wait_for("the view", f"!!document.querySelector('[data-recording-view=\"{steps}\"] [data-download=csv]')")
    await b.click("[data-download=csv]")
    path = os.path.join(downloads, f"{steps}.csv")
    wait_until("the CSV saved by the browser",
               lambda: os.path.exists(path) and os.path.getsize(path) == len(expected.encode()), timeout=30)
    with open(path) as f:
        text = f.read()
    check(text.count("\n") == 301 and text == expected, f"the page's CSV ({text.count(chr(10))} lines) is the REST one")
    status_text = await b.evaluate("document.getElementById('rec-download-status').textContent")
    check(status_text.startswith(f"{steps}.csv"), f"download status: {status_text!r}")


async def test_start_from_page(b, port, sim, rate_hz):
    await b.evaluate("location.hash = '#/recordings'")
    await b.wait_for("the start form", "!!document.querySelector('.rec-start form')")
    options = await b.evaluate("Array.from(document.querySelectorAll('.rec-start [data-field=controller] option'))"
                               ".map(o => o.value)")
    check(options == ["ext1"], f"only the controller with a report port: {options}")
    await set_value(b, ".rec-start [data-field=name] input", "from the page")
    await set_value(b, ".rec-start [data-field='arm.ttl_in_mode'] input", "0")
    await set_value(b, ".rec-start [data-field=max_frames] input", "100000")
    await b.click("#rec-start")
    mode = "document.querySelector(\".rec-start [data-field='arm.ttl_in_mode']\")"
    error = await b.wait_for("the field error", f"{mode}.querySelector('.field-error').textContent")
    invalid = await b.evaluate(f"{mode}.classList.contains('invalid')")
    still = await b.evaluate("location.hash") == "#/recordings"
    check(invalid and still, f"marked next to the input, the form still there: {error!r}")
    status, body = rest(port, "GET", "/api/v1/recordings?state=recording", token=TOKENS["viewer"])
    check(status == 200 and body["recordings"] == [], f"nothing started: {body}")

    await set_value(b, ".rec-start [data-field='arm.ttl_in_mode'] input", "1")
    await b.click("#rec-start")
    rid = await b.wait_for("the new recording's view",
                           "location.hash.startsWith('#/recordings/r-')"
                           " && document.getElementById('rec-state')?.textContent === 'recording'"
                           " && location.hash.slice('#/recordings/'.length)")
    rec = recording(port, rid)
    check(rec["name"] == "from the page" and rec["state"] == "recording" and rec["max_frames"] == 100000
          and rec["ttl_in_mode"] == 1, f"started as asked: {rec}")
    check(any(f"recordings/{rid}" in m and "subscribe" in m for m in b.ws_sent), "subscribed to its live topic")
    shown = await b.evaluate("['rec-stop', 'rec-delete'].map(id => document.getElementById(id).hidden)")
    check(shown == [False, True], f"Stop shown, Delete hidden while it records: {shown}")

    pulse(sim, 60, min(200, rate_hz))
    await b.wait_for("60 frames drawn live", f"{CHART}.dataset.frames === '60'")
    check(recording(port, rid)["state"] == "recording", "still recording: the rows came over the live topic")
    reads = await b.evaluate("document.querySelector('[data-recording-view]').dataset.storeReads")
    check(reads == "1", f"the stored rows read once (at the start), not again: {reads}")
    check(await figure(b, "frames") == "60", "the summary's frames follow too")

    # More frames than the chart draws points (2 per bucket, 2000 buckets): decimated as they come.
    pulse(sim, 4100, rate_hz)
    wait_until("4160 frames or markers stored",
               lambda: (lambda r: r["frames"] + r["losses"] >= 4160)(recording(port, rid)))
    await b.click("#rec-stop")
    await b.wait_for("stopped", "document.getElementById('rec-state')?.textContent === 'stopped'")
    await b.wait_for("its rate", "document.querySelector('[data-figure=rate]').textContent.endsWith('frames/s')")
    done = recording(port, rid)
    check(done["state"] == "stopped" and done["frames"] > 4000, f"stopped at the gateway: {done}")
    await b.wait_for("every frame held", f"{CHART}.dataset.frames === '{done['frames']}'")
    points = int(await b.evaluate(f"{CHART}.dataset.points"))
    check(2000 <= points <= 4000, f"{done['frames']} frames drawn as {points} points")
    # Read again from the store (JSON Lines), the same.
    await b.evaluate("location.hash = '#/recordings'")
    await b.wait_for("the list", f"{ROWS}.some(r => r.dataset.recording === '{rid}')")
    await b.evaluate(f"location.hash = '#/recordings/{rid}'")
    await b.wait_for("every stored frame", f"{CHART}?.dataset.frames === '{done['frames']}'"
                     f" && {CHART}.dataset.points === '{points}'")

    await b.wait_for("Delete", "!document.getElementById('rec-delete').hidden")
    await b.click("#rec-delete")
    check(await b.evaluate("document.getElementById('rec-delete').textContent") == "Really delete?", "asks first")
    check(rest(port, "GET", f"/api/v1/recordings/{rid}", token=TOKENS["viewer"])[0] == 200, "not deleted by one click")
    await b.click("#rec-delete")
    await b.wait_for("back at the list", "location.hash === '#/recordings'")
    check(rest(port, "GET", f"/api/v1/recordings/{rid}", token=TOKENS["viewer"])[0] == 404, "deleted")


async def test_viewer(b, port, steps):
    await sign_in(b, port, TOKENS["viewer"], "/recordings")
    await b.wait_for("the list", f"{ROWS}.length >= 2")
    hidden = await b.evaluate("getComputedStyle(document.querySelector('.rec-start')).display === 'none'")
    check(hidden, "no start form for a viewer")
    await b.evaluate(f"location.hash = '#/recordings/{steps}'")
    await b.wait_for("the view", "document.querySelector('[data-figure=frames]')?.textContent === '300'")
    actions = await b.evaluate("getComputedStyle(document.querySelector('.rec-operator-actions')).display")
    check(actions == "none", f"no Stop or Delete for a viewer: display {actions}")
    downloads = await b.evaluate("getComputedStyle(document.querySelector('[data-download=csv]')).display")
    check(downloads != "none", "downloads are for viewers too")


async def screenshot(b, port, steps, path):
    await sign_in(b, port, TOKENS["operator"], f"/recordings/{steps}")
    await b.wait_for("the chart", f"{CHART}?.dataset.points === '300'")
    await asyncio.sleep(0.5)  # the uPlot canvas painted
    await b.evaluate("window.scrollTo(0, 0)")
    await b.screenshot(path)
    print(f"screenshot: {path}")


async def main_async(args, fx):
    chromium = find_chromium()
    ext1 = fx.start_sim(args.sim, "ext1", "full", report=True)
    ext2 = fx.start_sim(args.sim, "ext2", "plain")
    port = free_port()
    config = {
        "http": {"listen_address": "127.0.0.1", "port": port}, "auth": auth_tokens(),
        "controllers": [{"id": "ext1", "port": ext1.link, "report_port": ext1.report_link, "baud": 115200},
                        {"id": "ext2", "port": ext2.link, "baud": 115200}],
        "logging": {"level": "info"},
    }
    fx.start_gateway(args.gateway, config)
    downloads = os.path.join(fx.tmp, "downloads")
    os.makedirs(downloads)
    b = Browser(chromium, os.path.join(fx.tmp, "profile"), free_port())
    try:
        await b.connect()
        await b.call("Browser.setDownloadBehavior", behavior="allow", downloadPath=downloads)
        checks = browser_checks.Checks(fx, b)
        run = checks.run
        ids = {}

        async def make():
            ids["steps"] = record_steps(port, ext1, args.pulse_rate)
            ids["lossy"] = record_losses(port, ext1)
        if await run("two recordings made over REST", make):
            if await run("the list: newest first, frames, losses, rate, filters", test_list, b, port, ids["steps"],
                         ids["lossy"]):
                await run("the view: summary, metadata, a 300-point chart per axis", test_view, b, port, ids["steps"])
            await run("loss markers drawn and counted", test_losses_marked, b, port, ids["lossy"])
            await run("the CSV downloaded through the page is the REST one", test_csv_download, b, port, ids["steps"],
                      downloads)
            await run("start from the page: field error, live rows, decimation, stop, delete", test_start_from_page,
                      b, port, ext1, args.pulse_rate, expected=r"422")
            await run("a viewer sees no start form, Stop or Delete", test_viewer, b, port, ids["steps"])
            if args.screenshot:
                await run("screenshot", screenshot, b, port, ids["steps"], args.screenshot)

        def favicon_404(text, url):  # the JSON page sign_in opens first has no icon
            return url.endswith("/favicon.ico") and "404" in text

        def refused_start(text, url):  # the form's bad value, refused by design
            return url.endswith("/api/v1/controllers/ext1/recordings") and "422" in text

        checks.console_check(browser_checks.unexpected_console(b.console, favicon_404, refused_start,
                                                                      browser_checks.lease_404))
    finally:
        await b.close()


def main():
    ap = browser_checks.parser()
    ap.add_argument("--screenshot", help="write the view of the 300-frame recording here")
    ap.add_argument("--pulse-rate", type=int, default=500,
                    help="trigger rate (Hz) of the recordings that must lose no frame (100 for a sanitizer build)")
    return browser_checks.main(ap.parse_args(), main_async, "gw-recordings-browser-")


if __name__ == "__main__":
    sys.exit(main())
