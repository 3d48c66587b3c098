#!/usr/bin/python3
"""The dashboard over HTTPS (http.tls, issue 34) in Debian's headless chromium: the real asi-gateway
with a self-signed certificate (Debian's openssl) and tokens, two simulated controllers. Chromium
trusts exactly that certificate's key (--ignore-certificate-errors-spki-list), as a lab would trust
its own CA.

Checks: the page loads from https://localhost:<port>/ and asks for a token; with an operator token
every card is connected and live (the WebSocket is wss://, built from the page's own scheme); a jog
click moves the stage (a state-changing POST from the page's https origin passes the browser rules);
a REST move over HTTPS shows on the page; a HALT click is counted; no console errors beyond the 401
of the token check.

Run by ctest with Debian's /usr/bin/python3 (python3-websockets). Skipped (exit 77) without chromium.
"""

import asyncio
import base64
import hashlib
import json
import os
import re
import ssl
import subprocess
import sys

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "integration", "api"))
import browser_checks  # noqa: E402
from browser_checks import lease_404  # noqa: E402
from cdp import Browser, find_chromium  # noqa: E402
from gateway_fixture import (TOKENS, auth_tokens, check, free_port, http_request,  # noqa: E402
                             self_signed_certificate, wait_until)

IDS = ["sim1", "sim2"]


def spki_sha256_base64(cert):
    """What chromium's --ignore-certificate-errors-spki-list takes: the base64 SHA-256 of the
    certificate's public key (SubjectPublicKeyInfo, DER)."""
    pub = subprocess.run(["openssl", "x509", "-in", cert, "-pubkey", "-noout"], check=True, capture_output=True).stdout
    der = subprocess.run(["openssl", "pkey", "-pubin", "-outform", "der"], input=pub, check=True,
                         capture_output=True).stdout
    return base64.b64encode(hashlib.sha256(der).digest()).decode()


class Gateway:
    def __init__(self, port, ctx):
        self.port, self.ctx = port, ctx

    def rest(self, method, path, body=None):
        status, text = http_request(self.port, method, path, body, token=TOKENS["operator"], tls=self.ctx)
        return status, (json.loads(text) if text else None)

    def position(self, controller, axis):
        status, s = self.rest("GET", f"/api/v1/controllers/{controller}")
        check(status == 200, f"GET {controller}: {status}")
        return next(a["position_um"] for a in s["axes"] if a["axis"] == axis)

    def halts(self):
        status, text = http_request(self.port, "GET", "/api/v1/metrics", token=TOKENS["admin"], tls=self.ctx)
        m = re.search(r'gw_http_requests_total\{[^}]*route="/api/v1/controllers/\{id\}/halt"[^}]*status="200"'
                      r'[^}]*\} ([0-9.e+]+)', text)
        return float(m.group(1)) if m else 0.0


def page_position(controller, axis):
    return (f"(() => {{ const e = document.querySelector('[data-controller={controller}] "
            f"td.pos[data-axis={axis}]'); return e ? parseFloat(e.textContent) : null; }})()")


async def test_token_then_live(b, gw):
    await b.navigate(f"https://localhost:{gw.port}/")
    form_shown = "getComputedStyle(document.getElementById('token-form')).display !== 'none'"
    await b.wait_for("the token form over HTTPS", form_shown)
    await b.evaluate(f"document.getElementById('token-input').value = {json.dumps(TOKENS['operator'])}")
    await b.click("#token-form button")
    await b.wait_for("every card connected and live over wss://",
                     "document.body.dataset.live === 'yes' && "
                     f"{json.dumps(IDS)}.every(id => document.querySelector(`[data-controller=${{id}}]`)"
                     "?.dataset.state === 'connected')")
    scheme = await b.evaluate("location.protocol")
    check(scheme == "https:", f"the page's scheme {scheme}")
    ws_urls = [t for t in b.ws_sent if t]  # frames sent: the page's WebSocket is open
    check(ws_urls, "the page sent nothing over its WebSocket")


async def test_jog_click(b, gw):
    before = await asyncio.to_thread(gw.position, "sim2", "X")
    await b.evaluate("(() => { const s = document.querySelector('[data-controller=sim2] .jog select');"
                     " s.value = '1000'; })()")
    await b.click("[data-controller=sim2] [data-jog='X+']")
    await asyncio.to_thread(wait_until, "sim2 X 1000 um further (REST over HTTPS)",
                            lambda: abs(gw.position("sim2", "X") - (before + 1000)) < 1)
    await b.wait_for("the page shows the jog", f"Math.abs({page_position('sim2', 'X')} - {before + 1000}) < 1")


async def test_rest_move_shows(b, gw):
    status, body = await asyncio.to_thread(gw.rest, "POST", "/api/v1/controllers/sim1/move",
                                           {"axes": {"Y": 777}, "wait": True})
    check(status == 200, f"move sim1: {status} {body}")
    await b.wait_for("the page shows sim1 at Y 777", f"Math.abs({page_position('sim1', 'Y')} - 777) < 1")


async def test_halt_click(b, gw):
    before = await asyncio.to_thread(gw.halts)
    await b.click("[data-halt=sim1]")
    await asyncio.to_thread(wait_until, "the halt counted by the gateway", lambda: gw.halts() >= before + 1)
    await b.wait_for("sim1 halted on the page",
                     "document.querySelector('[data-controller=sim1]').dataset.halted === 'yes'")


def token_401(text, url):
    return bool(re.search(r"status of 401", text or ""))


async def main_async(args, fx):
    chromium = find_chromium()
    cert, key = self_signed_certificate(fx.tmp)
    ctx = ssl.create_default_context(cafile=cert)
    port = free_port()
    config = {
        "http": {"listen_address": "127.0.0.1", "port": port, "tls": {"cert_file": cert, "key_file": key}},
        "simulate": {"count": 2, "time_scale": 10, "directory": os.path.join(fx.tmp, "sim")},
        "storage": {"path": os.path.join(fx.tmp, "store")},
        "auth": auth_tokens(),
        "logging": {"level": "info"},
    }
    fx.start_gateway(args.gateway, config, tls=ctx)
    gw = Gateway(port, ctx)
    b = Browser(chromium, os.path.join(fx.tmp, "profile"), free_port(),
                extra_args=[f"--ignore-certificate-errors-spki-list={spki_sha256_base64(cert)}"])
    try:
        await b.connect()
        checks = browser_checks.Checks(fx, b)
        run = checks.run
        await run("HTTPS: the token form, then every card live over wss://", test_token_then_live, b, gw)
        await run("HTTPS: a jog click moves the stage", test_jog_click, b, gw)
        await run("HTTPS: a REST move shows on the page", test_rest_move_shows, b, gw)
        await run("HTTPS: a HALT click is served", test_halt_click, b, gw)
        checks.console_check(browser_checks.unexpected_console(b.console, lease_404, token_401))
    finally:
        await b.close()


def main():
    ap = browser_checks.parser(sim_unused="not used: the controllers are simulated in-process")
    return browser_checks.main(ap.parse_args(), main_async, "gw-tls-browser-test-")


if __name__ == "__main__":
    sys.exit(main())
