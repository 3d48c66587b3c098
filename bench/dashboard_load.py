#!/usr/bin/python3
"""The dashboard under load, measured in the browser (issue 14): Debian's headless chromium on the real
gateway with 8 external simulated controllers whose stages move all the time (positions at 10 Hz each,
the page's max_rate_hz) and one of them streaming encoder reports at 500 frames/s (a TTL pulse train
on its report port).

For each view (the overview, then the report controller's view with its charts) it records, over a
measurement window: the page's frame rate (requestAnimationFrame callbacks per second), its long tasks
(PerformanceObserver "longtask": main-thread tasks over 50 ms), the renderer's main-thread busy time
(CDP Performance.getMetrics TaskDuration) and, on the controller view, the report frames the page
counted against those the simulator sent.

  /usr/bin/python3 bench/dashboard_load.py [--gateway build/gateway/asi-gateway]
      [--sim build/devices/sim/ms2000-sim] [--seconds 20] [--no-results]

Prints a table and, unless --no-results, replaces the "Dashboard under load" section of
bench/RESULTS.md. Takes about a minute. Standard library, python3-websockets and chromium (the
test packages of scripts/install-deps --tests).
"""

import argparse
import asyncio
import datetime
import json
import os
import platform
import re
import sys

sys.dont_write_bytecode = True
HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..")
sys.path.insert(0, os.path.join(ROOT, "tests", "browser"))
sys.path.insert(0, os.path.join(ROOT, "tests", "integration", "api"))
from cdp import Browser, find_chromium  # noqa: E402
from gateway_fixture import Fixture, check, free_port, http_request, wait_until  # noqa: E402

CONTROLLERS = 8
REPORT_HZ = 500
REPORTER = "ext1"

# The gaps the page counted in the report stream (controller_seq jumps and gap events).
GAP_COUNTER = "Number(document.querySelector('.report-stats[data-reports]')?.dataset.gaps ?? 0)"

# Installed in the page before the window: frame and long-task counters.
PROBE = """(() => {
  window.__bench = {frames: 0, longTasks: 0, longMs: 0, longestMs: 0};
  const tick = () => { window.__bench.frames += 1; requestAnimationFrame(tick); };
  requestAnimationFrame(tick);
  new PerformanceObserver((list) => {
    for (const e of list.getEntries()) {
      window.__bench.longTasks += 1;
      window.__bench.longMs += e.duration;
      window.__bench.longestMs = Math.max(window.__bench.longestMs, e.duration);
    }
  }).observe({type: "longtask"});
  return true;
})()"""


def rest(port, method, path, body=None):
    status, text = http_request(port, method, path, body, token=None)
    return status, (json.loads(text) if text else None)


async def task_seconds(b):
    metrics = (await b.call("Performance.getMetrics"))["metrics"]
    return next(m["value"] for m in metrics if m["name"] == "TaskDuration")


async def measure(b, seconds, page_counter=None):
    await b.evaluate(PROBE)
    before = await task_seconds(b)
    count_before = await b.evaluate(page_counter) if page_counter else None
    gaps_before = await b.evaluate(GAP_COUNTER) if page_counter else None
    await asyncio.sleep(seconds)
    after = await task_seconds(b)
    bench = await b.evaluate("window.__bench")
    count_after = await b.evaluate(page_counter) if page_counter else None
    gaps_after = await b.evaluate(GAP_COUNTER) if page_counter else None
    out = {
        "fps": bench["frames"] / seconds,
        "long_tasks": bench["longTasks"],
        "long_ms": bench["longMs"],
        "longest_ms": bench["longestMs"],
        "busy_pct": 100.0 * (after - before) / seconds,
    }
    if page_counter:
        out["page_frames"] = count_after - count_before
        out["page_gaps"] = gaps_after - gaps_before
    return out


def keep_moving(port, ids):
    """Slow long moves back and forth, so every stage moves through the whole window."""
    for i, c in enumerate(ids):
        status, body = rest(port, "POST", f"/api/v1/controllers/{c}/speed", {"axes": {"X": 0.4, "Y": 0.3}})
        check(status == 200, f"speed {c}: {status} {body}")
        sign = 1 if i % 2 == 0 else -1
        status, body = rest(port, "POST", f"/api/v1/controllers/{c}/move",
                            {"axes": {"X": sign * 40000, "Y": -sign * 30000}})
        check(status == 200, f"move {c}: {status} {body}")


