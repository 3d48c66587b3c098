#!/usr/bin/env python3
"""The serial fault suite: the real asi-gateway on external ms2000-sims, faults injected through the
simulators' control sockets, every answer checked against the truth.

  serial faults   drop, corrupt, delay, split, high-bit, echo and garbage faults on one controller
                  while clients read positions through the raw command and the state, and programs
                  on both controllers' shared ptys read them too (one more sends over-long lines,
                  control and high bytes and floods into the noisy one's TCP port); every answer is checked
                  against the stage's real position (the stage is parked at positions no two axes
                  share); a second controller on the same gateway must never see an error.
  unplug storm    unplug/replug cycles; the time from replug to "connected" in the state.
  jobs in storms  plate jobs on both controllers while one is unplugged again and again: every job
                  the unplug catches pauses with the reason, is resumed once the controller is back
                  and ends with every well done once; the other controller's jobs never pause; the
                  gateway's RSS is sampled throughout (its trend per hour).

--short (CI, about a minute) or --long (by hand: --minutes of faults, more cycles). --results FILE
writes the figures into FILE's "Reliability: serial link" section (bench/RESULTS.md).
Loopback and Unix sockets only; every loop is bounded in count and time. Debian's /usr/bin/python3,
standard library only.
"""

import argparse
import json
import os
import platform
import random
import re
import socket
import sys
import threading
import time

import serial  # Debian python3-serial: the shared ports' programs

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "api"))
from gateway_fixture import TOKENS, Fixture, check, free_port, http_request, run_main, wait_until  # noqa: E402

AXES = "XYZ"
PARK_UM = {"X": 1234.5, "Y": -555.1, "Z": 77.7}  # no two axes share a position


