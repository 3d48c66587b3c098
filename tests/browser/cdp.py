"""A minimal Chrome DevTools Protocol client: starts Debian's headless chromium, attaches to its page
over the DevTools WebSocket (Debian's python3-websockets) and offers the few calls the browser tests
need (navigate, evaluate, click, screenshot) plus every console message, page error and WebSocket
frame sent by the page.
Standard library and python3-websockets only; asyncio, since websockets 10 has no sync client.
"""
import asyncio
import base64
import http.client
import json
import os
import shutil
import subprocess
import time

import websockets


def find_chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    return None


class Browser:
    def __init__(self, chromium, profile_dir, debug_port, width=1400, height=1000, extra_args=()):
        args = [chromium, "--headless=new", "--disable-gpu", "--no-first-run", "--no-default-browser-check",
                "--disable-extensions", "--disable-background-networking", "--mute-audio",
                f"--user-data-dir={profile_dir}", f"--remote-debugging-port={debug_port}",
                f"--window-size={width},{height}", *extra_args, "about:blank"]
        if os.geteuid() == 0:
            args.insert(1, "--no-sandbox")  # chromium refuses to run as root with its sandbox
        self.proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        self.debug_port = debug_port
        self.ws = None
        self.next_id = 0
        self.pending = {}
        self.console = []  # (level, text, url) of console calls, exceptions and log entries
        self.ws_sent = []  # the text of every WebSocket frame the page sent
        self.reader = None

    def page_url(self, timeout=30):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                conn = http.client.HTTPConnection("127.0.0.1", self.debug_port, timeout=5)
                conn.request("GET", "/json/list")
                targets = json.loads(conn.getresponse().read())
                conn.close()
                pages = [t for t in targets if t.get("type") == "page"]
                if pages:
                    return pages[0]["webSocketDebuggerUrl"]
            except (OSError, http.client.HTTPException, ValueError):
                pass
            time.sleep(0.2)
        raise RuntimeError("chromium's DevTools endpoint did not come up")

    async def connect(self):
        self.ws = await websockets.connect(self.page_url(), max_size=64 * 1024 * 1024)
        self.reader = asyncio.ensure_future(self._read())
        for domain in ("Page", "Runtime", "Log", "Network"):
            await self.call(f"{domain}.enable")

    async def _read(self):
        async for text in self.ws:
            msg = json.loads(text)
            if "id" in msg:
                fut = self.pending.pop(msg["id"], None)
                if fut and not fut.done():
                    fut.set_result(msg)
                continue
            method, p = msg.get("method"), msg.get("params", {})
            if method == "Runtime.consoleAPICalled":
                text = " ".join(str(a.get("value", a.get("description", ""))) for a in p.get("args", []))
                self.console.append((p.get("type"), text, ""))
            elif method == "Runtime.exceptionThrown":
                d = p.get("exceptionDetails", {})
                self.console.append(("exception", d.get("exception", {}).get("description", d.get("text")), ""))
            elif method == "Network.webSocketFrameSent":
                self.ws_sent.append(p.get("response", {}).get("payloadData", ""))
            elif method == "Log.entryAdded":
                e = p.get("entry", {})
                self.console.append((e.get("level"), e.get("text"), e.get("url", "")))

    async def call(self, method, **params):
        self.next_id += 1
        fut = asyncio.get_running_loop().create_future()
        self.pending[self.next_id] = fut
        await self.ws.send(json.dumps({"id": self.next_id, "method": method, "params": params}))
        msg = await asyncio.wait_for(fut, 30)
        if "error" in msg:
            raise RuntimeError(f"{method}: {msg['error']}")
        return msg["result"]

    async def evaluate(self, expression):
        """The value of a JavaScript expression (awaited when it is a promise)."""
        r = await self.call("Runtime.evaluate", expression=expression, returnByValue=True, awaitPromise=True)
        if "exceptionDetails" in r:
            raise RuntimeError(f"{expression}: {r['exceptionDetails'].get('text')}")
        return r["result"].get("value")

    async def navigate(self, url):
        await self.call("Page.navigate", url=url)

    async def wait_for(self, what, expression, timeout=30):
        deadline = time.monotonic() + timeout
        last = None
        while time.monotonic() < deadline:
            try:
                last = await self.evaluate(expression)
                if last:
                    return last
            except RuntimeError as e:
                last = e
            await asyncio.sleep(0.1)
        raise AssertionError(f"timed out waiting for {what} (last: {last!r})")

    async def click(self, selector, timeout=10):
        """A real mouse click in the middle of the element (scrolled into view), once the element
        holds still for an animation frame and is the one the mouse would hit there: a panel that
        grows above it (live data arriving) moves it between finding it and pressing the button."""
        find = (f"(async () => {{ const e = document.querySelector({json.dumps(selector)}); if (!e) return null;"
                " e.scrollIntoView({block: 'center'}); const a = e.getBoundingClientRect();"
                " await new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)));"
                " const b = e.getBoundingClientRect(); const x = b.x + b.width / 2, y = b.y + b.height / 2;"
                " const hit = document.elementFromPoint(x, y);"
                " const still = a.x === b.x && a.y === b.y && a.width === b.width && a.height === b.height;"
                " return [x, y, still && !!hit && e.contains(hit)]; })()")
        # Which element the click reached: the page may still move between finding the element and the
        # mouse events (separate calls). A click that did nothing is sent again; one that reached another
        # control fails the test (it may have done something).
        # The element is kept as it was when the click went out: a click may remove it (a link to
        # another view), or the page may put a new copy in its place.
        watch = ("(() => { window.__cdpClick = null;"
                 f" window.__cdpMeant = document.querySelector({json.dumps(selector)});"
                 " addEventListener('click', (ev) => { window.__cdpClick = ev.target; },"
                 " {capture: true, once: true}); })()")
        # 'inert': the click reached text or a panel, which does nothing on a click.
        landed = (f"(() => {{ const e = document.querySelector({json.dumps(selector)}); const t = window.__cdpClick;"
                  " const meant = window.__cdpMeant;"
                  " if (t === null) return 'none';"
                  " if ((meant && meant.contains(t)) || (e && e.contains(t))) return 'element';"
                  " const c = t.closest('a, button, input, select, textarea, summary, label, [role=button],"
                  " [role=link], [role=checkbox], [role=radio], [role=tab], [role=menuitem]');"
                  " return c ? 'control: ' + c.outerHTML.slice(0, 120) : 'inert'; })()")
        deadline = time.monotonic() + timeout
        while True:
            box = await self.evaluate(find)
            if not box:
                raise AssertionError(f"no element {selector}")
            if box[2]:
                await self.evaluate(watch)
                for kind in ("mousePressed", "mouseReleased"):
                    await self.call("Input.dispatchMouseEvent", type=kind, x=box[0], y=box[1], button="left",
                                    clickCount=1)
                where = await self.evaluate(landed)
                if where == "element":
                    return
                if where.startswith("control"):
                    raise AssertionError(f"the click meant for {selector} reached another control as the page "
                                         f"moved: {where[9:]}")
                # 'none' (the press and the release fell on different elements) or 'inert': the page moved
                # under the mouse and nothing happened; the click is sent again where the element is now.
            if time.monotonic() > deadline:
                raise AssertionError(f"{selector} did not hold still under the mouse within {timeout} s")

    async def screenshot(self, path):
        r = await self.call("Page.captureScreenshot", format="png", captureBeyondViewport=False)
        with open(path, "wb") as f:
            f.write(base64.b64decode(r["data"]))

    async def close(self):
        if self.ws:
            await self.ws.close()
        if self.reader:
            self.reader.cancel()
        self.proc.terminate()
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
