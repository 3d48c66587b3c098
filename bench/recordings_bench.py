#!/usr/bin/python3
"""Benchmark: position recordings, the gateway against the physical cost of writing the same rows.

(a) The gateway: one ms2000-sim process runs --controllers simulated controllers (preset "full", XYZ,
    TTL_REPORT, a report pty each, a control socket); the gateway has them in its config and
    --clients WebSocket clients (bench/fanout_client.c, one epoll process) follow `recordings/#`.
    Windows, one after the other, each timed by the gateway's CPU (/proc/<pid>/stat utime + stime):
      idle     controllers connected and polled, clients attached, no frames;
      reports  IN0 armed through POST /controllers/{id}/ttl and pulsed at --rate: report frames decoded
               and published, nothing recorded (what every frame costs before the recorder);
      record   a recording on every controller, pulsed at --rate (`pulse N RATE_HZ` on the control
               socket), nothing else asking the gateway anything: CPU per recorded frame;
      probe    the same recordings go on while a thread polls GET /api/v1/recordings?state=recording
               every --probe-ms: the wall time at which each recording's `frames` counter (committed in
               the same transaction as the rows) first covers a frame is when that frame is durable.
    Afterwards the gateway is stopped and its recordings.sqlite3 read with Python's sqlite3: every
    frame's receive time (time_us) gives its latency (visible - time_us), the frames in each window and
    the count of stored rows; the file's growth (after a TRUNCATE checkpoint, main file + -wal) over the
    frames stored gives the disk bytes per frame.
(b) The peer: bench/recording_writer.c (plain C, Debian's libsqlite3) writes the same rows (same tables,
    WAL, synchronous FULL, one transaction per 250 ms for every recording) at the same rate for as long:
    its CPU per frame, disk bytes per frame and latency (commit end - arrival, exact).

  /usr/bin/python3 bench/recordings_bench.py [--controllers 32] [--rate 500] [--clients 4] \\
      [--idle-s 10] [--reports-s 15] [--record-s 30] [--probe-s 20] [--probe-ms 5] \\
      [--results bench/RESULTS.md] [--keep]

The gateway and the simulator are the prebuilt binaries given by --gateway and --sim.
"""

import argparse
import bisect
import http.client
import json
import os
import shutil
import sqlite3
import subprocess
import sys
import tempfile
import threading
import time

sys.dont_write_bytecode = True
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_gateway import Gateway  # noqa: E402
from bench_machine import publish_section  # noqa: E402
from fanout import build, cpu_seconds, metric_sum, pairs, read_line, rss_mib, stop_all  # noqa: E402
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "integration", "api"))
from gateway_fixture import Sim  # noqa: E402  (the simulator's control socket, as the tests use it)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TICKS = os.sysconf("SC_CLK_TCK")


# ---------------------------------------------------------------------------------------------
# The rig


