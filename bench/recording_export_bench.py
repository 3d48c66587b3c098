#!/usr/bin/python3
"""Benchmark: a long recording's downloads (CSV, JSON Lines, HDF5), against libhdf5 and pandas alone.

(a) A recording of --frames frames (3 axes) is put in a scratch storage directory: the gateway opens the
    directory once (creating recordings.sqlite3 and its tables), then this script fills the tables with
    Python's sqlite3 in the gateway's own row format (little-endian int32 counts, float64 micrometres,
    one row per frame in arrival order) and marks the recording stopped. Recording a million frames
    through the simulator would take minutes at its 2,000 frames/s; the stored rows are the same.
(b) The gateway (the prebuilt binary, one simulated controller so that it has a config) serves
    GET /api/v1/recordings/{id}/frames?format=F for each format, --repeat times, one download at a time
    over one connection, read in 1 MiB pieces and written to a file. Per download: the time to the
    first byte of the body and to its end, the bytes, the gateway's CPU (utime + stime of
    /proc/<pid>/stat) and its resident memory, sampled every 10 ms (the highest sample against the one
    before the download: a streamed body must not grow with the recording).
(c) The peers, on the same rows: h5py (Debian's python3-h5py, over the same libhdf5) writes the same
    columns with the same types and chunking from arrays in memory: the library's own cost of the HDF5
    file; and what analysis code pays to read each download (pandas.read_csv, read_json(lines=True),
    h5py into a pandas DataFrame), which also checks that every download holds every row.

  /usr/bin/python3 bench/recording_export_bench.py [--frames 1000000] [--repeat 3] \\
      [--results bench/RESULTS.md] [--keep]

The gateway is the prebuilt binary given by --gateway.
"""

import argparse
import http.client
import json
import os
import shutil
import sqlite3
import statistics
import struct
import sys
import tempfile
import threading
import time

import h5py  # Debian python3-h5py
import numpy  # Debian python3-numpy
import pandas  # Debian python3-pandas

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_machine import publish_section  # noqa: E402
from gateway_rig import cpu_seconds, free_port, rss_mib, start_gateway, stop_process  # noqa: E402

FORMATS = ("csv", "jsonl", "hdf5")
CHUNK_ROWS = 16384  # the gateway's HDF5 chunk (gateway/recordings/hdf5_export.cpp)
RSS_GOAL_MIB = 32  # a download may not grow the gateway by more than this, whatever the recording's length


class RssSampler(threading.Thread):
    """The highest VmRSS of `pid` while it runs, sampled every 10 ms."""

    def __init__(self, pid):
        super().__init__(daemon=True)
        self.pid, self.peak, self.done = pid, rss_mib(pid), threading.Event()

    def run(self):
        while not self.done.wait(0.01):
            self.peak = max(self.peak, rss_mib(self.pid))

    def stop(self):
        self.done.set()
        self.join()
        return self.peak


