#!/usr/bin/python3
"""Benchmark: the gateway's resident memory over many finished jobs (issue 12, point 6).

Starts the real asi-gateway on simulated controllers (in-process, `simulate.count`, a fast time
scale), a WebSocket client subscribed to `jobs/#` that reads every event (a dashboard), and, when
mosquitto is installed, a broker with the MQTT bridge enabled (retained job states). Then it runs
--jobs short array jobs (a 3 x 2 grid: six steps), one after the other on each controller, the
controllers in parallel, and records the gateway's VmRSS (and RssAnon) from /proc every --every
jobs, with the event hub's topic count and replay bytes from /api/v1/metrics when the gateway has
them (gw_events_topics, gw_events_replay_bytes). At the end it waits until the ended jobs' topics
have left the hub (events.ended_job_topic_ttl_s, --topic-ttl-s) and records once more.

Prints the trend and replaces the "Reliability: memory over finished jobs" section of bench/RESULTS.md
(the other sections, the other Reliability ones included, are kept as they are). Standard library only; run with Debian's /usr/bin/python3:

  scripts/build && /usr/bin/python3 bench/job_rss.py              # 10,000 jobs, about 15-25 min
  /usr/bin/python3 bench/job_rss.py --jobs 600 --every 100 --no-results   # a quick look
  /usr/bin/python3 bench/job_rss.py --topic-ttl-s none ...        # a gateway without the key
"""

import argparse
import datetime
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import threading
import time

from bench_broker import MOSQUITTO, Mosquitto
from gateway_rig import (HERE, ROOT, TERMINAL, Http, WsClient, free_port, git_commit, load_average, log_tail,
                         start_gateway, stop_process, wait_until)

SECTION = "Reliability: memory over finished jobs"
# A1 at a fixed place: with "current" each job would start where the last one ended and the stage would
# walk off its soft limits after a few thousand jobs.
SPEC = {"grid": {"columns": 3, "rows": 2, "column_step_mm": 0.1, "row_step_mm": 0.1}, "a1": {"X": 0, "Y": 0},
        "dwell_ms": 0, "advance": "timer"}


def metrics(port):
    """/api/v1/metrics as {name: value} for the label-less series."""
    status, text = Http(port).request("GET", "/api/v1/metrics")
    out = {}
    if status != 200:
        return out
    for line in text.splitlines():
        if line and not line.startswith("#") and "{" not in line:
            name, _, value = line.rpartition(" ")
            out[name] = float(value)
    return out


def rss_kib(pid):
    out = {}
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            key, _, value = line.partition(":")
            if key in ("VmRSS", "RssAnon"):
                out[key] = int(value.split()[0])
    return out


class WsReader(WsClient):
    """Subscribed to `topic_filter`: reads (and counts) every message until closed."""

    def __init__(self, port, topic_filter):
        super().__init__(port, topic_filter)
        self.messages = 0
        self.events = 0

    def on_message(self, payload, received):
        self.messages += 1
        if b'"type":"event"' in payload:
            self.events += 1


