#!/usr/bin/python3
"""The dashboard in a real headless browser (Debian's chromium, driven over the Chrome DevTools
Protocol by cdp.py) against the real asi-gateway: three simulated controllers in-process
(time scale 10) plus one external ms2000-sim (ext1) whose control socket unplugs it.

Checks: the overview shows every controller connected with its positions; a REST move of sim1 shows
on the page; a jog click moves sim2 (the REST state agrees); a HALT click stops a long move (the
halt reaches the gateway: its request counter and the stage stopping short; the card says who halted
it), and HALT ALL (one POST /api/v1/halt) stops two moves and shows all four halted; an unplugged ext1 shows
as disconnected with its error (within 2 s of the unplug), and connected again after replug; a gateway restart shows the banner
and greys the values, then the page reconnects by itself and resumes its topics from the last
sequence numbers it saw; with tokens, the page asks for one, refuses a wrong one, works with a viewer
token whose HALT stops the stage; no console errors other than the ones the
API causes by design (GET .../lease answers 404 when free; what is refused while the gateway is
down; the 401s of the token check). With --screenshot, writes a PNG of the overview.

Run by ctest with Debian's /usr/bin/python3 (python3-websockets). Skipped (exit 77) without chromium.
"""

import asyncio
import json
import os
import re
import sys
import time

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "integration", "api"))
import browser_checks  # noqa: E402
from browser_checks import lease_404  # noqa: E402
from cdp import Browser, find_chromium  # noqa: E402
from gateway_fixture import TOKENS, auth_tokens, check, free_port, http_request, wait_until  # noqa: E402

IDS = ["ext1", "sim1", "sim2", "sim3"]


def rest(port, method, path, body=None):
    status, text = http_request(port, method, path, body, token=None)
    return status, (json.loads(text) if text else None)


def position(port, controller, axis):
    status, s = rest(port, "GET", f"/api/v1/controllers/{controller}")
    check(status == 200, f"GET {controller}: {status}")
    return next(a["position_um"] for a in s["axes"] if a["axis"] == axis)


def page_position(controller, axis):
    return (f"(() => {{ const e = document.querySelector('[data-controller={controller}] "
            f"td.pos[data-axis={axis}]'); return e ? parseFloat(e.textContent) : null; }})()")


def halt_count(port, route="/api/v1/controllers/{id}/halt"):
    status, text = http_request(port, "GET", "/api/v1/metrics", token=None)
    m = re.search(r'gw_http_requests_total\{[^}]*route="' + re.escape(route) + r'"[^}]*status="200"[^}]*\} '
                  r'([0-9.e+]+)', text)
    return float(m.group(1)) if m else 0.0


async def test_overview(b, port):
    await b.navigate(f"http://127.0.0.1:{port}/")
    await b.wait_for("four cards, all connected, live",
                     "document.body.dataset.live === 'yes' && "
                     f"{json.dumps(IDS)}.every(id => document.querySelector(`[data-controller=${{id}}]`)"
                     "?.dataset.state === 'connected')")
    ids = await b.evaluate("[...document.querySelectorAll('[data-controller]')].map(e => e.dataset.controller)")
    check(ids == IDS, f"cards {ids}")
    for c in IDS:
        axes = await b.evaluate(f"[...document.querySelectorAll('[data-controller={c}] td.pos')]"
                                ".map(e => [e.dataset.axis, e.textContent])")
        check(len(axes) >= 2 and all(re.fullmatch(r"-?\d+\.\d", t) for _, t in axes), f"{c} positions {axes}")
    text = await b.evaluate("document.querySelector('[data-controller=sim1]').textContent")
    check("STD_XYZ_SCAN" in text and "ring_buffer" in text, f"sim1 card lacks build/modules: {text[:300]}")
    check("lease: free" in text, f"sim1 lease line: {text[:400]}")
    for hidden in ("banner", "token-form"):
        shown = await b.evaluate(f"getComputedStyle(document.getElementById('{hidden}')).display !== 'none'")
        check(not shown, f"#{hidden} is shown while live without tokens")