def rss_kib(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


def percentile(values, p):
    if not values:
        return None
    s = sorted(values)
    return s[min(len(s) - 1, int(round(p / 100.0 * (len(s) - 1))))]


class Gateway:
    def __init__(self, port):
        self.port = port

    def request(self, method, path, body=None, token=TOKENS["admin"]):
        status, text = http_request(self.port, method, path, body, token)
        try:
            return status, json.loads(text) if text else None
        except ValueError:
            return status, text

    def state(self, cid):
        return self.request("GET", f"/api/v1/controllers/{cid}", token=TOKENS["viewer"])

    def raw(self, cid, line):
        return self.request("POST", f"/api/v1/controllers/{cid}/command", {"command": line})


def park(gw, cid):
    """Moves the stage to PARK_UM and returns WHERE's tenths of a micron per axis."""
    status, body = gw.request("POST", f"/api/v1/controllers/{cid}/move",
                              {"axes": PARK_UM, "wait": True, "timeout_ms": 60000}, token=TOKENS["operator"])
    check(status == 200, f"park {cid}: {status} {body}")
    status, body = gw.raw(cid, "W X Y Z")
    check(status == 200, f"W X Y Z on {cid}: {status} {body}")
    values = [float(v) for v in body["reply"]["values"]]
    check(len(values) == 3, f"W X Y Z answered {body['raw_reply']}")
    return dict(zip(AXES, values))


FAULTS = [
    ("drop-next", lambda r: "drop-next"),
    ("corrupt-next", lambda r: "corrupt-next"),
    ("delay-next", lambda r: f"delay-next {r.choice([300, 800, 1500, 3000])}"),
    ("split-next", lambda r: f"split-next {r.choice([5, 50, 200, 700])}"),
    ("highbit-next", lambda r: "highbit-next"),
    ("echo-next", lambda r: "echo-next"),
    ("garbage", lambda r: f"garbage {r.choice([1, 16, 100, 500])}"),
]


class Tally:
    def __init__(self):
        self.lock = threading.Lock()
        self.counts = {}
        self.mismatches = []

    def add(self, key, n=1):
        with self.lock:
            self.counts[key] = self.counts.get(key, 0) + n

    def mismatch(self, what):
        with self.lock:
            self.mismatches.append(what)


def problem_type(body):
    return body.get("type", "").rsplit("/", 1)[-1] if isinstance(body, dict) else str(body)[:40]


def reader(gw, cid, truth, tally, stop, seed):
    """Raw WHERE and VERSION commands and state reads until `stop`; every answer checked."""
    r = random.Random(seed)
    while not stop.is_set():
        time.sleep(0.005)  # a busy client, not a spinning one (a disconnected controller answers at once)
        axis = r.choice(AXES)
        choice = r.random()
        if choice < 0.6:
            status, body = gw.raw(cid, f"W {axis}")
            if status != 200:
                tally.add(f"{cid} refused {status} {problem_type(body)}")
                continue
            tally.add(f"{cid} replies checked")
            values = body["reply"]["values"]
            if len(values) != 1 or float(values[0]) != truth[axis]:
                tally.mismatch(f"{cid} W {axis} -> {body['raw_reply']!r} (truth {truth[axis]})")
        elif choice < 0.8:
            status, body = gw.raw(cid, "V")
            if status != 200:
                tally.add(f"{cid} refused {status} {problem_type(body)}")
                continue
            tally.add(f"{cid} replies checked")
            if not re.match(r"^:A (Version: USB-|v)\d", body["raw_reply"]):
                tally.mismatch(f"{cid} V -> {body['raw_reply']!r}")
        else:
            status, body = gw.state(cid)
            if status != 200:
                tally.add(f"{cid} refused state {status}")
                continue
            tally.add(f"{cid} states checked")
            for a in body["axes"]:
                if a["position_um"] is not None and abs(a["position_um"] - truth[a["axis"]] / 10.0) > 0.01:
                    tally.mismatch(f"{cid} state {a['axis']} = {a['position_um']} (truth {truth[a['axis']] / 10})")


def shared_reader(path, cid, truth, tally, stop, seed):
    """A program on the controller's shared pty during the faults, reading as Micro-Manager does (input
    drained before each command, 1.5 s for the answer): every answer must be its command's, or none."""
    r = random.Random(seed)
    with serial.Serial(path, 115200, timeout=1.5) as port:
        while not stop.is_set():
            axis = r.choice(AXES)
            port.reset_input_buffer()
            port.write(f"W {axis}\r".encode())
            reply = port.read_until(b"\r\n")
            if not reply:
                tally.add(f"{cid} shared silences")
                continue
            parts = reply.split()
            if len(parts) == 2 and parts[0] == b":A" and float(parts[1]) == truth[axis]:
                tally.add(f"{cid} shared replies checked")
            else:
                tally.mismatch(f"{cid} shared pty W {axis} -> {reply!r} (truth {truth[axis]})")


def shared_garbage(tcp_port, stop, seed):
    """A program that sends what no controller could read into the noisy controller's shared TCP port
    (a client of its own; the pty is the reader's): over-long lines, control and high bytes (never
    IAC, which would be Telnet), a flood without waiting. Its answers are read and dropped."""
    r = random.Random(seed)
    with socket.create_connection(("127.0.0.1", tcp_port), timeout=5) as sock:
        sock.settimeout(0.05)
        while not stop.is_set():
            choice = r.random()
            if choice < 0.3:
                sock.sendall(b"W " + b"X" * r.randint(250, 600) + b"\r")
            elif choice < 0.6:
                sock.sendall(bytes(r.randrange(255) for _ in range(r.randint(1, 64))) + b"\r")
            else:
                sock.sendall(b"W X\r" * r.randint(1, 40))
            try:
                sock.recv(65536)
            except socket.timeout:
                pass
            time.sleep(r.uniform(0.01, 0.1))


def serial_faults(fx, gw, sims, minutes, seed, figures, only=None, shares=None):
    noisy = sims["noisy"]
    truth = {cid: park(gw, cid) for cid in ("noisy", "quiet")}
    tally = Tally()
    stop = threading.Event()
    readers = [threading.Thread(target=reader, args=(gw, cid, truth[cid], tally, stop, seed + i))
               for i, cid in enumerate(["noisy", "noisy", "quiet"])]
    # Programs on the shared ports: one reading each controller, one sending garbage to the noisy one.
    readers += [threading.Thread(target=shared_reader, args=(shares[cid], cid, truth[cid], tally, stop, seed + 10 + i))
                for i, cid in enumerate(["noisy", "quiet"])]
    readers.append(threading.Thread(target=shared_garbage, args=(shares["noisy tcp"], stop, seed + 20)))
    for t in readers:
        t.start()
    r = random.Random(seed)
    kinds = [f for f in FAULTS if not only or f[0] in only]
    deadline = time.monotonic() + minutes * 60
    injected = 0
    try:
        while time.monotonic() < deadline:
            name, make = r.choice(kinds)
            answer = noisy.control(make(r))
            check(answer == "ok", f"control {name}: {answer}")
            injected += 1
            tally.add(f"fault {name}")
            if r.random() < 0.1 and (not only or "garbage" in only):
                # The defect that took the gateway down: noise with high bytes, then text commands.
                noisy.control("garbage 500")
                for line in ("BU", "WHO", "BU X"):
                    gw.raw("noisy", line)
            time.sleep(r.uniform(0.05, 0.6))
            check(fx.gateway.poll() is None, "the gateway died")
    finally:
        stop.set()
        for t in readers:
            t.join(timeout=120)
    # The link comes back in step: the noisy controller answers correctly again.
    wait_until("noisy answers W X again", lambda: gw.raw("noisy", "W X")[0] == 200)
    status, body = gw.raw("noisy", "W X Y Z")
    check(status == 200 and [float(v) for v in body["reply"]["values"]] == [truth["noisy"][a] for a in AXES],
          f"after the faults: {status} {body}")
    counts = tally.counts
    quiet_refused = sum(v for k, v in counts.items() if k.startswith("quiet refused"))
    quiet_refused += counts.get("quiet shared silences", 0)
    figures["serial faults"] = {
        "minutes": minutes, "faults injected": injected,
        "replies checked": counts.get("noisy replies checked", 0) + counts.get("quiet replies checked", 0),
        "states checked": counts.get("noisy states checked", 0) + counts.get("quiet states checked", 0),
        "shared pty replies checked": counts.get("noisy shared replies checked", 0)
        + counts.get("quiet shared replies checked", 0),
        "shared pty silences (noisy)": counts.get("noisy shared silences", 0),
        "noisy refused (timeout/502)": sum(v for k, v in counts.items() if k.startswith("noisy refused")),
        "quiet controller errors": quiet_refused,
        "mismatches": len(tally.mismatches),
        "crashes": 0 if fx.gateway.poll() is None else 1,
        "by fault": {k[len("fault "):]: v for k, v in sorted(counts.items()) if k.startswith("fault ")},
        "refusals": {k: v for k, v in sorted(counts.items()) if "refused" in k},
    }
    check(not tally.mismatches, f"{len(tally.mismatches)} answers were not their command's: {tally.mismatches[:5]}")
    check(quiet_refused == 0, f"the quiet controller saw {quiet_refused} errors: one controller's faults reached another")
    check(counts.get("noisy replies checked", 0) > 0, "no reply was checked")
    check(counts.get("noisy shared replies checked", 0) > 0 and counts.get("quiet shared replies checked", 0) > 0,
          "no shared pty reply was checked")


def unplug_storm(fx, gw, sims, cycles, seed, figures):
    sim = sims["noisy"]
    r = random.Random(seed)
    latencies = []
    rss = []
    for i in range(cycles):
        check(sim.control("unplug") == "ok", "unplug")
        wait_until("disconnected", lambda: gw.state("noisy")[1]["state"] != "connected")
        time.sleep(r.uniform(0.1, 2.0))
        check(sim.control("replug") == "ok", "replug")
        start = time.monotonic()
        while gw.state("noisy")[1]["state"] != "connected":
            check(time.monotonic() - start < 60, f"cycle {i}: not connected 60 s after replug")
            time.sleep(0.01)
        latencies.append(time.monotonic() - start)
        rss.append(rss_kib(fx.gateway.pid))
    figures["unplug storm"] = {
        "cycles": cycles,
        "replug to connected p50 s": round(percentile(latencies, 50), 3),
        "p99 s": round(percentile(latencies, 99), 3),
        "max s": round(max(latencies), 3),
        "rss kib first/last": [rss[0], rss[-1]],
        "crashes": 0 if fx.gateway.poll() is None else 1,
    }
    check(fx.gateway.poll() is None, "the gateway died")


GRID = {"columns": 4, "rows": 3, "column_step_mm": 0.5, "row_step_mm": -0.5}
WELLS = {f"{row}{col}" for row in "ABC" for col in range(1, 5)}


def submit_plate(gw, cid):
    status, body = gw.request("POST", "/api/v1/jobs", {"controller": cid, "type": "array",
                                                      "spec": {"grid": GRID, "a1": {"X": 0, "Y": 0},
                                                               "dwell_ms": 300}},
                              token=TOKENS["operator"])
    check(status == 201, f"submit on {cid}: {status} {body}")
    return body["id"]


def job(gw, job_id):
    status, body = gw.request("GET", f"/api/v1/jobs/{job_id}", token=TOKENS["viewer"])
    check(status == 200, f"GET job {job_id}: {status} {body}")
    return body


def check_wells(gw, job_id):
    """Every well has a step event, and no step was reported done twice."""
    status, body = gw.request("GET", f"/api/v1/jobs/{job_id}/events?limit=1000", token=TOKENS["viewer"])
    check(status == 200, f"events of {job_id}: {status}")
    steps = [e for e in body["events"] if e["type"] == "step"]
    wells = [e["well"] for e in steps]
    check(set(wells) == WELLS, f"{job_id}: wells {sorted(set(wells))}, missing {sorted(WELLS - set(wells))}")
    indices = [e["index"] for e in steps]
    check(len(indices) == len(set(indices)), f"{job_id}: a step done twice: {indices}")
    return len(set(wells))


def rss_slope_kib_per_hour(samples):
    """Least squares over (seconds, KiB) samples."""
    n = len(samples)
    if n < 2:
        return 0.0
    mt = sum(t for t, _ in samples) / n
    mr = sum(r for _, r in samples) / n
    var = sum((t - mt) ** 2 for t, _ in samples)
    return 0.0 if var == 0 else sum((t - mt) * (r - mr) for t, r in samples) / var * 3600


def quiet_jobs(gw, stop, tally):
    """The quiet controller runs plate after plate; none may pause or fail."""
    while not stop.is_set():
        job_id = submit_plate(gw, "quiet")
        while True:
            j = job(gw, job_id)
            if j["state"] in ("succeeded", "failed", "cancelled", "paused", "interrupted"):
                break
            time.sleep(0.1)
        if j["state"] == "succeeded" and j["progress"]["steps_done"] == len(WELLS):
            tally.add("quiet jobs succeeded")
        else:
            tally.mismatch(f"quiet job {job_id} ended {j['state']} ({j['reason']}), "
                           f"{j['progress']['steps_done']}/{len(WELLS)} wells")
            return


def jobs_in_storms(fx, gw, sims, minutes, seed, figures):
    """Jobs on the noisy controller, unplugged while they run; the quiet one's jobs go on."""
    sim = sims["noisy"]
    r = random.Random(seed)
    tally = Tally()
    stop = threading.Event()
    quiet = threading.Thread(target=quiet_jobs, args=(gw, stop, tally))
    quiet.start()
    began = time.monotonic()
    rss = [(0.0, rss_kib(fx.gateway.pid))]
    pauses, jobs, wells = 0, 0, 0
    try:
        while time.monotonic() - began < minutes * 60 or jobs == 0:
            job_id = submit_plate(gw, "noisy")
            jobs += 1
            while True:
                j = job(gw, job_id)
                if j["state"] == "succeeded":
                    break
                check(j["state"] in ("queued", "running"), f"{job_id} {j['state']}: {j['reason']}")
                if j["state"] == "running" and r.random() < 0.5:
                    time.sleep(r.uniform(0.0, 1.0))
                    check(sim.control("unplug") == "ok", "unplug")
                    paused = wait_until(f"{job_id} to pause or end", lambda: (
                        lambda k: k if k["state"] not in ("queued", "running") else None)(job(gw, job_id)))
                    time.sleep(r.uniform(0.1, 1.5))
                    check(sim.control("replug") == "ok", "replug")
                    # Jobs are planned with the controller's build: the next submission waits for it too.
                    wait_until("noisy connected", lambda: gw.state("noisy")[1]["state"] == "connected")
                    if paused["state"] == "paused":
                        pauses += 1
                        check(paused["reason"].startswith("controller disconnected"),
                              f"{job_id} paused for {paused['reason']!r}")
                        status, body = gw.request("POST", f"/api/v1/jobs/{job_id}/resume", token=TOKENS["operator"])
                        check(status == 200, f"resume {job_id}: {status} {body}")
                    else:
                        check(paused["state"] == "succeeded", f"{job_id} {paused['state']}: {paused['reason']}")
                    rss.append((time.monotonic() - began, rss_kib(fx.gateway.pid)))
                    check(fx.gateway.poll() is None, "the gateway died")
                time.sleep(0.05)
            wells += check_wells(gw, job_id)
    finally:
        stop.set()
        quiet.join(timeout=120)
    rss.append((time.monotonic() - began, rss_kib(fx.gateway.pid)))
    half = [s for s in rss if s[0] >= rss[-1][0] / 2]
    figures["jobs in storms"] = {
        "minutes": round((time.monotonic() - began) / 60, 1), "noisy jobs": jobs,
        "unplugs that paused a job": pauses, "wells done": f"{wells}/{jobs * len(WELLS)}",
        "quiet jobs succeeded": tally.counts.get("quiet jobs succeeded", 0),
        "quiet jobs not succeeded": len(tally.mismatches),
        "rss kib first/last/max": [rss[0][1], rss[-1][1], max(v for _, v in rss)],
        "rss slope kib/h (all, second half)": [round(rss_slope_kib_per_hour(rss), 1),
                                               round(rss_slope_kib_per_hour(half), 1)],
        "rss kib over time (minute: KiB)": {round(rss[i][0] / 60, 1): rss[i][1]
                                            for i in range(0, len(rss), max(1, len(rss) // 10))},
        "crashes": 0 if fx.gateway.poll() is None else 1,
    }
    check(not tally.mismatches, f"the quiet controller's jobs: {tally.mismatches}")
    check(pauses > 0, "no unplug caught a running job")


def write_results(path, figures, args):
    """Replaces (or appends) the section of this suite in RESULTS.md; the other sections stay."""
    heading = "## Reliability: serial link (tests/integration/faults/fault_suite.py)"
    form = f"--long --minutes {args.minutes} --cycles {args.cycles} --storm-minutes {args.storm_minutes}" \
        if args.long else "--short"
    lines = [heading, "",
             f"Run of {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, `fault_suite.py {form}`; machine "
             f"{platform.machine()}, {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} at the end.", "",
             "| part | figure | value |", "| --- | --- | --- |"]
    for part, values in figures.items():
        for k, v in values.items():
            lines.append(f"| {part} | {k} | {v} |")
    block = "\n".join(lines) + "\n"
    text = open(path).read() if os.path.exists(path) else ""
    start = text.find(heading)
    if start >= 0:
        end = text.find("\n## ", start + len(heading))
        text = text[:start] + block + (text[end:] if end >= 0 else "")
    else:
        text = text.rstrip("\n") + "\n\n" + block
    with open(path, "w") as f:
        f.write(text)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    ap.add_argument("--sim", required=True)
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--short", action="store_true", help="the CI form (default)")
    mode.add_argument("--long", action="store_true", help="the form run by hand")
    ap.add_argument("--minutes", type=float, default=10.0, help="minutes of serial faults in --long")
    ap.add_argument("--cycles", type=int, default=200, help="unplug cycles in --long")
    ap.add_argument("--storm-minutes", type=float, default=10.0, help="minutes of jobs in unplug storms in --long")
    ap.add_argument("--only", help="comma-separated fault kinds (default: all); e.g. to show one defect on old code")
    ap.add_argument("--seed", type=int, default=12)
    ap.add_argument("--results", help="write the figures into this RESULTS.md")
    args = ap.parse_args()
    minutes = args.minutes if args.long else 0.4
    cycles = args.cycles if args.long else 8
    storm_minutes = args.storm_minutes if args.long else 0.3

    fx = Fixture("gw-fault-suite-")
    figures = {}
    try:
        sims = {name: fx.start_sim(args.sim, name, "full", time_scale=20) for name in ("noisy", "quiet")}
        port = free_port()
        shares = {name: os.path.join(fx.tmp, f"{name}-share") for name in sims}
        shares["noisy tcp"] = free_port()
        controllers = [{"id": name, "port": sim.link, "baud": 115200, "poll_ms": 50, "command_timeout_ms": 500,
                        "share": {"pty": shares[name]}}
                       for name, sim in sims.items()]
        controllers[0]["share"]["tcp"] = f"127.0.0.1:{shares['noisy tcp']}"
        config = {"http": {"listen_address": "127.0.0.1", "port": port}, "controllers": controllers,
                  "simulate": {"count": 0}, "auth": {"tokens": [{"name": "admin1", "token": TOKENS["admin"],
                                                                  "role": "admin"},
                                                                 {"name": "operator1", "token": TOKENS["operator"],
                                                                  "role": "operator"},
                                                                 {"name": "viewer1", "token": TOKENS["viewer"],
                                                                  "role": "viewer"}]},
                  "logging": {"level": os.environ.get("FAULT_SUITE_LOG_LEVEL", "warn")}}
        fx.start_gateway(args.gateway, config)
        gw = Gateway(port)
        fx.run("serial faults: every answer is its command's", serial_faults, fx, gw, sims, minutes, args.seed,
               figures, set(args.only.split(",")) if args.only else None, shares)
        fx.run("unplug storm: every replug reconnects", unplug_storm, fx, gw, sims, cycles, args.seed, figures)
        fx.run("jobs in storms: paused, resumed, every well once", jobs_in_storms, fx, gw, sims, storm_minutes,
               args.seed, figures)
        print(json.dumps(figures, indent=1))
        if args.results and not fx.failures:
            write_results(args.results, figures, args)
        fx.finish_log(80)
        if os.environ.get("FAULT_SUITE_KEEP_LOG") and fx.log_path:
            import shutil
            shutil.copy(fx.log_path, os.environ["FAULT_SUITE_KEEP_LOG"])
    finally:
        fx.cleanup()
    print(f"{len(fx.passed)} passed, {len(fx.failures)} failed")
    return 0 if not fx.failures else 1


if __name__ == "__main__":
    run_main(main)