class Sims:
    """One ms2000-sim process with `count` controllers c-1 .. c-<count>, each with a report pty."""

    def __init__(self, binary, workdir, count):
        self.names = [f"c-{i}" for i in range(1, count + 1)]
        self.control_path = os.path.join(workdir, "control.sock")
        base = os.path.join(workdir, "c")
        self.proc = subprocess.Popen([binary, "--preset", "full", "--name", "c", "--count", str(count),
                                      "--link", base + "/port", "--report-link", base + "/report",
                                      "--control", self.control_path],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        self.links = {n: (f"{base}/port-{i}", f"{base}/report-{i}") for i, n in enumerate(self.names, 1)}
        deadline = time.monotonic() + 20
        paths = [self.control_path] + [p for pair in self.links.values() for p in pair]
        while not all(os.path.exists(p) for p in paths):
            if self.proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError("ms2000-sim did not start")
            time.sleep(0.05)

    def control(self, line):
        """One command on the control socket; its one-line answer."""
        return Sim(None, None, self.control_path).control(line)

    def pulse_all(self, n, rate):
        for name in self.names:
            if self.control(f"{name} pulse {n} {rate:g}") != "ok":
                raise RuntimeError(f"{name}: pulse refused")

    def reports(self):
        """(reports_sent, reports_dropped), summed over the controllers."""
        sent = dropped = 0
        for name in self.names:
            st = json.loads(self.control(f"{name} state"))
            sent += st["reports_sent"]
            dropped += st["reports_dropped"]
        return sent, dropped

    def stop(self):
        stop_all([self.proc])


def disk_write_bytes(pid):
    """What the process sent to the disk so far (/proc/<pid>/io write_bytes; 0 if unreadable)."""
    try:
        with open(f"/proc/{pid}/io") as f:
            for line in f:
                if line.startswith("write_bytes:"):
                    return int(line.split()[1])
    except OSError:
        pass
    return 0


def cpu_pressure_s():
    """Seconds so far during which some task of the machine waited for a CPU (/proc/pressure/cpu, PSI;
    0 without it). Not /proc/stat's busy time: it samples at the timer tick, and here it came out below
    the rig's own per-process CPU."""
    try:
        with open("/proc/pressure/cpu") as f:
            return int(f.readline().split("total=")[1]) / 1e6
    except (OSError, IndexError, ValueError):
        return 0.0


def checkpointed_size(path):
    """The SQLite file's bytes after folding the WAL into it (main file + what is left of -wal)."""
    db = sqlite3.connect(path, timeout=30)
    try:
        db.execute("PRAGMA wal_checkpoint(TRUNCATE)").fetchall()
    finally:
        db.close()
    wal = path + "-wal"
    return os.path.getsize(path) + (os.path.getsize(wal) if os.path.exists(wal) else 0)


def thread_cpu_seconds(pid):
    """({tid: CPU seconds} of each of the process's threads, seconds they all waited on a run queue for
    a CPU (/proc/<pid>/task/<tid>/schedstat))."""
    out, waited = {}, 0.0
    for tid in os.listdir(f"/proc/{pid}/task"):
        try:
            with open(f"/proc/{pid}/task/{tid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
            out[int(tid)] = (int(fields[11]) + int(fields[12])) / TICKS
            with open(f"/proc/{pid}/task/{tid}/schedstat") as f:
                waited += int(f.read().split()[1]) / 1e9
        except OSError:
            pass  # a thread that just ended
    return out, waited


class Sample:
    """CPU seconds of the processes that matter and of the gateway's threads, the gateway's wait for a
    CPU and the machine's CPU pressure."""

    def __init__(self, procs):
        self.t = time.monotonic()
        self.wall = time.time()
        self.cpu = {k: cpu_seconds(p) for k, p in procs.items()}
        self.threads, self.waited = thread_cpu_seconds(procs["gateway"])
        self.pressure = cpu_pressure_s()


def window(a, b):
    """Between samples a and b: CPU cores of each process and of the gateway's threads, the gateway's
    wait for a CPU (ms per s) and the share of the time some task of the machine waited for one."""
    s = b.t - a.t
    cores = {k: (b.cpu[k] - a.cpu[k]) / s for k in a.cpu}
    threads = {t: (b.threads[t] - a.threads.get(t, 0.0)) / s for t in b.threads}
    return {"seconds": s, "cores": cores, "cpu": {k: b.cpu[k] - a.cpu[k] for k in a.cpu}, "threads": threads,
            "waited_ms_per_s": (b.waited - a.waited) / s * 1e3, "pressure": (b.pressure - a.pressure) / s}


class Prober(threading.Thread):
    """Polls the list of recordings that record every `interval` s over one keep-alive connection and
    notes, per recording, each new `frames` value with the wall time its answer arrived. The gateway
    reads the store on its writer thread after the writes queued before, so a poll sent during a commit
    is answered just after it; one sent while the writer is idle sees commits up to its send. Either
    way the answer time is at most one interval plus one round trip late."""

    def __init__(self, port, interval):
        super().__init__(daemon=True)
        self.port, self.interval = port, interval
        self.seen = {}  # id -> [(frames, visible_by)]
        self.round_trips = []  # seconds, every poll
        self.first = {}  # id -> frames at the first poll: those frames' commit time is unknown
        self.last = {}
        self.polls = 0
        self.stopping = threading.Event()
        self.error = None

    def run(self):
        conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=30)
        try:
            while not self.stopping.is_set():
                sent = time.time()
                conn.request("GET", "/api/v1/recordings?state=recording&limit=500")
                r = conn.getresponse()
                body = r.read()
                got = time.time()
                if r.status != 200:
                    raise RuntimeError(f"GET /api/v1/recordings: {r.status} {body[:200]!r}")
                self.polls += 1
                self.round_trips.append(got - sent)
                for rec in json.loads(body)["recordings"]:
                    if self.polls == 1:
                        self.first[rec["id"]] = self.last[rec["id"]] = rec["frames"]
                    elif rec["frames"] > self.last.get(rec["id"], 0):
                        self.last[rec["id"]] = rec["frames"]
                        self.seen.setdefault(rec["id"], []).append((rec["frames"], got))
                self.stopping.wait(max(0.0, sent + self.interval - time.time()))
        except Exception as e:  # reported with the results: a probe that died measures nothing
            self.error = repr(e)
        finally:
            conn.close()


def percentiles(values):
    """(p50, p99, max) of a list, or None when it is empty."""
    if not values:
        return None
    v = sorted(values)
    return v[len(v) // 2], v[min(len(v) - 1, int(0.99 * len(v)))], v[-1]


def wait_for(what, fn, timeout):
    deadline = time.monotonic() + timeout
    while not fn():
        if time.monotonic() > deadline:
            raise RuntimeError(f"timed out waiting for {what}")
        time.sleep(0.2)


# ---------------------------------------------------------------------------------------------
# (a) The gateway


def run_gateway(args, tmp):
    client_bin = build(tmp, "fanout_client") if args.clients > 0 else None
    sims = Sims(args.sim, os.path.join(tmp, "sim"), args.controllers)
    gw, client, prober = None, None, None
    try:
        controllers = [{"id": n, "port": port, "report_port": report, "baud": 115200}
                       for n, (port, report) in sims.links.items()]
        gw_dir = os.path.join(tmp, "gateway")
        os.makedirs(gw_dir)
        store = os.path.join(gw_dir, "data")
        gw = Gateway(args.gateway, gw_dir, {"controllers": controllers, "storage": {"path": store}})
        gw.wait_ready()

        def all_up():
            status, body = gw.request("GET", "/api/v1/controllers")
            return status == 200 and all(c["state"] == "connected" and c["report_port"] == "open"
                                         for c in body["controllers"])
        wait_for("the controllers and their report ports", all_up, 120)
        procs = {"gateway": gw.proc.pid, "simulator": sims.proc.pid, "bench": os.getpid()}
        if args.clients > 0:
            # Its stderr (a per-second worst latency) to a file: not this script's output.
            with open(os.path.join(tmp, "clients.err"), "w") as err:
                client = subprocess.Popen([client_bin, str(gw.port), str(args.clients), "-1", "recordings/#"],
                                          stdout=subprocess.PIPE, stderr=err, text=True)
            read_line(client, "subscribed")
            procs["clients"] = client.pid
        time.sleep(2)  # the connections' first polls done

        # idle: nothing but the gateway's own polling of the controllers
        s_idle = Sample(procs)
        time.sleep(args.idle_s)
        e_idle = Sample(procs)

        # reports: frames decoded and published, nothing recorded
        for name in sims.names:
            status, body = gw.request("POST", f"/api/v1/controllers/{name}/ttl", {"in0_mode": 1})
            if status not in (200, 204):
                raise RuntimeError(f"{name}: TTL X=1: {status} {body}")
        sent0, _ = sims.reports()
        decoded0 = metric_sum(gw, "gw_controller_report_frames_total")
        n1 = round(args.rate * (args.reports_s + 1))
        sims.pulse_all(n1, args.rate)
        time.sleep(0.5)  # the trains under way
        s_rep = Sample(procs)
        decoded_s = metric_sum(gw, "gw_controller_report_frames_total")
        time.sleep(args.reports_s)
        e_rep = Sample(procs)
        decoded_e = metric_sum(gw, "gw_controller_report_frames_total")
        wait_for("the reports-only pulses", lambda: sims.reports()[0] - sent0 >= n1 * args.controllers, 60)
        time.sleep(1)
        decoded = metric_sum(gw, "gw_controller_report_frames_total") - decoded0

        # record: a recording on every controller
        ids = []
        for name in sims.names:
            status, rec = gw.request("POST", f"/api/v1/controllers/{name}/recordings", {"name": f"bench {name}"})
            if status != 201:
                raise RuntimeError(f"{name}: start recording: {status} {rec}")
            ids.append(rec["id"])
        time.sleep(1)  # the records created by the writer
        db_path = os.path.join(store, "recordings.sqlite3")
        size0 = checkpointed_size(db_path)
        sent1, dropped1 = sims.reports()
        io0 = disk_write_bytes(gw.proc.pid)
        n2 = round(args.rate * (1 + args.record_s + args.probe_s + 0.5))
        sims.pulse_all(n2, args.rate)
        time.sleep(1)  # the trains under way
        s_rec = Sample(procs)
        time.sleep(args.record_s)
        e_rec = Sample(procs)
        prober = Prober(gw.port, args.probe_ms / 1000)
        prober.start()
        time.sleep(args.probe_s)
        e_probe = Sample(procs)
        wait_for("the recording pulses", lambda: sims.reports()[0] - sent1 >= n2 * args.controllers, 60)
        sent2, dropped2 = sims.reports()
        # The last frames committed and seen by the prober.
        wait_for("the last frames stored", lambda: len(prober.last) == len(ids) and
                 sum(prober.last.values()) >= sent2 - sent1 or prober.error, 30)
        prober.stopping.set()
        prober.join()
        io1 = disk_write_bytes(gw.proc.pid)
        rss = rss_mib(gw.proc.pid)
        records = []
        for rid in ids:
            status, rec = gw.request("POST", f"/api/v1/recordings/{rid}/stop")
            if status != 200:
                raise RuntimeError(f"stop {rid}: {status} {rec}")
            records.append(rec)
        got = None
        if client:
            time.sleep(0.5)  # the last live events on their way
            client.terminate()
            got = pairs(client.stdout.readline())
        gw.stop()
        size1 = checkpointed_size(db_path)
        return {"pid": gw.proc.pid, "idle": window(s_idle, e_idle), "reports": window(s_rep, e_rep), "record": window(s_rec, e_rec),
                "probe": window(e_rec, e_probe), "decoded": decoded, "reports_sent": n1 * args.controllers,
                "decoded_in_window": decoded_e - decoded_s,
                "sent": sent2 - sent1, "sim_dropped": dropped2 - dropped1, "records": records,
                "db": analyse_store(db_path, s_rec, e_rec, e_probe, prober), "prober": prober,
                "bytes": size1 - size0, "io": io1 - io0, "rss": rss, "ws": got}
    finally:
        if prober:
            prober.stopping.set()
        stop_all([client])
        if gw:
            gw.stop()
        sims.stop()


def analyse_store(path, s_rec, e_rec, e_probe, prober):
    """From the stored rows: frames, markers, frames received in the record and probe windows, and each
    probe-window frame's latency from its receive time to the poll that first saw it committed."""
    db = sqlite3.connect(path)
    try:
        rows, markers = db.execute("SELECT SUM(loss = 0), SUM(loss != 0) FROM frames").fetchone()

        def received(a, b):
            return db.execute("SELECT COUNT(*) FROM frames WHERE loss = 0 AND time_us >= ? AND time_us < ?",
                              (int(a.wall * 1e6), int(b.wall * 1e6))).fetchone()[0]
        in_record, in_probe = received(s_rec, e_rec), received(e_rec, e_probe)
        latencies, intervals = [], []
        for rid, seen in prober.seen.items():
            counts = [c for c, _ in seen]
            intervals += [(b[1] - a[1]) * 1e3 for a, b in zip(seen, seen[1:])]
            q = db.execute("SELECT f.idx, f.time_us FROM frames f JOIN recordings r ON f.recording = r.key "
                           "WHERE r.id = ? AND f.loss = 0 AND f.time_us >= ? AND f.time_us < ?",
                           (rid, int(e_rec.wall * 1e6), int(e_probe.wall * 1e6)))
            for idx, time_us in q:
                if idx < prober.first.get(rid, 0):
                    continue  # committed before the probe's first poll
                i = bisect.bisect_right(counts, idx)  # the first poll whose counter covers frame idx
                if i == len(seen):
                    continue  # never seen: "latency measured on" falls short of the frames received
                latencies.append(seen[i][1] * 1e3 - time_us / 1e3)
        return {"rows": rows or 0, "markers": markers or 0, "in_record": in_record, "in_probe": in_probe,
                "latency": percentiles(latencies), "measured": len(latencies),
                "interval": percentiles(intervals),
                "round_trip": percentiles([t * 1e3 for t in prober.round_trips])}
    finally:
        db.close()


# ---------------------------------------------------------------------------------------------
# (b) The peer


def run_peer(args, tmp):
    out = os.path.join(tmp, "recording_writer")
    subprocess.run(["cc", "-O2", "-std=c11", "-o", out, os.path.join(ROOT, "bench", "recording_writer.c"),
                    "-lsqlite3", "-lm"], check=True)
    peer_dir = os.path.join(tmp, "peer")
    os.makedirs(peer_dir)
    path = os.path.join(peer_dir, "recordings.sqlite3")
    seconds = 1 + args.record_s + args.probe_s + 0.5  # as long as the gateway's pulse trains
    p = subprocess.Popen([out, path, str(args.controllers), f"{args.rate:g}", f"{seconds:g}"],
                         stdout=subprocess.PIPE, text=True)
    try:
        initial = int(read_line(p, "ready").split()[2])
        pressure0, t0 = cpu_pressure_s(), time.monotonic()
        result = pairs(p.stdout.readline())
        pressure = (cpu_pressure_s() - pressure0) / (time.monotonic() - t0)
        if p.wait() != 0:
            raise RuntimeError("recording_writer failed")
    finally:
        stop_all([p])
    result["bytes"] = checkpointed_size(path) - initial
    result["pressure"] = pressure
    return result


# ---------------------------------------------------------------------------------------------
# The table


def us(x):
    return f"{x * 1e6:.2f} us"


def ms3(t):
    return "n/a" if t is None else f"{t[0]:.1f} / {t[1]:.1f} / {t[2]:.1f}"


def thread_lines(r, frames):
    """The main (I/O) thread, the recorder's writer (the busiest other thread, idle before the recordings)
    and the rest, as table rows."""
    rec, rep = r["record"]["threads"], r["reports"]["threads"]
    main = r["pid"]
    others = sorted((t for t in rec if t != main), key=lambda t: -rec[t])
    writer = next((t for t in others if rep.get(t, 0.0) < 0.005 and rec[t] > 0.005), None)
    rows = [("main thread (the I/O thread: serial ports, HTTP, WebSocket, the hub)", [main]),
            ("the recorder's writer (SQLite; busy only while recording)", [writer] if writer else []),
            ("the other threads", [t for t in others if t != writer])]
    seconds = r["record"]["seconds"]
    return [f"| {name} | {sum(rep.get(t, 0.0) for t in tids):.3f} | {sum(rec[t] for t in tids):.3f} | "
            f"{us(sum(rec[t] for t in tids) * seconds / frames)} |" for name, tids in rows]


def table(args, r, peer):
    db, records = r["db"], r["records"]
    stored = sum(rec["frames"] for rec in records)
    losses = sum(rec["losses"] for rec in records)
    states = sorted({rec["state"] for rec in records})
    cpu = {k: r[k]["cpu"]["gateway"] for k in ("idle", "reports", "record", "probe")}
    rate = {k: r[k]["cores"]["gateway"] for k in ("idle", "reports", "record", "probe")}
    per_frame = cpu["record"] / db["in_record"]
    per_frame_probe = cpu["probe"] / db["in_probe"]
    reports_rate = r["decoded_in_window"] / r["reports"]["seconds"]
    frame_rate = db["in_record"] / r["record"]["seconds"]
    over_idle = (rate["record"] - rate["idle"]) / frame_rate
    reports_over_idle = (rate["reports"] - rate["idle"]) / reports_rate
    peer_cpu = peer["cpu_s"] / peer["frames"]
    bytes_per_frame = r["bytes"] / stored if stored else float("nan")
    peer_bytes = peer["bytes"] / peer["frames"]
    ws = r["ws"]
    lines = [
        f"{args.controllers} controllers x {args.rate:g} frames/s (one ms2000-sim process, preset full: X Y Z), "
        f"{args.clients} WebSocket clients on `recordings/#`. Windows: idle {args.idle_s:g} s, reports only "
        f"{args.reports_s:g} s, record {args.record_s:g} s, record + latency probe {args.probe_s:g} s "
        f"(GET /api/v1/recordings?state=recording every {args.probe_ms:g} ms); the peer writes for as long as "
        f"the gateway's pulse trains ({1 + args.record_s + args.probe_s + 0.5:g} s).",
        "",
        "| figure | gateway | peer (recording_writer.c, SQLite alone) |",
        "|---|---:|---:|",
        f"| frames sent by the simulator (dropped there) | {r['sent']:,} ({r['sim_dropped']:,}) | - |",
        f"| frames stored (rows in the file) / loss markers | {stored:,} ({db['rows']:,}) / {losses} | "
        f"{int(peer['frames']):,} / 0 |",
        f"| recordings' end state | {', '.join(states)} | - |",
        f"| CPU per frame, record window | {us(per_frame)} ({rate['record']:.2f} cores) | "
        f"{us(peer_cpu)} ({peer['cpu_s'] / peer['wall_s']:.2f} cores) |",
        f"| CPU per frame, record + probe window | {us(per_frame_probe)} ({rate['probe']:.2f} cores) | - |",
        f"| disk bytes per frame (file growth after a checkpoint) | {bytes_per_frame:.1f} B | {peer_bytes:.1f} B |",
        f"| bytes sent to the disk per frame (/proc/pid/io write_bytes) | {r['io'] / stored:.1f} B | "
        f"{peer['write_bytes'] / peer['frames']:.1f} B |",
        f"| latency, receive -> durable, p50 / p99 / max ms | {ms3(db['latency'])} | "
        f"{peer['p50_ms']:.1f} / {peer['p99_ms']:.1f} / {peer['max_ms']:.1f} |",
        "",
        "Where the gateway's CPU goes (its cores in each window, and per frame above the idle window):",
        "",
        "| window | gateway cores | frames/s | CPU per frame above idle |",
        "|---|---:|---:|---:|",
        f"| idle (controllers polled, clients attached) | {rate['idle']:.3f} | 0 | - |",
        f"| reports only (decoded and published, not recorded) | {rate['reports']:.3f} | {reports_rate:,.0f} | "
        f"{us(reports_over_idle)} |",
        f"| record | {rate['record']:.3f} | {frame_rate:,.0f} | {us(over_idle)} |",
        f"| the recorder's own share (record - reports only) | | | {us(over_idle - reports_over_idle)} |",
        "",
        "The gateway's threads in the record window (per frame: the thread's CPU over the frames received):",
        "",
        "| thread | cores, reports only | cores, record | CPU per frame, record |",
        "|---|---:|---:|---:|",
        *thread_lines(r, db["in_record"]),
        "",
        "| rig and machine | value |",
        "|---|---:|",
        f"| frames the gateway decoded in the reports-only window (simulator sent) | {int(r['decoded']):,} "
        f"({r['reports_sent']:,}) |",
        f"| latency measured on (frames received in the probe window) | {db['measured']:,} ({db['in_probe']:,}) |",
        f"| probe polls{' (probe error: ' + r['prober'].error + ')' if r['prober'].error else ''}; their round "
        f"trip p50 / p99 / max ms | {r['prober'].polls:,}; {ms3(db['round_trip'])} |",
        f"| time between the commits the probe saw, p50 / p99 / max ms (the flush period) | "
        f"{ms3(db['interval'])} |",
        f"| the peer's transactions, BEGIN to the end of COMMIT, p50 / max ms | {peer['txn_p50_ms']:.1f} / "
        f"{peer['txn_max_ms']:.1f} |",
    ]
    if ws:
        lines += [
            f"| live events to the WebSocket clients (missed, connections closed) | {int(ws['events']):,} "
            f"({int(ws['missed'])}, {int(ws['closed'])}) |",
            f"| live event delivery latency p50 / p99 / max ms (publish -> client, 0.1 ms buckets) | "
            f"{ws['p50_ms']:.1f} / {ws['p99_ms']:.1f} / {ws['max_ms']:.1f} |",
        ]
    lines += [
        f"| simulator / WebSocket clients / this script, cores in the record window | "
        f"{r['record']['cores']['simulator']:.2f} / {r['record']['cores'].get('clients', 0):.2f} / "
        f"{r['record']['cores']['bench']:.2f} |",
        f"| the gateway's threads waiting for a CPU (run queue), ms per s: reports only / record / probe window | "
        f"{r['reports']['waited_ms_per_s']:.1f} / {r['record']['waited_ms_per_s']:.1f} / "
        f"{r['probe']['waited_ms_per_s']:.1f} |",
        f"| CPU pressure (PSI: share of the time some task waited for a CPU): record / probe window / peer run | "
        f"{r['record']['pressure']:.1%} / {r['probe']['pressure']:.1%} / {peer['pressure']:.1%} |",
        f"| gateway RSS at the end of the recordings | {r['rss']:.1f} MiB |",
        "",
        f"Latency: each frame's `time_us` (the gateway's receive time, read back from the file) against the wall "
        f"time of the first answer of GET /api/v1/recordings?state=recording (polled every {args.probe_ms:g} ms, "
        "one keep-alive connection) whose `frames` counter covers it; the counter is committed in the same "
        "transaction as the rows, and the gateway serves the read on its writer thread after the writes queued "
        "before it, so a poll sent during a commit is answered right after it. The figure is therefore an upper "
        f"bound, late by at most one poll interval plus one unblocked round trip (p50 above), i.e. about "
        f"{args.probe_ms + (db['round_trip'][0] if db['round_trip'] else 0):.0f} ms. The peer's latency is exact: "
        "the end of COMMIT minus the frame's scheduled arrival. Both include the wait for the next 250 ms flush "
        "(on average half of it).",
    ]
    met = (stored == r["sent"] == db["rows"] and losses == 0 and r["sim_dropped"] == 0 and states == ["stopped"]
           and (not ws or (int(ws["closed"]) == 0 and int(ws["missed"]) == 0)) and not r["prober"].error)
    return "\n".join(lines), met


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--gateway", default="/tmp/bench-bin/asi-gateway")
    p.add_argument("--sim", default="/tmp/bench-bin/ms2000-sim")
    p.add_argument("--controllers", type=int, default=32)
    p.add_argument("--rate", type=float, default=500, help="frames/s per controller")
    p.add_argument("--clients", type=int, default=4, help="WebSocket clients on recordings/#")
    p.add_argument("--idle-s", type=float, default=10)
    p.add_argument("--reports-s", type=float, default=15)
    p.add_argument("--record-s", type=float, default=30)
    p.add_argument("--probe-s", type=float, default=20)
    p.add_argument("--probe-ms", type=float, default=5, help="poll interval of the latency probe")
    p.add_argument("--results", default="", help="append the section to this file (e.g. bench/RESULTS.md)")
    p.add_argument("--keep", action="store_true", help="keep the scratch directory")
    args = p.parse_args()
    tmp = tempfile.mkdtemp(prefix="gw-recordings-")
    try:
        load_before = os.getloadavg()
        r = run_gateway(args, tmp)
        peer = run_peer(args, tmp)
        load_after = os.getloadavg()
    finally:
        if args.keep:
            print(f"scratch directory kept: {tmp}")
        else:
            shutil.rmtree(tmp, ignore_errors=True)
    text, met = table(args, r, peer)
    details = ("Goal: every frame the simulator sent stored, no loss marker, no live event missed; the CPU, "
               "disk and latency figures are measurements without a target.")
    return publish_section("Position recordings", "bench/recordings_bench.py", details, load_before, load_after,
                           text, met, args.results)


if __name__ == "__main__":
    sys.exit(main())
