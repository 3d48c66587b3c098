#!/usr/bin/python3
"""Benchmark: estimated vs simulated job durations, for every job type and path.

Starts the real asi-gateway with three in-process simulated controllers (--simulate 3: sim1 "full"
with ARRAY/RING BUFFER/SCAN, sim2 "plain" without modules, sim3 "planar" with PLANAR CORRECTION),
then for each case submits the job with ?dry_run=true (the plan's estimated_s), submits it for real
and waits for it to finish. The measured duration is the job record's finished - started (the
gateway's own timestamps), cross-checked by the wall time between the first poll that saw it running
and the first that saw it finished. With --time-scale N the simulators run N times faster and every
measured duration is multiplied by N, so all figures are in simulated seconds.

A case whose job type (or path) is not available yet is reported as "not available" with the reason
the gateway gave. Prints a table and writes bench/RESULTS.md (figures + machine). Standard library
only; run with Debian's /usr/bin/python3 (see bench/README.md).
"""

import argparse
import datetime
import http.client
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time

from bench_gateway import Gateway, parse_time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
TARGET = 0.10  # |estimate - measured| / measured
TERMINAL = {"succeeded", "failed", "cancelled", "interrupted"}

# A 4 x 3 grid on a 9 mm pitch (the seed's plate pitch): 12 wells, 11 moves of 9 mm, ~20 s per run.
GRID = {"columns": 4, "rows": 3, "column_step_mm": 9.0, "row_step_mm": -9.0}
SCAN = {
    "fast_axis": "X",
    "slow_axis": "Y",
    "fast": {"start_mm": 0.0, "stop_mm": 2.0, "encoder_divide": 24},
    "slow": {"start_mm": 0.0, "stop_mm": -0.9, "lines": 10},
    "pattern": "raster",
    "speed_mm_s": 1.0,
}
RING = [{"X": 0, "Y": 0}, {"X": 6000, "Y": 0}, {"X": 6000, "Y": -6000},
        {"X": 0, "Y": -6000}, {"X": 3000, "Y": -3000}, {"X": 0, "Y": 0}]

# (name, controller, type, spec). sim1 has the modules, sim2 has none (host-driven paths).
CASES = [
    ("array firmware", "sim1", "array",
     {"grid": GRID, "a1": {"X": 0, "Y": 0}, "order": "serpentine", "dwell_ms": 100, "mode": "firmware"}),
    ("array host", "sim2", "array",
     {"grid": GRID, "a1": {"X": 0, "Y": 0}, "order": "serpentine", "dwell_ms": 100, "mode": "host"}),
    ("scan firmware", "sim1", "scan", dict(SCAN, mode="firmware")),
    ("scan host", "sim2", "scan", dict(SCAN, mode="host")),
    ("ring_buffer firmware", "sim1", "ring_buffer",
     {"positions": RING, "axes": "XY", "trigger": "autoplay", "delay_ms": 200, "repeat": False,
      "mode": "firmware"}),
    ("ring_buffer host", "sim2", "ring_buffer",
     {"positions": RING, "axes": "XY", "trigger": "autoplay", "delay_ms": 200, "repeat": False, "mode": "host"}),
    ("planar_correction", "sim3", "planar_correction",
     {"action": "set", "points": [{"X": 0, "Y": 0, "Z": 0}, {"X": 20000, "Y": 0, "Z": 50},
                                  {"X": 0, "Y": -20000, "Z": -30}], "enable": True}),
]


def problem_text(status, body):
    if isinstance(body, dict):
        return f"{status} {body.get('title', '')}: {body.get('detail', '')}".strip()
    return f"{status} {str(body)[:200]}"


