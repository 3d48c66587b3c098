#!/usr/bin/python3
"""The dashboard's fleet view (#/fleet) in a real headless browser (Debian's chromium over the Chrome
DevTools Protocol, cdp.py) against a real mosquitto and three real asi-gateways (lab1, lab2, lab3, two
simulated controllers each) that publish on it.

The broker (Debian's mosquitto) has a TCP listener for the gateways and a websockets listener for the
page, no anonymous access, a password file and an ACL: the gateways' account reads and writes the
topic tree, the page's account `viewer` only reads it. lab2 runs a job submitted over REST (an array
job that waits for `next`, so it stays running).

Checks: a wildcard in the topic prefix is refused by the form; a wrong password is shown as refused;
with the viewer account the page, opened on lab1's own dashboard, lists all three gateways from their
retained births, each with its controllers and their state, and the job running on lab2 (none on the
others); a REST move on lab1 shows as a new position; the gateways' links follow the "Gateway pages"
pattern; the settings are remembered in localStorage and the password only in sessionStorage, and a
reload connects again; the page sent no PUBLISH packet to the broker (its WebSocket frames, read as MQTT
packets); a signed move published over the viewer account does not reach the gateway (no command
counted, nothing moved) while the same over the gateways' account does; lab3 stopped with SIGTERM shows
offline ("shutdown"), lab2 killed (-9) shows offline ("connection lost", the Last
Will); no console errors. With --screenshot, writes the fleet view (lab3 offline) there.

Run by ctest with Debian's /usr/bin/python3 (python3-websockets, python3-paho-mqtt). Skipped (exit 77)
without chromium or mosquitto.
"""

import asyncio
import base64
import json
import os
import signal
import subprocess
import sys
import time

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "integration", "api"))
import browser_checks  # noqa: E402
from cdp import Browser, find_chromium  # noqa: E402
from gateway_fixture import TOKENS, axis_position, check, free_port, http_request, wait_until  # noqa: E402
from mqtt_api_test import MOSQUITTO, PREFIX, Broker, Client, Gateway  # noqa: E402

PAGES = "http://{gateway}.fleet.test:8080/"  # the "Gateway pages" pattern the test types in
LAB3_URL = "https://lab3.public.test:8443/"  # lab3's own http.public_url, which its birth tells
CARD = "document.querySelector(\"[data-gateway='{}']\")"
GATEWAY_PASSWORD = "gateway-password"  # Client() and the gateways use <user>-password


def card(gw):
    return CARD.format(gw)


def rest(port, method, path, body=None, token=TOKENS["operator"]):
    status, text = http_request(port, method, path, body, token=token)
    return status, (json.loads(text) if text and text.lstrip().startswith("{") else text)


def commands_counted(gw):
    """gw_mqtt_commands_total over every outcome: a command that reached the gateway is counted."""
    status, text = http_request(gw.port, "GET", "/api/v1/metrics", token=TOKENS["viewer"])
    check(status == 200, f"metrics: {status}")
    return sum(float(line.rsplit(" ", 1)[1]) for line in text.splitlines()
               if line.startswith("gw_mqtt_commands_total"))


def mqtt_packet_types(frame_b64):
    """The MQTT control packet types (1 CONNECT ... 3 PUBLISH ... 8 SUBSCRIBE, 12 PINGREQ) in one binary
    WebSocket frame the page sent (DevTools gives binary payloads in base64)."""
    try:
        data = base64.b64decode(frame_b64, validate=True)
    except ValueError:
        return ["not binary"]
    types, i = [], 0
    while i < len(data):
        types.append(data[i] >> 4)
        length, shift, i = 0, 0, i + 1
        while i < len(data):  # the remaining length: a variable byte integer
            length |= (data[i] & 0x7F) << shift
            shift += 7
            i += 1
            if not data[i - 1] & 0x80:
                break
        i += length
    return types


def write_broker_accounts(tmp):
    """The password file (mosquitto_passwd) and the ACL: the gateways read and write the tree, the
    viewer only reads it."""
    passwd = os.path.join(tmp, "passwd")
    for i, user in enumerate(("gateway", "viewer")):
        subprocess.run(["mosquitto_passwd", "-b", *(["-c"] if i == 0 else []), passwd, user, f"{user}-password"],
                       check=True)
    acl = os.path.join(tmp, "acl")
    with open(acl, "w") as f:
        f.write(f"user gateway\ntopic readwrite {PREFIX}/#\n\nuser viewer\ntopic read {PREFIX}/#\n")
    return passwd, acl


