#!/usr/bin/python3
"""Benchmark: gcode jobs traced on a simulated MS-2000 - deviation from the ideal path and traced time.

Starts the simulator executable (ms2000-sim, preset "full", with its control socket) and the real
asi-gateway with that controller in its config, then for each case (a square, a circle, a spiral with
the TTL output on along it) submits a gcode job, records the simulator's encoder positions and TTL
output while it runs (the control socket's "state", polled as fast as it answers: the simulator's
positions are exact on each axis's motion profile), and reports:

  * the maximum distance of any recorded position from the ideal path (lines and true arcs, computed
    here from the program's geometry, not from the gateway's segmentation), and separately of the
    positions recorded with the TTL output on from the path's lit stretches;
  * the traced time (the job record's finished - started) against the ideal time at the programmed
    feed (path length / F, rapids at the rapid speed, plus dwells) and the plan's estimate.

Why the gateway is not started with --simulate (as bench/job_eta.py does): its in-process simulators
have no control socket, and the gateway's own position polls (20 ms) are too sparse to find the worst
point of a path. The controller here is the same simulator code behind a pty, as a real one would be.

Prints a table and appends (or replaces) the "G-code traces" section of bench/RESULTS.md. Standard
library only; run with Debian's /usr/bin/python3 (see bench/README.md).
"""

import argparse
import datetime
import json
import math
import os
import platform
import shutil
import socket
import subprocess
import sys
import tempfile
import threading
import time

from bench_gateway import Gateway, parse_time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
ARC_TOLERANCE_UM = 1.0  # the jobs' default arc_tolerance_mm (chord sagitta)
FINISH_ERROR_UM = 0.022  # one encoder count of the B screw: targets are quantised to it
RAPID_MM_S = 5.5  # gcode_options.rapid_mm_s
SECTION = "## G-code traces (bench/gcode_trace.py)"


# --- the cases: programs generated with their exact geometry ---------------------------------------

class Path:
    """Ideal path: pieces ("line", a, b, feed, ttl) and ("arc", centre, r, a0, sweep, feed, ttl)."""

    def __init__(self):
        self.lines = ["%", "G21 G90 G17"]
        self.pieces = []
        self.at = (0.0, 0.0)
        self.ttl = False
        self.dwell_s = 0.0

    def rapid(self, x, y):
        self.lines.append(f"G00 X{x:.6f} Y{y:.6f}")
        self.pieces.append(("line", self.at, (x, y), RAPID_MM_S, self.ttl))
        self.at = (x, y)

    def line(self, x, y, feed_mm_min):
        self.lines.append(f"G01 X{x:.6f} Y{y:.6f} F{feed_mm_min:g}")
        self.pieces.append(("line", self.at, (x, y), feed_mm_min / 60.0, self.ttl))
        self.at = (x, y)

    def arc_ccw(self, cx, cy, sweep, feed_mm_min):
        """Counter-clockwise arc about (cx, cy) by `sweep` radians (<= 2 pi) from the current point."""
        x0, y0 = self.at
        r = math.hypot(x0 - cx, y0 - cy)
        a0 = math.atan2(y0 - cy, x0 - cx)
        x1, y1 = cx + r * math.cos(a0 + sweep), cy + r * math.sin(a0 + sweep)
        if abs(sweep - 2 * math.pi) < 1e-12:
            x1, y1 = x0, y0
        self.lines.append(f"G03 X{x1:.6f} Y{y1:.6f} I{cx - x0:.6f} J{cy - y0:.6f} F{feed_mm_min:g}")
        self.pieces.append(("arc", (cx, cy), r, a0, sweep, feed_mm_min / 60.0, self.ttl))
        self.at = (x1, y1)

    def laser(self, on):
        self.lines.append("M03" if on else "M05")
        self.ttl = on

    def dwell(self, ms):
        self.lines.append(f"G04 P{ms}")
        self.dwell_s += ms / 1000.0

    def program(self):
        return "\n".join(self.lines + ["%"]) + "\n"

    def ideal_s(self):
        t = self.dwell_s
        for p in self.pieces:
            if p[0] == "line":
                t += math.dist(p[1], p[2]) / p[3]
            else:
                t += abs(p[2] * p[4]) / p[5]
        return t

    def length_mm(self):
        return sum(math.dist(p[1], p[2]) if p[0] == "line" else abs(p[2] * p[4]) for p in self.pieces)