def wait_idle(gw, controller, timeout=120):
    """Until the controller's snapshot says not busy (a previous job's last move has settled)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        status, body = gw.request("GET", f"/api/v1/controllers/{controller}")
        if status == 200 and isinstance(body, dict) and not body.get("busy", False):
            return
        time.sleep(0.1)


def run_case(gw, name, controller, job_type, spec, time_scale, job_timeout):
    row = {"case": name, "controller": controller, "type": job_type}
    wait_idle(gw, controller)
    body = {"controller": controller, "type": job_type, "spec": spec}
    status, dry = gw.request("POST", "/api/v1/jobs?dry_run=true", body)
    if status != 200 or not isinstance(dry, dict) or "plan" not in dry:
        row["status"] = "not available: " + problem_text(status, dry)
        return row
    plan = dry["plan"]
    row["path"] = plan.get("path")
    row["steps"] = plan.get("steps_total")
    row["estimated_s"] = plan.get("estimated_s")

    status, job = gw.request("POST", "/api/v1/jobs", body)
    if status not in (200, 201) or not isinstance(job, dict) or "id" not in job:
        row["status"] = "submit refused: " + problem_text(status, job)
        return row
    job_id = job["id"]
    row["job"] = job_id
    row["record_estimated_s"] = job.get("estimated_s")
    seen_running = seen_done = None
    deadline = time.monotonic() + job_timeout
    while time.monotonic() < deadline:
        status, job = gw.request("GET", f"/api/v1/jobs/{job_id}")
        now = time.monotonic()
        state = job.get("state") if isinstance(job, dict) else None
        if state == "running" and seen_running is None:
            seen_running = now
        if state in TERMINAL:
            seen_done = now
            break
        time.sleep(0.02)
    else:
        gw.request("POST", f"/api/v1/jobs/{job_id}/cancel")
        row["status"] = f"timed out after {job_timeout} s (cancelled)"
        return row
    row["state"] = job["state"]
    if job["state"] != "succeeded":
        row["status"] = f"{job['state']}: {job.get('reason', '')}"
        return row
    started, finished = parse_time(job.get("started")), parse_time(job.get("finished"))
    if started is not None and finished is not None:
        row["measured_s"] = (finished - started) * time_scale
    if seen_running is not None:
        row["wall_s"] = (seen_done - seen_running) * time_scale
    # Per-step timing from the stored events, to find where a gap comes from.
    status, events = gw.request("GET", f"/api/v1/jobs/{job_id}/events?limit=1000")
    if status == 200 and isinstance(events, dict):
        row["step_elapsed_s"] = [
            (e.get("name"), e.get("elapsed_s")) for e in events.get("events", [])
            if isinstance(e, dict) and e.get("type") == "step"
        ]
    est, meas = row.get("estimated_s"), row.get("measured_s")
    if est is not None and meas:
        row["error"] = (est - meas) / meas
        row["status"] = "ok" if abs(row["error"]) <= TARGET else "OFF TARGET"
    else:
        row["status"] = "no timestamps"
    return row


def fmt(v, spec=".2f"):
    return "-" if v is None else format(v, spec)


def table(rows):
    head = "| case | controller | path | steps | estimated s | measured s | wall s | error | result |"
    lines = [head, "|---|---|---|---:|---:|---:|---:|---:|---|"]
    for r in rows:
        err = r.get("error")
        lines.append("| {} | {} | {} | {} | {} | {} | {} | {} | {} |".format(
            r["case"], r["controller"], r.get("path") or "-", r.get("steps") if r.get("steps") is not None else "-",
            fmt(r.get("estimated_s")), fmt(r.get("measured_s")), fmt(r.get("wall_s")),
            "-" if err is None else f"{err * 100:+.1f} %", r["status"]))
    return "\n".join(lines)


def machine():
    info = {"python": platform.python_version()}
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, check=False).stdout
        for line in out.splitlines():
            key, _, value = line.partition(":")
            if key.strip() in ("Model name", "CPU(s)", "Thread(s) per core", "Core(s) per socket"):
                info[key.strip()] = value.strip()
    except OSError:
        pass
    info["cores available"] = str(os.cpu_count())
    try:
        with open("/etc/debian_version") as f:
            info["Debian"] = f.read().strip()
    except OSError:
        pass
    info["kernel"] = platform.release()
    try:
        load = os.getloadavg()
        info["load average at the end"] = " ".join(f"{x:.2f}" for x in load)
    except OSError:
        pass
    return info


def git_commit():
    try:
        return subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True, check=False).stdout.strip()
    except OSError:
        return ""


OWN_SECTIONS = ("Per-step elapsed time", "Analysis")


def other_sections(path):
    """The sections other benchmarks wrote into RESULTS.md ("## G-code ..."), kept as they are."""
    try:
        with open(path) as f:
            old = f.read()
    except OSError:
        return ""
    parts = old.split("\n## ")[1:]  # the first part is this benchmark's header and table
    return "".join("\n## " + p.rstrip("\n") + "\n" for p in parts if not p.startswith(OWN_SECTIONS))


def write_results(path, rows, args, started, elapsed):
    m = machine()
    kept = other_sections(path)
    with open(path, "w") as f:
        f.write("# Job ETA benchmark: estimated vs simulated durations\n\n")
        f.write("Written by `bench/job_eta.py` (see README.md). Figures are simulated seconds: the gateway's\n"
                "`estimated_s` from `?dry_run=true`, and the job record's `finished - started` (\"measured\")\n"
                "and the polled wall time (\"wall\"), both multiplied by the time scale. Target: "
                f"|error| <= {TARGET * 100:.0f} %.\n\n")
        f.write(f"- run: {started} UTC, {elapsed:.0f} s, commit {git_commit()}\n")
        gateway = os.path.relpath(os.path.abspath(args.gateway), ROOT)  # no machine paths in RESULTS.md
        if gateway.startswith(".."):
            gateway = os.path.basename(gateway) + " (built outside this checkout)"
        f.write(f"- gateway: `{gateway}` --config (simulate 3, time scale {args.time_scale})\n")
        for k, v in m.items():
            f.write(f"- {k}: {v}\n")
        f.write("\n" + table(rows) + "\n")
        notes = [r for r in rows if r.get("step_elapsed_s")]
        if notes:
            f.write("\n## Per-step elapsed time (simulated s, from the job's step events)\n\n")
            for r in notes:
                steps = r["step_elapsed_s"]
                shown = ", ".join(f"{n} {fmt(e * args.time_scale if e is not None else None)}"
                                  for n, e in steps[:16])
                more = f", ... ({len(steps)} steps)" if len(steps) > 16 else ""
                f.write(f"- {r['case']}: {shown}{more}\n")
        if args.notes and os.path.exists(args.notes):
            with open(args.notes) as n:
                f.write("\n" + n.read())
        f.write(kept)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--gateway", default=os.path.join(ROOT, "build", "gateway", "asi-gateway"))
    p.add_argument("--time-scale", type=float, default=1.0,
                   help="simulator speed-up; durations are converted back to simulated seconds")
    p.add_argument("--only", nargs="*", help="case names (or job types) to run")
    p.add_argument("--results", default=os.path.join(HERE, "RESULTS.md"))
    p.add_argument("--no-results", action="store_true", help="print only, do not write RESULTS.md")
    p.add_argument("--notes", default=os.path.join(HERE, "analysis.md"),
                   help="a markdown file appended to RESULTS.md (the analysis of any gap)")
    p.add_argument("--job-timeout", type=float, default=300)
    p.add_argument("--keep", action="store_true", help="keep the scratch directory (gateway log, database)")
    args = p.parse_args()
    if not os.access(args.gateway, os.X_OK):
        sys.exit(f"no gateway binary at {args.gateway}: build first (scripts/build), or pass --gateway")

    cases = [c for c in CASES if not args.only or c[0] in args.only or c[2] in args.only]
    workdir = tempfile.mkdtemp(prefix="gw-bench-")
    started = datetime.datetime.utcnow().strftime("%Y-%m-%d %H:%M")
    t0 = time.monotonic()
    gw = Gateway(args.gateway, workdir, {
        "simulate": {"count": 3, "time_scale": args.time_scale, "directory": os.path.join(workdir, "sims")}})
    rows = []
    try:
        gw.wait_ready()
        for name, controller, job_type, spec in cases:
            print(f"... {name}", file=sys.stderr, flush=True)
            try:
                row = run_case(gw, name, controller, job_type, spec, args.time_scale, args.job_timeout)
            except (OSError, http.client.HTTPException, ValueError) as e:
                row = {"case": name, "controller": controller, "type": job_type, "status": f"error: {e}"}
            rows.append(row)
            print(f"    {row['status']}", file=sys.stderr, flush=True)
    finally:
        gw.stop()
        if args.keep:
            print(f"scratch directory kept: {workdir}", file=sys.stderr)
        else:
            shutil.rmtree(workdir, ignore_errors=True)
    print(table(rows))
    if not args.no_results:
        write_results(args.results, rows, args, started, time.monotonic() - t0)
        print(f"written: {args.results}", file=sys.stderr)
    measured = [r for r in rows if "error" in r]
    return 0 if measured and all(abs(r["error"]) <= TARGET for r in measured) else 1


if __name__ == "__main__":
    sys.exit(main())
