#!/usr/bin/python3
"""Benchmark: REST and WebSocket latency while jobs write their step events to the store.

The job store commits every step event (SQLite, WAL, synchronous=FULL); where that commit runs on the
gateway's I/O thread, each fsync may hold up HTTP, WebSocket, MQTT and serial polling. This script
shows the effect, for one or more gateway binaries side by side in one run. For each binary (in the
order given) it starts the real gateway on a fresh scratch storage directory with --controllers
simulated controllers (in-process, --time-scale, --poll-ms), then measures two phases of --seconds:

1. baseline: no job running;
2. jobs: array jobs with many short steps (a 20 x 20 grid of 10 um steps, no dwell, advance timer:
   400 steps, resubmitted as soon as one ends) on sim1, sim2 and sim3 at once.

In both phases the last controller (the watched one, sim4 by default) keeps moving (slow moves from
one end of X to the other, so its position changes at every poll and a position event is due every
--poll-ms), and the script records:

* GET /api/v1/controllers/{watched} issued at --rate per second on a steady schedule over one
  keep-alive connection: latency from sending the request to reading the whole answer;
* the interarrival of WebSocket events on controllers/{watched}/position (a stdlib WebSocket client
  subscribed as the dashboard does), by the client's receive time.

It prints one markdown table (p50 / p99 / max of both, per binary and phase, with the step events per
second the jobs made) and, with --results, appends it to bench/RESULTS.md as a new section. Standard
library only; run with Debian's /usr/bin/python3:

  scripts/build && /usr/bin/python3 bench/store_latency.py                      # the current build
  /usr/bin/python3 bench/store_latency.py --gateway before=OLD/asi-gateway --gateway after=NEW/asi-gateway

The scratch directory is on --tmp-dir (default: the system's temporary directory); on a tmpfs an
fsync costs nothing and the benchmark shows nothing, so the filesystem is printed with the results.
A fast disk hides the effect too; --fsync-delay-ms N makes every fsync of the gateways N ms longer (a
slow or busy disk, reproducibly: bench/slow_fsync.c, preloaded).
"""

import argparse
import datetime
import json
import os
import platform
import shlex
import shutil
import subprocess
import sys
import tempfile
import threading
import time

from gateway_rig import (ROOT, TERMINAL, Http, WsClient, free_port, git_commit, load_average, log_tail,
                         start_gateway, stop_process)

# A1 at a fixed place, 10 um steps: every step is a short move, so the steps (and their store commits)
# come as fast as the job's arrival polling allows.
SPEC = {"grid": {"columns": 20, "rows": 20, "column_step_mm": 0.01, "row_step_mm": 0.01},
        "a1": {"X": 0, "Y": 0}, "dwell_ms": 0, "advance": "timer"}
JOB_CONTROLLERS = 3


class WsPositions(WsClient):
    """Subscribed to one topic: records the receive time of every event on it."""

    def __init__(self, port, topic):
        super().__init__(port, topic)
        self.topic = topic
        self.marker = f'"topic":"{topic}"'.encode()
        self.lock = threading.Lock()
        self.times = []  # monotonic receive times of the topic's events

    def take(self):
        """The receive times so far; starts a new list."""
        with self.lock:
            out, self.times = self.times, []
        return out

    def on_message(self, payload, received):
        if b'"type":"event"' in payload and self.marker in payload:
            with self.lock:
                self.times.append(received)


def percentile(values, p):
    """Nearest-rank percentile of a non-empty list."""
    s = sorted(values)
    k = max(0, min(len(s) - 1, int(round(p / 100 * len(s) + 0.5)) - 1))
    return s[k]


def summary_ms(values):
    if not values:
        return None
    return {"n": len(values), "p50": percentile(values, 50) * 1000, "p99": percentile(values, 99) * 1000,
            "max": max(values) * 1000}