def square():
    p = Path()
    p.rapid(1, 1)
    p.laser(True)
    for x, y in [(5, 1), (5, 5), (1, 5), (1, 1)]:
        p.line(x, y, 120)
    p.laser(False)
    p.rapid(0, 0)
    return p


def circle():
    p = Path()
    p.rapid(4, 2)
    p.laser(True)
    p.arc_ccw(2, 2, 2 * math.pi, 60)  # radius 2 mm, 1 mm/s
    p.laser(False)
    p.rapid(0, 0)
    return p


def spiral():
    """Half circles about alternating centres (a classic G-code spiral), lit, with a dwell at the start."""
    p = Path()
    p.rapid(3, 3)
    p.laser(True)
    p.dwell(200)
    r = 0.25
    for i in range(8):
        # Centre on the x axis through the current point, alternately ahead and behind: the radius
        # grows by 0.25 mm every half turn.
        x, y = p.at
        cx = x + r if i % 2 == 0 else x - r
        p.arc_ccw(cx, y, math.pi, 90)
        r += 0.125
    p.laser(False)
    p.rapid(0, 0)
    return p


CASES = [("square 4 mm, F120, TTL on", square), ("circle r 2 mm, F60, TTL on", circle),
         ("spiral 8 half turns, F90, TTL on, G04", spiral)]


def distance_to_piece(piece, x, y):
    if piece[0] == "line":
        (ax, ay), (bx, by) = piece[1], piece[2]
        dx, dy = bx - ax, by - ay
        l2 = dx * dx + dy * dy
        t = 0.0 if l2 == 0 else max(0.0, min(1.0, ((x - ax) * dx + (y - ay) * dy) / l2))
        return math.hypot(x - (ax + t * dx), y - (ay + t * dy))
    (cx, cy), r, a0, sweep = piece[1], piece[2], piece[3], piece[4]
    a = math.atan2(y - cy, x - cx)
    rel = (a - a0) % (2 * math.pi) if sweep > 0 else (a0 - a) % (2 * math.pi)
    if rel <= abs(sweep) + 1e-12:
        return abs(math.hypot(x - cx, y - cy) - r)
    ends = [(cx + r * math.cos(a0), cy + r * math.sin(a0)),
            (cx + r * math.cos(a0 + sweep), cy + r * math.sin(a0 + sweep))]
    return min(math.hypot(x - ex, y - ey) for ex, ey in ends)


def distance_to_path(path, x, y, ttl=None):
    return min(distance_to_piece(p, x, y) for p in path.pieces if ttl is None or p[-1] == ttl)


# --- processes --------------------------------------------------------------------------------------