async def test_rest_move_shows(b, port):
    status, body = rest(port, "POST", "/api/v1/controllers/sim1/move", {"axes": {"X": 2345}, "wait": True})
    check(status == 200, f"move sim1: {status} {body}")
    await b.wait_for("sim1 X near 2345 on the page", f"Math.abs({page_position('sim1', 'X')} - 2345) < 1")


async def test_jog_click(b, port):
    before = position(port, "sim2", "X")
    await b.evaluate("(() => { const s = document.querySelector('[data-controller=sim2] .jog select');"
                     " s.value = '1000'; })()")
    await b.click("[data-controller=sim2] [data-jog='X+']")
    await asyncio.to_thread(wait_until, "sim2 X 1000 um further (REST)",
                            lambda: abs(position(port, "sim2", "X") - (before + 1000)) < 1)
    await b.wait_for("the page shows the jog", f"Math.abs({page_position('sim2', 'X')} - {before + 1000}) < 1")


async def test_halt_click(b, port):
    halts = halt_count(port)
    status, body = rest(port, "POST", "/api/v1/controllers/sim3/speed", {"axes": {"Y": 0.5}})
    check(status == 200, f"speed sim3: {status} {body}")  # 5 mm/s at time scale 10: 20 s for the move
    status, body = rest(port, "POST", "/api/v1/controllers/sim3/move", {"axes": {"Y": 100000}})
    check(status == 200, f"long move sim3: {status} {body}")
    await b.wait_for("sim3 busy on the page", "document.querySelector('[data-controller=sim3]').dataset.busy === 'yes'")
    await b.click("[data-halt=sim3]")
    await asyncio.to_thread(wait_until, "the halt counted by the gateway", lambda: halt_count(port) >= halts + 1)
    await asyncio.to_thread(wait_until, "sim3 stopped",
                            lambda: rest(port, "GET", "/api/v1/controllers/sim3")[1]["busy"] is False)
    y = position(port, "sim3", "Y")
    check(y < 99000, f"sim3 Y reached {y}: the halt did not stop the move")
    await b.wait_for("the page shows where it stopped", f"Math.abs({page_position('sim3', 'Y')} - {y}) < 1")
    err = await b.evaluate("document.querySelector('[data-controller=sim3] .op-error').textContent")
    check(err == "", f"halt error on the page: {err}")
    # The card says who halted it, until a job is submitted or resumed there.
    text = await b.wait_for("sim3 shown halted", "document.querySelector('[data-controller=sim3]').dataset.halted "
                            "=== 'yes' && document.querySelector('[data-controller=sim3] .halted-line').textContent")
    check(text.startswith("HALTED by "), f"the halted line: {text!r}")


async def test_halt_all(b, port):
    halts = halt_count(port, "/api/v1/halt")
    for c in ("sim1", "sim2"):
        status, body = rest(port, "POST", f"/api/v1/controllers/{c}/speed", {"axes": {"Y": 0.5}})
        check(status == 200, f"speed {c}: {status} {body}")
        status, body = rest(port, "POST", f"/api/v1/controllers/{c}/move", {"axes": {"Y": -100000}})
        check(status == 200, f"long move {c}: {status} {body}")
    await b.wait_for("sim1 and sim2 busy on the page", "['sim1', 'sim2'].every(id => document.querySelector("
                     "`[data-controller=${id}]`).dataset.busy === 'yes')")
    await b.click("#halt-all")
    # One request halts them all (POST /api/v1/halt), and every card says so.
    await asyncio.to_thread(wait_until, "HALT ALL counted by the gateway",
                            lambda: halt_count(port, "/api/v1/halt") >= halts + 1)
    await b.wait_for("every card shown halted", f"{json.dumps(IDS)}.every(id => document.querySelector("
                     "`[data-controller=${id}]`).dataset.halted === 'yes')")
    for c in ("sim1", "sim2"):
        await asyncio.to_thread(wait_until, f"{c} stopped",
                                lambda: rest(port, "GET", f"/api/v1/controllers/{c}")[1]["busy"] is False)
        y = position(port, c, "Y")
        check(y > -99000, f"{c} Y reached {y}: HALT ALL did not stop the move")