class Gateway:
    """One binary on a fresh scratch directory: start, phases, stop."""

    def __init__(self, label, binary, args):
        self.label = label
        self.binary = binary
        self.args = args
        self.tmp = tempfile.mkdtemp(prefix="asi-store-latency-", dir=args.tmp_dir)
        self.port = free_port()
        self.proc = None
        self.ws = None
        self.watched = f"sim{args.controllers}"
        self.stop_mover = threading.Event()
        self.mover = None
        self.mover_error = None

    def start(self):
        a = self.args
        config = {
            "http": {"listen_address": "127.0.0.1", "port": self.port},
            "simulate": {"count": a.controllers, "time_scale": a.time_scale,
                         "directory": os.path.join(self.tmp, "sims")},
            "storage": {"path": os.path.join(self.tmp, "store")},
            "logging": {"level": "warn"},
        }
        self.proc = start_gateway([self.binary], config, self.tmp, self.port, ["--poll-ms", str(a.poll_ms)])
        self.ws = WsPositions(self.port, f"controllers/{self.watched}/position")
        self.ws.start()
        # The watched stage moves slowly from end to end (about 2 mm/s of real time whatever the time
        # scale): its position changes at every poll, so a position event is due every poll.
        h = Http(self.port)
        speed = min(50.0, max(0.001, 2.0 / a.time_scale))
        status, text = h.request("POST", f"/api/v1/controllers/{self.watched}/speed", {"axes": {"X": speed}})
        if status != 200:
            raise RuntimeError(f"speed on {self.watched}: {status} {text[:300]}")
        self.mover = threading.Thread(target=self.move_forever, daemon=True)
        self.mover.start()
        time.sleep(2)  # the first move under way
        self.ws.take()

    def move_forever(self):
        """Moves without "wait" (a waited move polls STATUS on the same serial link as the position polls),
        reversing once the stage is idle (read every 0.5 s)."""
        h = Http(self.port)
        target = 100000
        try:
            while not self.stop_mover.is_set():
                status, text = h.request("POST", f"/api/v1/controllers/{self.watched}/move", {"axes": {"X": target}})
                if status != 200:
                    raise RuntimeError(f"move on {self.watched}: {status} {text[:300]}")
                time.sleep(1)
                while not self.stop_mover.wait(0.5):
                    status, text = h.request("GET", f"/api/v1/controllers/{self.watched}")
                    if status == 200 and not json.loads(text).get("busy"):
                        break
                target = -target
        except Exception as e:  # noqa: BLE001 - reported with the phase
            self.mover_error = str(e)

    def log_tail(self, n=30):
        return log_tail(self.tmp, n)

    def job_worker(self, controller, stop, counts, errors):
        """Array jobs one after the other on `controller` until `stop`; the last one is cancelled."""
        h = Http(self.port)
        try:
            while not stop.is_set():
                status, text = h.request("POST", "/api/v1/jobs", {"controller": controller, "type": "array",
                                                                  "spec": SPEC})
                if status != 201:
                    raise RuntimeError(f"submit on {controller}: {status} {text[:300]}")
                job = json.loads(text)
                counts["path"] = job.get("path")
                state, cancelled = None, False
                while state not in TERMINAL:
                    if stop.wait(self.args.job_poll_s) and not cancelled:
                        h.request("POST", f"/api/v1/jobs/{job['id']}/cancel", {})
                        cancelled = True
                    status, text = h.request("GET", f"/api/v1/jobs/{job['id']}")
                    record = json.loads(text) if status == 200 else {}
                    state = record.get("state")
                    if stop.is_set() and state not in TERMINAL:
                        time.sleep(0.1)
                counts["steps"] += record.get("progress", {}).get("steps_done", 0)
                counts["jobs"] += 1
                counts["failed"] += state not in ("succeeded", "cancelled")
        except Exception as e:  # noqa: BLE001 - reported once the phase ends
            errors.append(f"{controller}: {e}")

    def phase(self, name, with_jobs):
        a = self.args
        stop = threading.Event()
        workers, counts, errors = [], [], []
        if with_jobs:
            for i in range(JOB_CONTROLLERS):
                c = {"controller": f"sim{i + 1}", "steps": 0, "jobs": 0, "failed": 0, "path": None}
                counts.append(c)
                t = threading.Thread(target=self.job_worker, args=(c["controller"], stop, c, errors), daemon=True)
                workers.append(t)
                t.start()
            time.sleep(1)  # the jobs under way before the window opens
        h = Http(self.port)
        latencies, bad = [], 0
        self.ws.take()
        t0 = time.monotonic()
        period = 1.0 / a.rate
        i = 0
        while True:
            due = t0 + i * period
            if due - t0 >= a.seconds:
                break
            now = time.monotonic()
            if due > now:
                time.sleep(due - now)
            sent = time.monotonic()
            status, _ = h.request("GET", f"/api/v1/controllers/{self.watched}")
            latencies.append(time.monotonic() - sent)
            bad += status != 200
            i += 1
        window = time.monotonic() - t0
        arrivals = self.ws.take()
        stop.set()
        for t in workers:
            t.join(timeout=60)
        if self.proc.poll() is not None:
            raise RuntimeError("the gateway died:\n" + self.log_tail())
        if errors:
            raise RuntimeError("; ".join(errors))
        gaps = [b - a_ for a_, b in zip(arrivals, arrivals[1:])]
        steps = sum(c["steps"] for c in counts)
        return {"gateway": self.label, "phase": name, "window_s": window, "get": summary_ms(latencies),
                "get_not_ok": bad, "ws": summary_ms(gaps), "ws_events": len(arrivals),
                "jobs": sum(c["jobs"] for c in counts), "failed": sum(c["failed"] for c in counts),
                "steps_per_s": steps / window if with_jobs else 0.0,
                "paths": ", ".join(f"{c['controller']} {c['path']}" for c in counts),
                "mover_error": self.mover_error, "ws_error": self.ws.error}

    def stop(self):
        self.stop_mover.set()
        stop_process(self.proc)
        if not self.args.keep:
            shutil.rmtree(self.tmp, ignore_errors=True)
        else:
            print(f"kept {self.tmp}")