async def sign_in(b, port, hash_path):
    """Opens #<hash_path> on the gateway's dashboard with the viewer token (sessionStorage, set on a page
    of the same origin first)."""
    await b.navigate(f"http://127.0.0.1:{port}/api/v1/health")
    await b.wait_for("a page of the gateway's origin", "location.pathname === '/api/v1/health'")
    await b.evaluate(f"sessionStorage.setItem('asi-gateway.token', {json.dumps(TOKENS['viewer'])})")
    await b.navigate(f"http://127.0.0.1:{port}/#{hash_path}")
    await b.wait_for("the dashboard, live",
                     "document.body.dataset.live === 'yes' && document.body.dataset.role !== 'unknown'")


async def set_value(b, selector, value):
    await b.evaluate(f"{{ const e = document.querySelector({json.dumps(selector)}); e.value = {json.dumps(value)};"
                     " e.dispatchEvent(new Event('input')); }")


async def fill_form(b, ws_url, username, password):
    await set_value(b, "#fleet-url", ws_url)
    await set_value(b, "#fleet-username", username)
    await set_value(b, "#fleet-password", password)
    await set_value(b, "#fleet-prefix", PREFIX)
    await set_value(b, "#fleet-pages", PAGES)
    await b.click("#fleet-connect")


async def test_refused(b, lab1, ws_url):
    await sign_in(b, lab1.port, "/fleet")
    await b.wait_for("the Fleet nav link, marked",
                     "!!document.querySelector('nav a[data-nav=fleet]')?.classList.contains('active')")
    await set_value(b, "#fleet-url", ws_url)
    await set_value(b, "#fleet-prefix", "asi/#")
    await b.click("#fleet-connect")
    error = await b.wait_for("the prefix refused", "document.getElementById('fleet-form-error').textContent")
    check("topic prefix" in error, f"a wildcard in the prefix: {error!r}")
    check(await b.evaluate("document.getElementById('fleet-status').dataset.state") == "idle", "not connected")
    await fill_form(b, ws_url, "viewer", "not-the-password")
    await b.wait_for("refused", "document.getElementById('fleet-status').dataset.state === 'refused'")
    text = await b.evaluate("document.getElementById('fleet-status').textContent")
    check("refused" in text, f"the status says so: {text!r}")
    check(await b.evaluate("document.querySelectorAll('[data-gateway]').length") == 0, "no gateway shown")


async def test_fleet_listed(b, gws, ws_url, job):
    await fill_form(b, ws_url, "viewer", "viewer-password")
    await b.wait_for("connected", "document.getElementById('fleet-status').dataset.state === 'connected'")
    await b.wait_for("three gateways online",
                     "document.querySelectorAll('[data-gateway][data-online=yes]').length === 3")
    ids = await b.evaluate("Array.from(document.querySelectorAll('[data-gateway]')).map(c => c.dataset.gateway)")
    check(ids == ["lab1", "lab2", "lab3"], f"every gateway, by name: {ids}")
    for gw in gws:
        await b.wait_for(f"{gw.name}'s controllers, connected, with positions",
                         f"Array.from({card(gw.name)}.querySelectorAll('tr[data-controller]'))"
                         ".map(r => r.dataset.controller + ':' + r.dataset.state + ':'"
                         " + r.querySelectorAll('[data-axis]').length).join() === 'sim1:connected:3,sim2:connected:3'")
        version = await b.evaluate(f"{card(gw.name)}.querySelector('.meta').textContent")
        check("version" in version and "since" in version, f"{gw.name}'s birth shown: {version!r}")
    await b.wait_for("lab2's running job",
                     f"{card('lab2')}.querySelector(\"tr[data-job='{job}']\")?.dataset.state === 'running'")
    row = await b.evaluate(f"Array.from({card('lab2')}.querySelector(\"tr[data-job='{job}']\").cells)"
                           ".map(c => c.textContent)")
    check(row[1] == "sim1" and row[2] == "array" and "waits for next" in row[5], f"the job's row: {row}")
    for name in ("lab1", "lab3"):
        n = await b.evaluate(f"{card(name)}.querySelectorAll('tr[data-job]').length")
        check(n == 0, f"no job on {name}: {n}")
    summary = await b.evaluate("document.getElementById('fleet-summary').textContent")
    check("3 gateways" in summary and "3 online" in summary and "1 job running" in summary, f"summary: {summary!r}")