async def test_unplug(b, control):
    check(control("unplug") == "ok", "unplug")
    unplugged = time.monotonic()
    await b.wait_for("ext1 not connected on the page",
                     "document.querySelector('[data-controller=ext1]').dataset.state !== 'connected'", timeout=20)
    shown_after = time.monotonic() - unplugged
    check(shown_after <= 2.0, f"the unplug showed on the page after {shown_after:.2f} s (at most 2 s)")
    await b.wait_for("ext1 greyed out", "document.querySelector('[data-controller=ext1]')"
                     ".classList.contains('offline')")
    await b.wait_for("ext1's error shown", "(() => { const e = document.querySelector("
                     "'[data-controller=ext1] .last-error'); return !e.hidden && e.textContent.length > 0"
                     " && e.textContent; })()", timeout=20)
    check(control("replug") == "ok", "replug")
    await b.wait_for("ext1 connected again",
                     "document.querySelector('[data-controller=ext1]').dataset.state === 'connected'", timeout=30)


async def test_restart(b, fx, gateway, config, port):
    sent_before = len(b.ws_sent)
    fx.gateway.terminate()
    fx.gateway.wait(timeout=30)
    await b.wait_for("the banner", "!document.getElementById('banner').hidden && document.body.dataset.live === 'no'")
    grey = await b.evaluate("getComputedStyle(document.querySelector('td.pos')).color")
    check(grey == "rgb(176, 180, 186)", f"positions not greyed while down: {grey}")
    await asyncio.to_thread(fx.start_gateway, gateway, config)
    await b.wait_for("live again after the restart", "document.body.dataset.live === 'yes' && "
                     "document.getElementById('banner').hidden", timeout=40)
    # The new subscriptions resumed every topic from the last sequence number the page had seen (one
    # subscribe per max_rate_hz: the overview also follows controllers/+/reports, unlimited).
    subs = [json.loads(t) for t in b.ws_sent[sent_before:] if '"subscribe"' in t]
    check(subs, "no subscribe sent after the restart")
    resume = {}
    for sub in subs:
        resume.update(sub.get("resume", {}))
    check(all(f"controllers/{c}/position" in resume and f"controllers/{c}/state" in resume for c in IDS)
          and all(isinstance(v, int) and v > 0 for v in resume.values()), f"resume after the restart: {resume}")


async def test_tokens(b, fx, gateway):
    """A gateway with tokens: the page asks for one, says when it is refused, then works with a viewer
    token (REST and the WebSocket's access_token); a viewer's HALT stops the stage (auth.halt_role); the viewer
    sees no operator controls (the jog pad), an operator's token shows them."""
    port = free_port()
    config = {
        "http": {"listen_address": "127.0.0.1", "port": port},
        "simulate": {"count": 1, "time_scale": 10, "directory": os.path.join(fx.tmp, "sim-auth")},
        "storage": {"path": os.path.join(fx.tmp, "store-auth")},
        "auth": auth_tokens(),
        "logging": {"level": "info"},
    }
    await asyncio.to_thread(fx.start_gateway, gateway, config)
    await b.navigate(f"http://127.0.0.1:{port}/")
    form_shown = "getComputedStyle(document.getElementById('token-form')).display !== 'none'"
    await b.wait_for("the token form", form_shown)

    async def submit(token):
        await b.evaluate(f"document.getElementById('token-input').value = {json.dumps(token)}")
        await b.click("#token-form button")

    await submit("wrong-token-0123456789")
    await b.wait_for("a refused token said so",
                     "document.getElementById('token-error').textContent === 'that token was refused'")
    await submit(TOKENS["viewer"])
    await b.wait_for("sim1 live with the viewer token",
                     "document.body.dataset.live === 'yes' && "
                     "document.querySelector('[data-controller=sim1]')?.dataset.state === 'connected'")
    check(not await b.evaluate(form_shown), "the token form is still shown")
    stored = await b.evaluate("sessionStorage.getItem('asi-gateway.token')")
    check(stored == TOKENS["viewer"], f"sessionStorage holds {stored!r}")
    # The emergency stop is every token holder's (auth.halt_role viewer by default).
    await b.click("[data-halt=sim1]")
    text = await b.wait_for("sim1 halted by the viewer", "document.querySelector('[data-controller=sim1]')"
                            ".dataset.halted === 'yes' && document.querySelector('[data-controller=sim1] "
                            ".halted-line').textContent")
    check("by viewer1" in text, f"the halted line: {text!r}")
    err = await b.evaluate("document.querySelector('[data-controller=sim1] .op-error').textContent")
    check(err == "", f"a viewer's halt shows {err!r}")
    # The role hides what it may not do: a viewer sees no jog pad, and says who it is.
    role = await b.wait_for("the viewer's role on the page", "document.body.dataset.role !== 'unknown' && "
                            "document.body.dataset.role")
    check(role == "viewer", f"body role {role!r}")
    jog_shown = "getComputedStyle(document.querySelector('[data-controller=sim1] .jog')).display !== 'none'"
    check(not await b.evaluate(jog_shown), "a viewer sees the jog pad")
    who = await b.evaluate("document.getElementById('whoami').textContent")
    check("viewer" in who, f"whoami line {who!r}")
    # An operator's token shows it again (a new page session: the token form takes the new token).
    await b.evaluate("sessionStorage.clear()")
    await b.navigate("about:blank")
    await b.navigate(f"http://127.0.0.1:{port}/")
    await b.wait_for("the token form again", form_shown)
    await submit(TOKENS["operator"])
    await b.wait_for("the operator's role on the page", "document.body.dataset.role === 'operator'")
    await b.wait_for("an operator sees the jog pad", jog_shown)