async def run(args, fx):
    sims = {}
    for i in range(CONTROLLERS):
        name = f"ext{i + 1}"
        sims[name] = fx.start_sim(args.sim, name, "full" if name == REPORTER else "plain", report=name == REPORTER)
    port = free_port()
    config = {
        "http": {"listen_address": "127.0.0.1", "port": port},
        "controllers": [{"id": n, "port": s.link, "baud": 115200, "poll_ms": 100,
                         **({"report_port": s.report_link} if s.report_link else {})} for n, s in sims.items()],
        "storage": {"path": os.path.join(fx.tmp, "store")},
        "logging": {"level": "warn"},
    }
    fx.start_gateway(args.gateway, config)
    ids = sorted(sims)
    wait_until("every controller connected", lambda: all(
        rest(port, "GET", f"/api/v1/controllers/{c}")[1]["state"] == "connected" for c in ids), timeout=60)
    status, body = rest(port, "POST", f"/api/v1/controllers/{REPORTER}/ttl", {"in0_mode": 1})
    check(status == 200, f"ttl in0_mode 1: {status} {body}")
    keep_moving(port, ids)

    b = Browser(find_chromium(), os.path.join(fx.tmp, "profile"), free_port())
    results = []
    try:
        await b.connect()
        await b.call("Performance.enable")
        pulses = int(REPORT_HZ * (args.seconds * 2 + 30))
        check(sims[REPORTER].control(f"pulse {pulses} {REPORT_HZ}") == "ok", "pulse train")

        await b.navigate(f"http://127.0.0.1:{port}/")
        await b.wait_for("eight live cards", "document.body.dataset.live === 'yes' && "
                         f"document.querySelectorAll('[data-controller]').length === {CONTROLLERS}")
        await asyncio.sleep(2)
        results.append(("overview, 8 cards", await measure(b, args.seconds)))

        await b.navigate(f"http://127.0.0.1:{port}/#/controller/{REPORTER}")
        await b.wait_for("the controller view live", "document.body.dataset.live === 'yes'")
        await asyncio.sleep(2)
        results.append((f"controller view {REPORTER} (charts, {REPORT_HZ} frames/s)",
                        await measure(b, args.seconds, args.frame_counter)))
        # GET .../lease answers 404 for a free controller, by design.
        bad = [e for e in b.console if e[0] in ("error", "exception") and not e[2].endswith("/lease")]
        check(not bad, f"console errors: {bad[:3]}")
    finally:
        await b.close()
    return results


def table(results, seconds):
    lines = ["| view | frame rate | long tasks (> 50 ms) | longest | main thread busy | report frames counted | gaps |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for name, r in results:
        frames = f"{r['page_frames']} ({r['page_frames'] / seconds:.0f}/s)" if "page_frames" in r else "–"
        gaps = str(r["page_gaps"]) if "page_gaps" in r else "–"
        lines.append(f"| {name} | {r['fps']:.0f} fps | {r['long_tasks']} ({r['long_ms']:.0f} ms) | "
                     f"{r['longest_ms']:.0f} ms | {r['busy_pct']:.0f} % | {frames} | {gaps} |")
    return "\n".join(lines)


def write_results(text):
    path = os.path.join(HERE, "RESULTS.md")
    with open(path) as f:
        doc = f.read()
    section = "## Dashboard under load\n\n" + text + "\n"
    pattern = re.compile(r"## Dashboard under load\n.*?(?=\n## |\Z)", re.S)
    doc = pattern.sub(lambda _: section, doc) if pattern.search(doc) else doc.rstrip("\n") + "\n\n" + section
    with open(path, "w") as f:
        f.write(doc)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", default=os.path.join(ROOT, "build", "gateway", "asi-gateway"))
    ap.add_argument("--sim", default=os.path.join(ROOT, "build", "devices", "sim", "ms2000-sim"))
    ap.add_argument("--seconds", type=float, default=20)
    ap.add_argument("--frame-counter", default="Number(document.querySelector('.report-stats[data-reports]')"
                    "?.dataset.frames ?? 0)", help="a JS expression: the report frames the page counted")
    ap.add_argument("--no-results", action="store_true")
    args = ap.parse_args()
    if not find_chromium():
        print("chromium is not installed (scripts/install-deps --tests installs it)")
        return 2
    fx = Fixture("gw-dashboard-bench-")
    try:
        results = asyncio.run(run(args, fx))
    finally:
        fx.cleanup()
    with open("/proc/loadavg") as f:
        load = " ".join(f.read().split()[:3])
    text = (f"`bench/dashboard_load.py`, {datetime.date.today()}: headless chromium (Debian) on the gateway with "
            f"{CONTROLLERS} external simulated controllers, every stage moving (positions at 10 Hz each), "
            f"{REPORTER} streaming {REPORT_HZ} report frames/s; {args.seconds:.0f} s per view; "
            f"{os.cpu_count()} cores, {platform.machine()}, load average {load} at the end (the gateway, "
            f"{CONTROLLERS} simulators and the browser share the machine).\n\n" + table(results, args.seconds) +
            "\n\nFrame rate counts requestAnimationFrame callbacks (headless chromium is not tied to a 60 Hz "
            "display). Main thread busy is the renderer's TaskDuration over the window. Gaps are frames missing "
            "from the controller's own sequence numbers as the page saw them: 0 means the page counted every frame "
            "the simulator sent, so a count under 500/s is the simulator's pulse train slowing on the shared "
            "machine, not frames lost on the way.")
    print(text)
    if not args.no_results:
        write_results(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