async def test_links(b):
    for name in ("lab1", "lab2", "lab3"):
        href = await b.evaluate(f"{card(name)}.querySelector('a.fleet-gateway-link').href")
        want = LAB3_URL if name == "lab3" else PAGES.format(gateway=name)
        check(href == want, f"{name}'s page: {href} (wanted {want})")
    ctl = await b.evaluate(f"{card('lab1')}.querySelector(\"tr[data-controller='sim2'] a\").href")
    check(ctl == PAGES.format(gateway="lab1") + "#/controller/sim2", f"a controller's view on its gateway: {ctl}")


async def test_position(b, lab1):
    shown = f"{card('lab1')}.querySelector(\"tr[data-controller='sim1'] [data-axis=X]\").textContent"
    before = float(await b.evaluate(shown))
    target = 1234.0 if abs(before - 1234.0) > 10 else 2345.0
    status, body = rest(lab1.port, "POST", "/api/v1/controllers/sim1/move", {"axes": {"X": target}, "wait": True})
    check(status == 200, f"move: {status} {body}")
    await b.wait_for(f"lab1 sim1 X near {target}", f"Math.abs(parseFloat({shown}) - {target}) < 1")


async def test_settings_kept(b, lab1):
    saved = json.loads(await b.evaluate("localStorage.getItem('asi-gateway.fleet')"))
    check(saved.get("username") == "viewer" and saved.get("prefix") == PREFIX and saved.get("pages") == PAGES
          and saved.get("url", "").startswith("ws://") and "password" not in saved,
          f"localStorage keeps the settings, not the password: {saved}")
    check(await b.evaluate("sessionStorage.getItem('asi-gateway.fleet.password')") == "viewer-password",
          "the password only for the session")
    # A reload connects again as the page was left.
    await b.navigate(f"http://127.0.0.1:{lab1.port}/#/fleet")
    await b.wait_for("connected again", "document.getElementById('fleet-status')?.dataset.state === 'connected'")
    await b.wait_for("the three gateways again",
                     "document.querySelectorAll('[data-gateway][data-online=yes]').length === 3")


async def test_page_publishes_nothing(b):
    types = [t for frame in b.ws_sent for t in mqtt_packet_types(frame)]
    check(1 in types and 8 in types, f"the page's CONNECT and SUBSCRIBE seen in its frames: {set(types)}")
    check(3 not in types, f"the page sent a PUBLISH: {types}")


def test_viewer_cannot_publish(broker, lab3):
    """A signed move (it would run, were it delivered) over the viewer account: the broker drops it."""
    topic = lab3.topic("controllers", "sim1", "cmd")
    x0, counted0 = axis_position(lab3.port, "sim1"), commands_counted(lab3)
    target = x0 + 3000.0
    move = {"operation": "move", "args": {"axes": {"X": target}, "wait": True}, "token": TOKENS["operator"]}
    viewer = Client(broker.port, "fleet-test-viewer", user="viewer")
    try:
        viewer.publish(topic, move)
    finally:
        viewer.close()
    time.sleep(2)
    check(commands_counted(lab3) == counted0, "a command over the viewer account reached the gateway")
    check(abs(axis_position(lab3.port, "sim1") - x0) < 1, "the viewer's move ran")
    # The same over an account that may write: it runs, so the viewer's would have too.
    writer = Client(broker.port, "fleet-test-writer", user="gateway")
    try:
        writer.publish(topic, move)
    finally:
        writer.close()
    wait_until("the writer's move ran", lambda: abs(axis_position(lab3.port, "sim1") - target) < 1)
    check(commands_counted(lab3) > counted0, "the writer's command counted")


async def test_shutdown_offline(b, lab3):
    lab3.proc.send_signal(signal.SIGTERM)
    lab3.proc.wait(timeout=30)
    await b.wait_for("lab3 offline", f"{card('lab3')}.dataset.online === 'no'")
    reason = await b.evaluate(f"{card('lab3')}.querySelector('.fleet-offline-reason').textContent")
    check(reason.startswith("offline: shutdown"), f"the reason: {reason!r}")
    for name in ("lab1", "lab2"):
        check(await b.evaluate(f"{card(name)}.dataset.online") == "yes", f"{name} still online")