class Run:
    def __init__(self, args):
        self.args = args
        self.tmp = tempfile.mkdtemp(prefix="asi-job-rss-")
        self.procs = []
        self.port = free_port()
        self.broker_port = None
        self.gateway = None
        self.pid = None
        self.done = 0
        self.failed = 0
        self.lock = threading.Lock()
        self.samples = []  # (jobs done, elapsed s, VmRSS KiB, RssAnon KiB, topics, replay bytes)
        self.t0 = None

    def start(self):
        a = self.args
        mqtt = a.mqtt and os.path.exists(MOSQUITTO)
        if mqtt:
            broker = Mosquitto(self.tmp)
            self.broker_port = broker.port
            self.procs.append(broker.proc)
        config = {
            "http": {"listen_address": "127.0.0.1", "port": self.port},
            "simulate": {"count": a.controllers, "time_scale": a.time_scale,
                         "directory": os.path.join(self.tmp, "sims")},
            "storage": {"path": os.path.join(self.tmp, "store")},
            "jobs": {"max_queued_per_controller": 10},
            "logging": {"level": "warn"},
        }
        if a.topic_ttl_s != "none":
            config["events"] = {"ended_job_topic_ttl_s": int(a.topic_ttl_s)}
        if mqtt:
            config["mqtt"] = {"enabled": True, "brokers": [f"mqtt://127.0.0.1:{self.broker_port}"],
                              "gateway_id": "bench"}
            if a.topic_ttl_s == "none":  # an older gateway: its own clearing time
                config["mqtt"]["jobs"] = {"retain_finished_s": 5}
        wrapper = ["heaptrack", "-o", a.heaptrack] if a.heaptrack else []
        self.gateway = start_gateway([*wrapper, a.gateway], config, self.tmp, self.port)
        self.procs.append(self.gateway)
        self.pid = self.gateway.pid
        if a.heaptrack:  # the gateway is heaptrack's child
            self.pid = wait_until("the gateway under heaptrack", lambda: gateway_pid(self.gateway.pid, a.gateway))
        self.mqtt = mqtt
        self.ws = WsReader(self.port, "jobs/#") if a.ws else None
        if self.ws:
            self.ws.start()

    def log_tail(self, n=30):
        return log_tail(self.tmp, n)

    def sample(self):
        m = metrics(self.port)
        r = rss_kib(self.pid)
        with self.lock:
            done = self.done
        s = (done, time.monotonic() - self.t0, r.get("VmRSS"), r.get("RssAnon"), m.get("gw_events_topics"),
             m.get("gw_events_replay_bytes"))
        self.samples.append(s)
        print(f"{s[0]:>6} jobs {s[1]:7.0f} s  VmRSS {s[2] / 1024:7.1f} MiB  RssAnon {s[3] / 1024:7.1f} MiB  "
              f"topics {fmt_count(s[4])}  replay {fmt_kib(s[5])}", flush=True)

    def worker(self, controller, count):
        h = Http(self.port)
        for _ in range(count):
            status, text = h.request("POST", "/api/v1/jobs", {"controller": controller, "type": "array",
                                                              "spec": SPEC})
            if status != 201:
                raise RuntimeError(f"submit on {controller}: {status} {text[:300]}")
            job = json.loads(text)["id"]
            while True:
                status, text = h.request("GET", f"/api/v1/jobs/{job}")
                state = json.loads(text).get("state") if status == 200 else None
                if state in TERMINAL:
                    break
                time.sleep(0.01)
            with self.lock:
                self.done += 1
                self.failed += state != "succeeded"

    def run_jobs(self):
        a = self.args
        controllers = [f"sim{i + 1}" for i in range(a.controllers)]
        share = [a.jobs // len(controllers) + (i < a.jobs % len(controllers)) for i in range(len(controllers))]
        errors = []

        def guarded(c, n):
            try:
                self.worker(c, n)
            except Exception as e:  # noqa: BLE001 - reported once the others end
                errors.append(f"{c}: {e}")

        threads = [threading.Thread(target=guarded, args=(c, n), daemon=True) for c, n in zip(controllers, share)]
        self.t0 = time.monotonic()
        self.sample()
        for t in threads:
            t.start()
        next_mark = a.every
        while any(t.is_alive() for t in threads):
            time.sleep(0.2)
            with self.lock:
                done = self.done
            if done >= next_mark:
                self.sample()
                next_mark += a.every
            if self.gateway.poll() is not None:
                raise RuntimeError("the gateway died:\n" + self.log_tail())
        if errors:
            raise RuntimeError("; ".join(errors))
        if self.samples[-1][0] != self.done:
            self.sample()
        self.run_s = time.monotonic() - self.t0

    def settle(self):
        """After the last job: wait out the topics' time to live (+ the hub's and bridge's 1 s ticks)."""
        a = self.args
        wait = (int(a.topic_ttl_s) if a.topic_ttl_s != "none" else 5) + 3
        time.sleep(wait)
        self.sample()
        self.settled_after_s = wait

    def cleanup(self):
        if self.gateway and self.pid != self.gateway.pid:  # under heaptrack: stop the gateway itself
            try:
                os.kill(self.pid, 15)
            except OSError:
                pass
        for p in self.procs:
            stop_process(p)
        if not self.args.keep:
            shutil.rmtree(self.tmp, ignore_errors=True)
        else:
            print(f"kept {self.tmp}")


def gateway_pid(ancestor, binary):
    """The process below `ancestor` that runs `binary`."""
    want = os.path.realpath(binary)
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            if os.path.realpath(f"/proc/{entry}/exe") != want:
                continue
            pid = int(entry)
            while pid > 1:
                with open(f"/proc/{pid}/stat") as f:
                    pid = int(f.read().rsplit(")", 1)[1].split()[1])
                if pid == ancestor:
                    return int(entry)
        except OSError:
            continue
    return None


def fmt_count(v):
    return "-" if v is None else f"{v:.0f}"


def fmt_kib(v):
    return "-" if v is None else f"{v / 1024:.0f} KiB"


def slope_kib_per_job(points):
    """Least-squares slope of (jobs, KiB)."""
    if len(points) < 2:
        return None
    n = len(points)
    mx = sum(p[0] for p in points) / n
    my = sum(p[1] for p in points) / n
    sxx = sum((p[0] - mx) ** 2 for p in points)
    if sxx == 0:
        return None
    return sum((p[0] - mx) * (p[1] - my) for p in points) / sxx


def cpu_model():
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, check=False).stdout
        for line in out.splitlines():
            if line.startswith("Model name:"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "?"


def section(run, started, load_start, load_end):
    a = run.args
    s = run.samples
    during = [x for x in s[:-1] if x[0] > 0] if len(s) > 2 else s  # the settle sample is separate
    half = [x for x in during if x[0] >= a.jobs // 2]
    slope_all = slope_kib_per_job([(x[0], x[2]) for x in during])
    slope_half = slope_kib_per_job([(x[0], x[2]) for x in half])
    gateway = os.path.relpath(os.path.abspath(a.gateway), ROOT)
    if gateway.startswith(".."):
        gateway = os.path.basename(gateway) + " (built outside this checkout)"
    subscribers = ["a WebSocket client on `jobs/#`" if a.ws else None,
                   "the MQTT bridge (mosquitto, retained job states)" if run.mqtt else None]
    subscribers = ", ".join(x for x in subscribers if x) or "none"
    ttl = "not set (a gateway without the key)" if a.topic_ttl_s == "none" else f"{a.topic_ttl_s} s"
    lines = [f"## {SECTION} (bench/job_rss.py)", "",
             f"### RSS over {a.jobs:,} finished jobs (run of {started} UTC)", "",
             f"`bench/job_rss.py --jobs {a.jobs} --every {a.every} --time-scale {a.time_scale:g}"
             f"{' --topic-ttl-s ' + str(a.topic_ttl_s) if a.topic_ttl_s != '5' else ''}`: the real gateway "
             f"(`{gateway}`, commit {git_commit()}) on {a.controllers} simulated controllers (time scale "
             f"{a.time_scale:g}), {a.jobs:,} six-step array jobs (3 x 2 grid from X=0 Y=0, no dwell), one at a "
             f"time per controller, the controllers in parallel; subscribers: {subscribers}; "
             f"`events.ended_job_topic_ttl_s` {ttl}. VmRSS and RssAnon from /proc/<pid>/status, hub topics "
             f"and replay bytes from /api/v1/metrics.", "",
             f"Machine: {cpu_model()}, {os.cpu_count()} cores shared with other work (load average "
             f"{load_start} at the start, {load_end} at the end: 1, 5, 15 min), Debian "
             f"{open('/etc/debian_version').read().strip() if os.path.exists('/etc/debian_version') else '?'}, "
             f"{platform.machine()}. {run.run_s:.0f} s for the jobs ({a.jobs / run.run_s:.1f} jobs/s), "
             f"{run.failed} not succeeded.", "",
             "| jobs done | elapsed s | VmRSS MiB | RssAnon MiB | hub topics | hub replay KiB |",
             "| ---: | ---: | ---: | ---: | ---: | ---: |"]
    for i, x in enumerate(s):
        label = f"{x[0]:,}" + (f" (+{run.settled_after_s} s idle)" if i == len(s) - 1 and len(s) > 2 else "")
        lines.append(f"| {label} | {x[1]:.0f} | {x[2] / 1024:.1f} | {x[3] / 1024:.1f} | {fmt_count(x[4])} | "
                     f"{'-' if x[5] is None else f'{x[5] / 1024:.0f}'} |")
    lines.append("")
    fmt_slope = lambda v: "-" if v is None else f"{v:+.2f} KiB/job"  # noqa: E731
    lines.append(f"RSS slope (least squares over the samples while jobs ran): {fmt_slope(slope_all)} over all "
                 f"of them, {fmt_slope(slope_half)} over the second half (jobs {a.jobs // 2:,} on).")
    if a.notes:
        lines += ["", a.notes]
    return "\n".join(lines) + "\n"


def write_results(path, text):
    """Replaces this benchmark's section of RESULTS.md (or appends it); every other section is kept."""
    try:
        with open(path) as f:
            old = f.read()
    except OSError:
        old = ""
    parts = old.split("\n## ")
    head, rest = parts[0], parts[1:]
    kept = [p for p in rest if not p.startswith(SECTION)]
    out = head.rstrip("\n") + "\n"
    out += "".join("\n## " + p.rstrip("\n") + "\n" for p in kept)
    out += "\n" + text
    with open(path, "w") as f:
        f.write(out)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--gateway", default=os.path.join(ROOT, "build", "gateway", "asi-gateway"))
    p.add_argument("--jobs", type=int, default=10000)
    p.add_argument("--every", type=int, default=500, help="record RSS every N finished jobs")
    p.add_argument("--time-scale", type=float, default=100)
    p.add_argument("--controllers", type=int, default=3)
    p.add_argument("--topic-ttl-s", default="5",
                   help="events.ended_job_topic_ttl_s; 'none' leaves the key out (an older gateway)")
    p.add_argument("--no-ws", dest="ws", action="store_false", help="no WebSocket subscriber")
    p.add_argument("--no-mqtt", dest="mqtt", action="store_false", help="no broker, MQTT bridge off")
    p.add_argument("--results", default=os.path.join(HERE, "RESULTS.md"))
    p.add_argument("--no-results", action="store_true", help="print only, do not write RESULTS.md")
    p.add_argument("--notes", default="", help="a paragraph appended to the section")
    p.add_argument("--keep", action="store_true", help="keep the scratch directory")
    p.add_argument("--heaptrack", default="", help="run the gateway under heaptrack, writing this file")
    args = p.parse_args()
    if not os.path.exists(args.gateway):
        sys.exit(f"no gateway at {args.gateway}: run scripts/build first")
    started = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M")
    load_start = load_average(1)
    run = Run(args)
    try:
        run.start()
        run.run_jobs()
        run.settle()
        if run.ws and run.ws.error:
            print(f"note: the WebSocket subscriber ended: {run.ws.error}")
    except Exception as e:  # noqa: BLE001
        print(f"error: {e}\n{run.log_tail()}", file=sys.stderr)
        run.cleanup()
        return 1
    load_end = load_average(1)
    text = section(run, started, load_start, load_end)
    print("\n" + text)
    run.cleanup()
    if not args.no_results:
        write_results(args.results, text)
        print(f"wrote the {SECTION} section of {args.results}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