class Simulator:
    def __init__(self, binary, workdir, time_scale):
        self.link = os.path.join(workdir, "sim", "port")
        self.control = os.path.join(workdir, "sim.sock")
        self.log = open(os.path.join(workdir, "sim.log"), "w")
        self.proc = subprocess.Popen(
            [binary, "--preset", "full", "--name", "trace", "--link", self.link, "--baud", "115200",
             "--time-scale", str(time_scale), "--control", self.control],
            stdout=self.log, stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 20
        while not (os.path.exists(self.link) and os.path.exists(self.control)):
            if self.proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError("the simulator did not start; see sim.log")
            time.sleep(0.05)

    def connect(self):
        s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        s.connect(self.control)
        return s.makefile("rw", buffering=1)

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            self.proc.wait(10)
        self.log.close()


class Recorder(threading.Thread):
    """Polls the simulator's state: (time_us, x_um, y_um, ttl_on) as fast as the socket answers."""

    def __init__(self, sim):
        super().__init__(daemon=True)
        self.io = sim.connect()
        self.samples = []
        self.running = True

    def run(self):
        while self.running:
            self.io.write("state\n")
            st = json.loads(self.io.readline())
            ax = st["axes"]
            self.samples.append((st["time_us"], ax["X"]["position"] / 10.0, ax["Y"]["position"] / 10.0,
                                 st["ttl"]["out0_mode"] == 1))

    def stop(self):
        self.running = False
        self.join(10)
        return self.samples



def run_case(gw, sim, name, make, time_scale, timeout):
    path = make()
    row = {"case": name, "length_mm": path.length_mm(), "ideal_s": path.ideal_s()}
    body = {"controller": "trace", "type": "gcode", "spec": {"program": path.program()}}
    status, dry = gw.request("POST", "/api/v1/jobs?dry_run=true", body)
    if status != 200 or not isinstance(dry, dict) or "plan" not in dry:
        row["status"] = f"refused: {status} {dry}"
        return row
    row["estimated_s"] = dry["plan"]["estimated_s"]
    row["steps"] = dry["plan"]["steps_total"]
    recorder = Recorder(sim)
    recorder.start()
    status, job = gw.request("POST", "/api/v1/jobs", body)
    if status not in (200, 201):
        recorder.stop()
        row["status"] = f"submit refused: {status} {job}"
        return row
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        status, job = gw.request("GET", f"/api/v1/jobs/{job['id']}")
        if job.get("state") in ("succeeded", "failed", "cancelled", "interrupted"):
            break
        time.sleep(0.05)
    time.sleep(0.1)
    samples = recorder.stop()
    row["state"] = job.get("state")
    if job.get("state") != "succeeded":
        row["status"] = f"{job.get('state')}: {job.get('reason', '')}"
        return row
    row["traced_s"] = (parse_time(job["finished"]) - parse_time(job["started"])) * time_scale
    row["samples"] = len(samples)
    worst = worst_lit = 0.0
    worst_at = None
    rises = 0
    for i, (_, x, y, ttl) in enumerate(samples):
        d = distance_to_path(path, x / 1000.0, y / 1000.0) * 1000.0
        if d > worst:
            worst, worst_at = d, (round(x, 2), round(y, 2))
        if ttl:
            worst_lit = max(worst_lit, distance_to_path(path, x / 1000.0, y / 1000.0, ttl=True) * 1000.0)
        if i and ttl and not samples[i - 1][3]:
            rises += 1
    row["max_dev_um"] = worst
    row["max_dev_at"] = worst_at
    row["max_dev_lit_um"] = worst_lit
    row["ttl_rises"] = rises
    row["ttl_planned"] = sum(1 for line in path.lines if line == "M03")
    row["status"] = "ok"
    return row


def table(rows, time_scale):
    head = ("| case | path mm | samples | max deviation um | lit: max deviation um | TTL on (planned) "
            "| ideal s | traced s | traced / ideal | plan estimate s | estimate error |")
    out = [head, "| " + " | ".join(["---"] * 11) + " |"]
    for r in rows:
        if r.get("status") != "ok":
            out.append(f"| {r['case']} | | | {r.get('status')} | | | | | | | |")
            continue
        out.append(
            f"| {r['case']} | {r['length_mm']:.2f} | {r['samples']} | {r['max_dev_um']:.3f} | "
            f"{r['max_dev_lit_um']:.3f} | {r['ttl_rises']} ({r['ttl_planned']}) | {r['ideal_s']:.2f} | "
            f"{r['traced_s']:.2f} | {r['traced_s'] / r['ideal_s']:.2f} | {r['estimated_s']:.2f} | "
            f"{(r['estimated_s'] - r['traced_s']) / r['traced_s'] * 100:+.1f} % |")
    return "\n".join(out)


def write_results(rows, args, text):
    path = os.path.join(HERE, "RESULTS.md")
    old = open(path).read() if os.path.exists(path) else "# Benchmark results\n"
    # Replace only our own section (up to the next "## " heading that is not ours).
    start = old.find(SECTION)
    if start >= 0:
        end = old.find("\n## ", start + len(SECTION))
        old = old[:start].rstrip("\n") + ("\n\n" + old[end + 1:] if end >= 0 else "\n")
    limit = ARC_TOLERANCE_UM + FINISH_ERROR_UM
    ok = all(r.get("status") == "ok" and r["max_dev_um"] <= limit for r in rows)
    section = [
        SECTION, "",
        f"Run {datetime.datetime.now():%Y-%m-%d %H:%M}, {platform.node()}, {os.cpu_count()} cores, load "
        f"average {' '.join(f'{x:.1f}' for x in os.getloadavg())} (1, 5, 15 min; at the end), gateway "
        f"{os.path.relpath(args.gateway, ROOT)}; simulator time scale {args.time_scale}, 115200 baud, lead screw "
        "B (SPEED 5.5 mm/s, ACCEL 20 ms, settle 14 ms); arc tolerance 1 um.", "",
        text, "",
        f"Every recorded position within arc tolerance + finish error ({limit:.3f} um) of the ideal path: "
        f"{'yes' if ok else 'NO'}. \"traced / ideal\": the job's duration over path length / F (rapids at "
        f"{RAPID_MM_S} mm/s, dwells included). Each straight segment is one MOVE that starts and stops "
        "(ramps of 20 ms, 14 ms settle, then the gateway's 20 ms STATUS polling notices the arrival, then "
        "SPEED and MOVE for the next segment go over the wire): arcs, cut into chords within 1 um of the arc (a tenth "
        "of a millimetre or so each), pay this per segment; long straight lines barely do. The plan estimate "
        "(`?dry_run=true`) counts all of it: ramps and settle (motion_profile), and per segment the SPEED and "
        "MOVE round trips at the link's baud and the STATUS polling lag (devices/ms2000/host_step_timing), "
        "plus the approach from where the stage stands; \"estimate error\" is (estimate - traced) / traced, "
        "target within 10 %. Busier machines trace slower (the polls and replies wait for a CPU).", "",
    ]
    with open(path, "w") as f:
        f.write(old.rstrip("\n") + "\n\n" + "\n".join(section))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gateway", default=os.path.join(ROOT, "build", "gateway", "asi-gateway"))
    ap.add_argument("--sim", default=os.path.join(ROOT, "build", "devices", "sim", "ms2000-sim"))
    ap.add_argument("--time-scale", type=float, default=1.0,
                    help="simulator speed-up; durations are multiplied back (default 1: real time)")
    ap.add_argument("--no-results", action="store_true", help="print only, do not touch RESULTS.md")
    ap.add_argument("--keep", action="store_true", help="keep the scratch directory")
    args = ap.parse_args()
    for b in (args.gateway, args.sim):
        if not os.access(b, os.X_OK):
            sys.exit(f"{b} not found: build it first (scripts/build)")
    workdir = tempfile.mkdtemp(prefix="gw-gcode-bench-")
    sim = gw = None
    rows = []
    try:
        sim = Simulator(args.sim, workdir, args.time_scale)
        gw = Gateway(args.gateway, workdir, {"controllers": [{"id": "trace", "port": sim.link, "baud": 115200}]})
        gw.wait_ready()
        for name, make in CASES:
            row = run_case(gw, sim, name, make, args.time_scale, timeout=600)
            rows.append(row)
            print(f"{name}: {row.get('status')}", flush=True)
    finally:
        if gw:
            gw.stop()
        if sim:
            sim.stop()
        if args.keep:
            print("scratch directory:", workdir)
        else:
            shutil.rmtree(workdir, ignore_errors=True)
    text = table(rows, args.time_scale)
    print(text)
    if not args.no_results:
        write_results(rows, args, text)
    limit = ARC_TOLERANCE_UM + FINISH_ERROR_UM
    return 0 if rows and all(r.get("status") == "ok" and r["max_dev_um"] <= limit for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