async def test_lost_offline(b, lab2):
    lab2.proc.kill()
    lab2.proc.wait(timeout=30)
    # The Last Will: the broker publishes it when the connection ends without a DISCONNECT (here at once,
    # the kernel closing the killed process's socket; after 1.5 keepalives for a gateway gone silent).
    await b.wait_for("lab2 offline by its Last Will", f"{card('lab2')}.dataset.online === 'no'", timeout=30)
    reason = await b.evaluate(f"{card('lab2')}.querySelector('.fleet-offline-reason').textContent")
    check(reason == "offline: connection lost", f"the reason: {reason!r}")


async def screenshot(b, path):
    await b.wait_for("lab3 offline, lab1 and lab2 online",
                     "document.querySelectorAll('[data-gateway][data-online=yes]').length === 2")
    await asyncio.sleep(0.5)  # the next batch of positions drawn
    await b.evaluate("window.scrollTo(0, 0)")
    await b.screenshot(path)
    print(f"screenshot: {path}")


def submit_waiting_job(lab2):
    body = {"controller": "sim1", "type": "array",
            "spec": {"grid": {"columns": 3, "rows": 2, "column_step_mm": 0.2, "row_step_mm": -0.2},
                     "a1": "current", "advance": "next"}}
    status, job = rest(lab2.port, "POST", "/api/v1/jobs", body)
    check(status == 201, f"submit: {status} {job}")
    wait_until("the job running", lambda: rest(lab2.port, "GET", f"/api/v1/jobs/{job['id']}",
                                               token=TOKENS["viewer"])[1]["state"] == "running")
    return job["id"]


async def main_async(args, fx):
    chromium = find_chromium()
    passwd, acl = write_broker_accounts(fx.tmp)
    ws_port = free_port()
    broker = Broker(fx, "fleet-broker", extra=["allow_anonymous false", f"password_file {passwd}", f"acl_file {acl}",
                                               f"listener {ws_port} 127.0.0.1", "protocol websockets"])
    broker.start()
    ws_url = f"ws://127.0.0.1:{ws_port}"
    gws = [Gateway(fx, args.gateway, name, [f"mqtt://127.0.0.1:{broker.port}"], sims=2,
                   mqtt_extra={"username": "gateway", "password": GATEWAY_PASSWORD})
           for name in ("lab1", "lab2", "lab3")]
    # lab3 says where its page is (http.public_url, in its birth): the page links there, not to the pattern.
    gws[2].config["http"]["public_url"] = LAB3_URL
    for gw in gws:
        gw.start()
    lab1, lab2, lab3 = gws
    fx.log_path = lab1.log_path  # the log the fixture prints when something failed
    b = Browser(chromium, os.path.join(fx.tmp, "profile"), free_port())
    try:
        await b.connect()
        checks = browser_checks.Checks(fx, b)
        run = checks.run
        job = {}

        async def submit():
            job["id"] = submit_waiting_job(lab2)
        await run("a job running on lab2 (REST)", submit)
        await run("a wrong password: refused", test_refused, b, lab1, ws_url)
        if await run("every gateway, its controllers and lab2's job", test_fleet_listed, b, gws, ws_url,
                     job.get("id")):
            await run("links to each gateway's page", test_links, b)
            await run("a REST move shows as a new position", test_position, b, lab1)
            await run("settings kept (the password for the session only), connected again after a reload",
                      test_settings_kept, b, lab1)
        await run("the viewer account cannot publish", asyncio.to_thread, test_viewer_cannot_publish, broker, lab3)
        await run("the page published nothing", test_page_publishes_nothing, b)
        await run("lab3 stopped (SIGTERM): offline, shutdown", test_shutdown_offline, b, lab3)
        if args.screenshot:
            await run("screenshot", screenshot, b, args.screenshot)
        await run("lab2 killed: offline, connection lost", test_lost_offline, b, lab2)

        def favicon_404(text, url):  # the JSON page sign_in opens first has no icon
            return url.endswith("/favicon.ico") and "404" in text

        checks.console_check(browser_checks.unexpected_console(
            [e for i, e in enumerate(b.console) if i not in checks.by_design], favicon_404))
    finally:
        await b.close()


def main():
    ap = browser_checks.parser(sim_unused="not used: the gateways simulate their controllers (--simulate)")
    ap.add_argument("--screenshot", help="write the fleet view (lab3 offline) here")
    args = ap.parse_args()
    if not os.path.exists(MOSQUITTO):
        print(f"{MOSQUITTO} is not installed (scripts/install-deps --tests installs it): skipped")
        return 77
    return browser_checks.main(args, main_async, "gw-fleet-browser-")


if __name__ == "__main__":
    sys.exit(main())