def synthetic_rows(n):
    """Columns of `n` frames of a serpentine scan: X sweeps 0..10 mm, Y steps, Z drifts."""
    i = numpy.arange(n, dtype=numpy.int64)
    counts_per_um = 45.3976  # the simulator's encoder (45,397.6 counts per mm)
    x_counts = ((i % 2000) * 227).astype(numpy.int32)
    y_counts = ((i // 2000) * 4540).astype(numpy.int32)
    z_counts = (1000 + (i % 97)).astype(numpy.int32)
    return {
        "index": i.astype(numpy.uint64),
        "time_us": 1_765_000_000_000_000 + i * 2000,
        "loss": numpy.zeros(n, dtype=numpy.uint8),
        "X_um": x_counts / counts_per_um, "Y_um": y_counts / counts_per_um, "Z_um": z_counts / counts_per_um,
        "X_counts": x_counts, "Y_counts": y_counts, "Z_counts": z_counts,
    }


def fill_store(db_path, rid, rows):
    """The recording and its rows, as the gateway's writer stores them."""
    n = len(rows["index"])
    db = sqlite3.connect(db_path)
    started = int(rows["time_us"][0] // 1000)
    stopped = int(rows["time_us"][-1] // 1000)
    db.execute("INSERT INTO recordings (id, controller, name, state, reason, started_ms, stopped_ms, frames,"
               " losses, axes, ttl_in_mode, previous_in_mode, max_frames, max_s, metadata, job)"
               " VALUES (?, 'sim1', 'export bench', 'stopped', 'stopped', ?, ?, ?, 0, 'XYZ', 1, 0, NULL, NULL,"
               " '{}', NULL)", (rid, started, stopped, n))
    key = db.execute("SELECT key FROM recordings WHERE id = ?", (rid,)).fetchone()[0]
    counts = numpy.stack([rows["X_counts"], rows["Y_counts"], rows["Z_counts"]], axis=1).astype("<i4")
    um = numpy.stack([rows["X_um"], rows["Y_um"], rows["Z_um"]], axis=1).astype("<f8")
    step = 100_000
    for lo in range(0, n, step):
        hi = min(n, lo + step)
        db.executemany("INSERT INTO frames (recording, seq, idx, time_us, loss, counts, um) VALUES (?, ?, ?, ?, 0, ?, ?)",
                       ((key, k, k, int(rows["time_us"][k]), counts[k].tobytes(), um[k].tobytes())
                        for k in range(lo, hi)))
    db.commit()
    db.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    db.close()


def download(port, pid, rid, fmt, path):
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=600)
    sampler = RssSampler(pid)
    rss0 = sampler.peak
    sampler.start()
    cpu0, t0 = cpu_seconds(pid), time.monotonic()
    conn.request("GET", f"/api/v1/recordings/{rid}/frames?format={fmt}")
    r = conn.getresponse()
    if r.status != 200:
        raise RuntimeError(f"{fmt}: HTTP {r.status} {r.read()[:300]}")
    first, size = None, 0
    with open(path, "wb") as f:
        while True:
            piece = r.read1(1 << 20)
            if not piece:
                break
            if first is None:
                first = time.monotonic() - t0
            size += len(piece)
            f.write(piece)
    total = time.monotonic() - t0
    cpu = cpu_seconds(pid) - cpu0
    peak = sampler.stop()
    conn.close()
    return {"first_s": first or total, "total_s": total, "bytes": size, "cpu_s": cpu, "rss0": rss0, "peak": peak}


def read_back(fmt, path):
    """(seconds, the DataFrame) as analysis code reads the download."""
    t0 = time.monotonic()
    if fmt == "csv":
        frame = pandas.read_csv(path)
    elif fmt == "jsonl":
        frame = pandas.read_json(path, lines=True)
    else:
        with h5py.File(path, "r") as f:
            frame = pandas.DataFrame({c: f[c][:] for c in f.attrs["columns"].split(",")})
    return time.monotonic() - t0, frame


def h5py_write(rows, path):
    """Seconds h5py takes to write the same columns (types, chunks) from memory."""
    t0 = time.monotonic()
    with h5py.File(path, "w") as f:
        for name, values in rows.items():
            f.create_dataset(name, data=values, chunks=(CHUNK_ROWS,), maxshape=(None,))
        f.attrs["columns"] = ",".join(rows)
    return time.monotonic() - t0


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--gateway", default="/tmp/bench-bin/asi-gateway")
    p.add_argument("--frames", type=int, default=1_000_000)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--results", default="", help="append the section to this file (e.g. bench/RESULTS.md)")
    p.add_argument("--keep", action="store_true", help="keep the scratch directory")
    args = p.parse_args()

    load_before = os.getloadavg()
    tmp = tempfile.mkdtemp(prefix="gw-export-bench-")
    store = os.path.join(tmp, "data")
    port = free_port()
    config = {"http": {"listen_address": "127.0.0.1", "port": port}, "storage": {"path": store},
              "simulate": {"count": 1, "directory": os.path.join(tmp, "sim")}}
    gw = None
    try:
        rows = synthetic_rows(args.frames)
        rid = "r-EXPORTBENCH0000000000000000"
        gw = start_gateway([args.gateway], config, tmp, port)  # creates the tables
        stop_process(gw)
        t0 = time.monotonic()
        fill_store(os.path.join(store, "recordings.sqlite3"), rid, rows)
        print(f"stored {args.frames:,} frames in {time.monotonic() - t0:.1f} s")
        gw = start_gateway([args.gateway], config, tmp, port)
        runs = {fmt: [] for fmt in FORMATS}
        reads = {}
        ok = True
        for attempt in range(args.repeat):
            for fmt in FORMATS:
                path = os.path.join(tmp, f"frames.{fmt}")
                d = download(port, gw.pid, rid, fmt, path)
                runs[fmt].append(d)
                print(f"{fmt}: {d['total_s']:.2f} s, {d['bytes'] / 1e6:.1f} MB, first byte {d['first_s'] * 1000:.0f} ms,"
                      f" CPU {d['cpu_s']:.2f} s, RSS {d['rss0']:.1f} -> {d['peak']:.1f} MiB")
                if attempt == 0:
                    seconds, frame = read_back(fmt, path)
                    same = (len(frame) == args.frames and (frame["index"].to_numpy() == rows["index"]).all()
                            and (frame["X_counts"].to_numpy() == rows["X_counts"]).all())
                    reads[fmt] = (seconds, same)
                    ok = ok and same
                os.remove(path)
        peer_path = os.path.join(tmp, "peer.h5")
        peer_s = statistics.median(h5py_write(rows, peer_path) for _ in range(args.repeat))
        peer_bytes = os.path.getsize(peer_path)
        stop_process(gw)
        gw = None
    finally:
        stop_process(gw)
        if not args.keep:
            shutil.rmtree(tmp, ignore_errors=True)

    def med(fmt, key):
        return statistics.median(d[key] for d in runs[fmt])

    growth = max(d["peak"] - d["rss0"] for fmt in FORMATS for d in runs[fmt])
    met = ok and growth < RSS_GOAL_MIB
    n = args.frames
    lines = ["| figure (median of the downloads) | CSV | JSON Lines | HDF5 |", "|---|---:|---:|---:|"]

    def row(label, fn):
        lines.append(f"| {label} | " + " | ".join(fn(fmt) for fmt in FORMATS) + " |")
    row("download, s", lambda f: f"{med(f, 'total_s'):.2f}")
    row("frames per second", lambda f: f"{n / med(f, 'total_s'):,.0f}")
    row("bytes per frame", lambda f: f"{med(f, 'bytes') / n:.1f}")
    row("MB/s", lambda f: f"{med(f, 'bytes') / med(f, 'total_s') / 1e6:.1f}")
    row("first byte of the body, ms", lambda f: f"{med(f, 'first_s') * 1000:.0f}")
    row("gateway CPU per frame, us", lambda f: f"{med(f, 'cpu_s') / n * 1e6:.2f}")
    def most_growth(f):
        d = max(runs[f], key=lambda d: d["peak"] - d["rss0"])
        return f"{d['rss0']:.1f} -> {d['peak']:.1f}"
    row("gateway RSS before -> highest during, MiB (the download that grew it most)", most_growth)
    row("read back by pandas / h5py, s (all rows equal)",
        lambda f: f"{reads[f][0]:.2f} ({'yes' if reads[f][1] else 'NO'})")
    lines.append("")
    lines.append("| peer (the same rows, columns and chunks) | value |")
    lines.append("|---|---:|")
    lines.append(f"| h5py writing the HDF5 file from arrays in memory (libhdf5 alone), s | {peer_s:.2f} |")
    lines.append(f"| its file, bytes per frame (the gateway's HDF5: {med('hdf5', 'bytes') / n:.1f}) | "
                 f"{peer_bytes / n:.1f} |")
    details = (f"One stopped recording of {n:,} frames (3 axes), downloaded {args.repeat} times in each format, "
               f"one at a time over loopback. Goal: every download holds every row, and no download grows "
               f"the gateway's memory by {RSS_GOAL_MIB} MiB or more (largest growth this run: {growth:.1f} MiB).")
    return publish_section("Recording downloads", "bench/recording_export_bench.py", details, load_before,
                           os.getloadavg(), "\n".join(lines), met, args.results)


if __name__ == "__main__":
    sys.exit(main())
