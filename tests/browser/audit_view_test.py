#!/usr/bin/python3
"""The dashboard's audit view (#/audit) in a real headless browser (Debian's chromium over the Chrome
DevTools Protocol, cdp.py) against the real asi-gateway with tokens and two simulated controllers.

Checks: as admin, the view lists the calls made over REST (a move, a refused move, a HALT) newest
first with who, transport, address, action and outcome, a refused call marked; the controller filter
shows only that controller's rows; a call made from the page itself (HALT ALL) appears after Refresh;
paging ("Older") goes back with no row twice; as an operator, the nav link is hidden and the view
says the trail is for admins; no console errors other than the 403 that causes by design.

Run by ctest with Debian's /usr/bin/python3 (python3-websockets). Skipped (exit 77) without chromium.
"""

import asyncio
import json
import os
import sys
import time

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "integration", "api"))
import browser_checks  # noqa: E402
from cdp import Browser, find_chromium  # noqa: E402
from gateway_fixture import TOKENS, auth_tokens, check, free_port, http_request  # noqa: E402

ROWS = "Array.from(document.querySelectorAll('#audit-rows tr'))"


def rest(port, method, path, body=None, token=TOKENS["admin"]):
    status, text = http_request(port, method, path, body, token=token)
    return status, (json.loads(text) if text and text.lstrip().startswith("{") else text)


async def sign_in(b, port, token):
    """Opens #/audit with `token` as the page's token (the page keeps it in sessionStorage): set on a
    page of the same origin first, so that the dashboard starts with it."""
    await b.navigate(f"http://127.0.0.1:{port}/api/v1/health")
    await b.wait_for("a page of the gateway's origin", "location.pathname === '/api/v1/health'")
    await b.evaluate(f"sessionStorage.setItem('asi-gateway.token', {json.dumps(token)})")
    await b.navigate(f"http://127.0.0.1:{port}/#/audit")
    await b.wait_for("the dashboard, live", "document.body.dataset.live === 'yes' && !!document.getElementById('audit-rows')")


async def rows(b):
    return await b.evaluate(f"{ROWS}.map(r => ({{id: Number(r.dataset.id), refused: r.className === 'refused',"
                            " cells: Array.from(r.cells).map(c => c.textContent)}))")


async def test_lists_calls(b, port):
    check(rest(port, "POST", "/api/v1/controllers/sim1/move", {"axes": {"X": 50}})[0] == 200, "move")
    check(rest(port, "POST", "/api/v1/controllers/sim1/move", {"axes": {"Q": 1}})[0] == 422, "refused move")
    check(rest(port, "POST", "/api/v1/controllers/sim2/halt", token=TOKENS["operator"])[0] == 200, "halt")
    await sign_in(b, port, TOKENS["admin"])
    await b.wait_for("three rows", f"{ROWS}.length >= 3")
    shown = await rows(b)
    check([r["id"] for r in shown] == sorted((r["id"] for r in shown), reverse=True), "newest first")
    halt, refused, move = shown[0], shown[1], shown[2]
    check(halt["cells"][1] == "operator1 (operator)" and halt["cells"][2] == "rest 127.0.0.1"
          and halt["cells"][3] == "halt" and halt["cells"][4] == "sim2" and halt["cells"][5] == "ok", f"HALT row: {halt}")
    check(refused["refused"] and refused["cells"][5].startswith("422"), f"the refused move is marked: {refused}")
    check(move["cells"][3] == "move" and '"X":50' in move["cells"][6], f"move row: {move}")
    check(not move["refused"], "a call that went through is not marked")


async def test_filter(b, port):
    await b.evaluate("{ const i = document.getElementById('audit-controller'); i.value = 'sim2';"
                     " i.dispatchEvent(new Event('change')); }")
    await b.wait_for("only sim2", f"{ROWS}.length > 0 && {ROWS}.every(r => r.cells[4].textContent.startsWith('sim2'))")
    await b.evaluate("{ const i = document.getElementById('audit-controller'); i.value = '';"
                     " i.dispatchEvent(new Event('change')); }")
    await b.wait_for("every row again", f"{ROWS}.some(r => r.cells[4].textContent.startsWith('sim1'))")


async def test_page_call_appears(b, port):
    await b.click("#halt-all")
    await b.wait_for("HALT ALL answered", "document.getElementById('halt-all-error').textContent === ''", timeout=10)
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        await b.click("#audit-refresh")
        await asyncio.sleep(0.3)
        if (await rows(b))[0]["cells"][3] == "halt_all":
            break
    top = (await rows(b))[0]
    check(top["cells"][3] == "halt_all" and top["cells"][1] == "admin1 (admin)", f"the page's own HALT ALL: {top}")


async def test_paging(b, port):
    for i in range(55):  # more than a page of 50
        rest(port, "POST", "/api/v1/controllers/sim2/move", {"axes": {"X": i}})
    await b.click("#audit-refresh")
    await b.wait_for("a full page", f"{ROWS}.length === 50")
    await b.click("#audit-older")
    await b.wait_for("the next page appended", f"{ROWS}.length > 50")
    ids = [r["id"] for r in await rows(b)]
    check(len(ids) == len(set(ids)) and ids == sorted(ids, reverse=True), "no row twice, newest first")


async def test_operator_sees_no_trail(b, port):
    await sign_in(b, port, TOKENS["operator"])
    hidden = await b.evaluate("getComputedStyle(document.querySelector('nav a[data-nav=audit]')).display === 'none'")
    check(hidden, "the Audit link is hidden for an operator")
    text = await b.wait_for("the refusal", "document.getElementById('audit-status').textContent")
    check("for admins" in text, f"status: {text!r}")


async def main_async(args, fx):
    chromium = find_chromium()
    port = free_port()
    config = {
        "http": {"listen_address": "127.0.0.1", "port": port}, "auth": auth_tokens(),
        "simulate": {"count": 2, "time_scale": 2, "directory": os.path.join(fx.tmp, "sim")},
        "storage": {"path": os.path.join(fx.tmp, "store")},
        "logging": {"level": "info"},
    }
    fx.start_gateway(args.gateway, config)
    b = Browser(chromium, os.path.join(fx.tmp, "profile"), free_port())
    try:
        await b.connect()
        checks = browser_checks.Checks(fx, b)
        run = checks.run
        if await run("the audit view lists REST calls, newest first, refusals marked", test_lists_calls, b, port):
            await run("the controller filter", test_filter, b, port)
            await run("a call from the page shows after Refresh", test_page_call_appears, b, port)
            await run("Older pages back, no row twice", test_paging, b, port)
            if args.screenshot:
                await b.evaluate("window.scrollTo(0, 0)")
                await b.screenshot(args.screenshot)
                print(f"screenshot: {args.screenshot}")
        await run("an operator sees no trail", test_operator_sees_no_trail, b, port,
                  expected=r"403")

        def audit_403(text, url):
            return url.endswith("/api/v1/audit?limit=50") and "403" in text

        def favicon_404(text, url):  # the JSON page sign_in opens first has no icon
            return url.endswith("/favicon.ico") and "404" in text

        checks.console_check(browser_checks.unexpected_console(b.console, audit_403, favicon_404,
                                                                      browser_checks.lease_404))
    finally:
        await b.close()


def main():
    ap = browser_checks.parser(
        sim_unused="unused (the controllers are simulated in-process); accepted like the other browser tests")
    ap.add_argument("--screenshot", help="write the audit view (after paging) here")
    return browser_checks.main(ap.parse_args(), main_async, "gw-audit-browser-")


if __name__ == "__main__":
    sys.exit(main())