def unexpected_console(entries):
    return browser_checks.unexpected_console(entries, lease_404)


async def main_async(args, fx):
    chromium = find_chromium()
    ext1 = fx.start_sim(args.sim, "ext1", "plain", time_scale=10)
    port = free_port()
    config = {
        "http": {"listen_address": "127.0.0.1", "port": port},
        "controllers": [{"id": "ext1", "port": ext1.link, "baud": 115200, "poll_ms": 100,
                         "command_timeout_ms": 500}],
        "simulate": {"count": 3, "time_scale": 10, "directory": os.path.join(fx.tmp, "sim")},
        "storage": {"path": os.path.join(fx.tmp, "store")},
        "logging": {"level": "info"},
    }
    fx.start_gateway(args.gateway, config)
    b = Browser(chromium, os.path.join(fx.tmp, "profile"), free_port())
    try:
        await b.connect()
        checks = browser_checks.Checks(fx, b)
        run = checks.run
        await run("overview: every controller connected with positions", test_overview, b, port)
        await run("a REST move shows on the page", test_rest_move_shows, b, port)
        await run("a jog click moves the stage", test_jog_click, b, port)
        if args.screenshot:
            await b.wait_for("every card idle", "[...document.querySelectorAll('[data-controller]')]"
                             ".every(e => e.dataset.busy === 'no')")
            await b.screenshot(args.screenshot)
            print(f"screenshot: {args.screenshot}")
        await run("a HALT click stops the move", test_halt_click, b, port)
        await run("HALT ALL stops every controller", test_halt_all, b, port)
        await run("unplug shows disconnected, replug connected", test_unplug, b, ext1.control)
        before_restart = len(b.console)
        await run("gateway restart: banner, greyed values, reconnect", test_restart, b, fx, args.gateway, config, port)
        after_restart = len(b.console)
        await run("tokens: asked for, refused, then used", test_tokens, b, fx, args.gateway)
        # While the gateway was down the browser logs the refused requests and WebSocket, and with
        # tokens the 401s and the viewer's 403: by design.
        restart_ids = set(range(before_restart, after_restart))
        for i in range(after_restart, len(b.console)):
            if re.search(r"status of (401|403)", b.console[i][1] or ""):
                restart_ids.add(i)
        console = [e for i, e in enumerate(b.console) if i not in restart_ids or "127.0.0.1" not in (e[1] or "") + e[2]]
        checks.console_check(unexpected_console(console))
    finally:
        await b.close()


def main():
    ap = browser_checks.parser()
    ap.add_argument("--screenshot", help="write a PNG of the overview here")
    return browser_checks.main(ap.parse_args(), main_async, "gw-browser-test-")


if __name__ == "__main__":
    sys.exit(main())
