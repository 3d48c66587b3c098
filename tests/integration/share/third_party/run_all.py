#!/usr/bin/env python3
"""Runs every third-party driver runner (run_<driver>.py beside this file) against one controller
port, each as a subprocess of this interpreter (the virtual environment made by setup-venv) with a
time limit, prints their step lines and a summary table, and exits non-zero if any runner failed.
With --url, every runner runs a second time through that rfc2217:// URL. A runner that exits 77
(its driver is not at hand: run_storm.py without $STORM_CONTROL_SRC) counts as skipped. This is what
proves that unmodified third-party MS-2000 drivers work through a port: the simulator's pty, or the
gateway's shared pty and its RFC 2217 TCP port.

Usage: DIR/bin/python run_all.py --port PATH [--url rfc2217://HOST:PORT] [--allow-known-gaps]
                                 [--only NAME ...] [--timeout SECONDS]
The runners move the stage: give each run a controller nothing else is moving.
"""

import argparse
import glob
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
SKIPPED = 77  # a runner whose driver is not at hand (run_storm.py without a storm-control source)


def runners():
    paths = sorted(glob.glob(os.path.join(HERE, "run_*.py")))
    return {os.path.basename(p)[4:-3]: p for p in paths if not p.endswith("run_all.py")}


def run_one(path, port, args):
    command = [sys.executable, path, "--port", port]
    if args.allow_known_gaps:
        command.append("--allow-known-gaps")
    started = time.monotonic()
    try:
        done = subprocess.run(command, cwd=HERE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                              timeout=args.timeout, env={**os.environ, "PYTHONDONTWRITEBYTECODE": "1"})
        status = {0: "pass", SKIPPED: "skip"}.get(done.returncode, "FAIL")
        output = done.stdout
        errors = done.stderr
    except subprocess.TimeoutExpired as expired:
        output, errors = _text(expired.stdout), _text(expired.stderr)
        status = "TIMEOUT"
    seconds = time.monotonic() - started
    lines = output.splitlines()
    marks = ("ok", "FAIL", "GAP", "n/a")
    counts = {mark: sum(1 for line in lines if line.startswith(mark)) for mark in marks}
    return status, seconds, counts, lines, errors


def _text(data):
    if data is None:
        return ""
    return data.decode(errors="replace") if isinstance(data, bytes) else data


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--port", required=True, help="the controller's serial device path")
    parser.add_argument("--url", help="also run every runner through this rfc2217:// URL")
    parser.add_argument("--allow-known-gaps", action="store_true", help="passed on to every runner")
    parser.add_argument("--only", nargs="+", metavar="NAME", help="run only these (names as in run_NAME.py)")
    parser.add_argument("--timeout", type=float, default=240, help="seconds per runner (default 240)")
    args = parser.parse_args()

    selected = runners()
    if args.only:
        unknown = set(args.only) - set(selected)
        if unknown:
            parser.error(f"no runner named {', '.join(sorted(unknown))}; have {', '.join(selected)}")
        selected = {name: selected[name] for name in args.only}
    ports = [args.port] + ([args.url] if args.url else [])

    rows = []
    for port in ports:
        for name, path in selected.items():
            print(f"== {name} --port {port}", flush=True)
            status, seconds, counts, lines, errors = run_one(path, port, args)
            for line in lines:
                print(f"   {line}")
            if status != "pass" and errors.strip():
                print("   stderr (last lines):")
                for line in errors.strip().splitlines()[-8:]:
                    print(f"     {line}")
            rows.append((name, port, status, counts, seconds))

    print()
    header = (f"{'driver':<12} {'port':<32} {'result':<8} {'ok':>3} {'FAIL':>4} {'GAP':>3} {'n/a':>3} "
              f"{'seconds':>7}")
    print(header)
    print("-" * len(header))
    for name, port, status, counts, seconds in rows:
        print(f"{name:<12} {port:<32} {status:<8} {counts['ok']:>3} {counts['FAIL']:>4} {counts['GAP']:>3} "
              f"{counts['n/a']:>3} {seconds:>7.1f}")
    failed = sum(1 for row in rows if row[2] not in ("pass", "skip"))
    skipped = sum(1 for row in rows if row[2] == "skip")
    print(f"{len(rows) - failed - skipped} passed, {failed} failed, {skipped} skipped")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