def cpu_model():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "?"


def filesystem(path):
    """'ext4 on /dev/vda (rotational)' for the filesystem that holds `path`."""
    try:
        out = subprocess.run(["findmnt", "-n", "-o", "FSTYPE,SOURCE", "-T", path], capture_output=True, text=True,
                             check=False).stdout.split()
    except OSError:
        return "?"
    if len(out) < 2:
        return "?"
    fstype, source = out[0], out[1]
    text = f"{fstype} on {source}"
    dev = os.path.basename(source)
    try:
        with open(f"/sys/block/{dev}/queue/rotational") as f:
            text += " (the kernel reports it rotational)" if f.read().strip() == "1" else " (non-rotational)"
    except OSError:
        pass
    return text


def fmt(s, key):
    return "-" if s is None else f"{s[key]:.1f}"


def table(rows):
    lines = ["| gateway | phase | GET p50 ms | GET p99 ms | GET max ms | GETs | WS position p50 ms | "
             "WS p99 ms | WS max ms | WS events | step events/s |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        g, w = r["get"], r["ws"]
        lines.append(f"| {r['gateway']} | {r['phase']} | {fmt(g, 'p50')} | {fmt(g, 'p99')} | {fmt(g, 'max')} | "
                     f"{g['n'] if g else 0} | {fmt(w, 'p50')} | {fmt(w, 'p99')} | {fmt(w, 'max')} | "
                     f"{r['ws_events']} | {r['steps_per_s']:.0f} |")
    return "\n".join(lines)


def slow_disk(delay_ms):
    """Builds bench/slow_fsync.c and preloads it into the gateways started from now on."""
    out = os.path.join(tempfile.mkdtemp(prefix="gw-slow-fsync-"), "slow_fsync.so")
    subprocess.run(["cc", "-shared", "-fPIC", "-O2", "-o", out, os.path.join(ROOT, "bench", "slow_fsync.c"),
                    "-ldl"], check=True)
    os.environ["LD_PRELOAD"] = out
    os.environ["GW_BENCH_FSYNC_DELAY_US"] = str(int(delay_ms * 1000))


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--gateway", action="append", default=[],
                   help="LABEL=PATH or PATH (repeatable; default build/gateway/asi-gateway)")
    p.add_argument("--seconds", type=float, default=25, help="length of each phase")
    p.add_argument("--rate", type=float, default=50, help="GET requests per second")
    p.add_argument("--controllers", type=int, default=4, help="simulated controllers (jobs on the first three, "
                                                              "the last one watched)")
    p.add_argument("--time-scale", type=float, default=50, help="simulator speed-up (short steps, frequent commits)")
    p.add_argument("--poll-ms", type=int, default=50, help="the gateway's position polling interval")
    p.add_argument("--job-poll-s", type=float, default=0.2, help="how often a job worker reads its job's state")
    p.add_argument("--fsync-delay-ms", type=float, default=0,
                   help="a slow disk: every fsync/fdatasync of the gateways takes this much longer "
                        "(bench/slow_fsync.c, preloaded; needs cc)")
    p.add_argument("--tmp-dir", default=None, help="where the scratch storage directories go (default: $TMPDIR or /tmp)")
    p.add_argument("--results", default="", help="append the table to this file (e.g. bench/RESULTS.md) as a "
                                                 "new section")
    p.add_argument("--title", default="Latency while jobs run", help="the section's title with --results")
    p.add_argument("--keep", action="store_true", help="keep the scratch directories")
    args = p.parse_args()
    if args.controllers < JOB_CONTROLLERS + 1:
        sys.exit(f"--controllers must be at least {JOB_CONTROLLERS + 1}")
    gateways = []
    for g in args.gateway or [os.path.join(ROOT, "build", "gateway", "asi-gateway")]:
        label, sep, path = g.partition("=")
        if not sep:
            label, path = os.path.relpath(os.path.abspath(g), ROOT), g
        if not os.path.exists(path):
            sys.exit(f"no gateway at {path}: run scripts/build first")
        gateways.append((label, os.path.abspath(path)))
    if args.fsync_delay_ms > 0:
        slow_disk(args.fsync_delay_ms)
    started = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M")
    load_start = load_average()
    rows = []
    for label, path in gateways:
        gw = Gateway(label, path, args)
        try:
            gw.start()
            for name, with_jobs in (("no job", False), (f"{JOB_CONTROLLERS} array jobs", True)):
                print(f"{label}: {name} for {args.seconds:g} s ...", flush=True)
                r = gw.phase(name, with_jobs)
                rows.append(r)
                g = r["get"]
                print(f"  GET p50 {fmt(g, 'p50')} p99 {fmt(g, 'p99')} max {fmt(g, 'max')} ms; WS p50 "
                      f"{fmt(r['ws'], 'p50')} p99 {fmt(r['ws'], 'p99')} max {fmt(r['ws'], 'max')} ms "
                      f"({r['ws_events']} events); {r['jobs']} jobs, {r['steps_per_s']:.0f} steps/s"
                      f"{' (' + r['paths'] + ')' if with_jobs else ''}", flush=True)
                for key in ("mover_error", "ws_error"):
                    if r[key]:
                        print(f"  note: {key}: {r[key]}")
                if r["get_not_ok"] or r["failed"]:
                    print(f"  note: {r['get_not_ok']} GETs not 200, {r['failed']} jobs neither succeeded nor "
                          f"cancelled")
        except Exception as e:  # noqa: BLE001
            print(f"error ({label}): {e}\n{gw.log_tail()}", file=sys.stderr)
            gw.stop()
            return 1
        gw.stop()
    load_end = load_average()
    tmp = args.tmp_dir or tempfile.gettempdir()
    lines = [f"## {args.title}", "",
             f"`bench/store_latency.py`, run of {started} UTC, commit {git_commit()}: " +
             "; ".join(f"`{label}` = `{os.path.relpath(path, ROOT) if not os.path.relpath(path, ROOT).startswith('..') else path}`"
                       for label, path in gateways) + ".", "",
             f"Each gateway on a fresh storage directory in {tmp} ({filesystem(tmp)}), {args.controllers} "
             f"simulated controllers (time scale {args.time_scale:g}, --poll-ms {args.poll_ms}); "
             f"sim{args.controllers} moves all the time. GET /api/v1/controllers/sim{args.controllers} at "
             f"{args.rate:g}/s (send to answer, one keep-alive connection); WebSocket interarrival of "
             f"controllers/sim{args.controllers}/position events (client receive times); each phase "
             f"{args.seconds:g} s. Jobs: 20 x 20 array jobs of 10 um steps, no dwell, on sim1-sim3, resubmitted "
             f"as each ends; \"step events/s\" is the steps the jobs completed (each one a store commit) per "
             f"second of the window (about: it counts the jobs' steps from 1 s before the window to their "
             f"cancellation after it)." +
             (f" Every fsync/fdatasync of the gateways took {args.fsync_delay_ms:g} ms longer (a slow disk: "
              f"bench/slow_fsync.c preloaded)." if args.fsync_delay_ms > 0 else ""), "",
             "Command: `/usr/bin/python3 " + shlex.join(sys.argv) + "`", "",
             f"Machine: {cpu_model()}, {os.cpu_count()} cores (nproc), shared with other work: load average "
             f"{load_start} at the start, {load_end} at the end (1, 5, 15 min); Debian "
             f"{open('/etc/debian_version').read().strip() if os.path.exists('/etc/debian_version') else '?'}, "
             f"kernel {platform.release()}, Python {platform.python_version()}.", "",
             table(rows), ""]
    paths = sorted({r["paths"] for r in rows if r["paths"]})
    if paths:
        lines += [f"Job paths: {'; '.join(paths)}.", ""]
    text = "\n".join(lines)
    print("\n" + text)
    if args.results:
        old = ""
        if os.path.exists(args.results):
            with open(args.results) as f:
                old = f.read()
        with open(args.results, "w") as f:
            f.write(old.rstrip("\n") + "\n\n" + text)
        print(f"appended the section to {args.results}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
