#!/usr/bin/python3
"""Planning speed and memory of `asi-gateway gcode plan` on a generated 1,000,000-line program, side
by side with LinuxCNC's interpreter `rs274 -g` (Debian linuxcnc-uspace) on the same file.

The program mixes what the Tracer subset has: straight feeds (G01), rapids (G00), arcs both ways
(G02/G03, I/J form), dwells (G04) and TTL switches (M03/M05), on a serpentine of 1 mm rows. Every run
writes its output to /dev/null; wall time and the child's max RSS come from os.wait4. Each command
runs --repeat times (default 3); the table shows the median and the range.

rs274 reads the same text with LinuxCNC's meanings (G04 P in seconds, M03 = spindle on); it is a
peer for speed, not for results (tests/integration/gcode/ compares the results where both agree).

    /usr/bin/python3 bench/gcode_plan.py [--gateway build/gateway/asi-gateway] [--lines 1000000]
        [--repeat 3] [--results bench/RESULTS.md]   (--results appends a section)
"""

import argparse
import datetime
import os
import random
import shutil
import statistics
import subprocess
import sys
import tempfile

sys.dont_write_bytecode = True
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_machine import machine_line  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def generate(path, lines, seed=5):
    """Writes the program; returns its size in bytes. Deterministic for a seed."""
    rnd = random.Random(seed)
    out = ["G21 G90 G17", "G00 X0 Y0", "G01 F600"]
    x, y, row = 0.0, 0.0, 0
    ttl = False
    while len(out) < lines - 2:
        r = rnd.random()
        if r < 0.55:  # a straight feed along the row
            step = rnd.uniform(0.05, 0.5) * (1 if row % 2 == 0 else -1)
            x = round(x + step, 4)
            out.append(f"G01 X{x:.4f} Y{y:.4f}")
        elif r < 0.75:  # a half circle to the next row (or back), alternating direction
            code = "G02" if rnd.random() < 0.5 else "G03"
            out.append(f"{code} X{x:.4f} Y{y + 1:.4f} I0 J0.5")
            y = round(y + 1, 4)
            row += 1
        elif r < 0.83:  # TTL switch
            ttl = not ttl
            out.append("M03" if ttl else "M05")
        elif r < 0.90:
            out.append(f"G04 P{rnd.randint(1, 50)}")
        else:  # a rapid hop
            x = round(x + rnd.uniform(-1, 1), 4)
            out.append(f"G00 X{x:.4f} Y{y:.4f}")
    out.append("M05")
    out.append("M30")
    with open(path, "w") as f:
        for line in out:
            f.write(line + "\n")
    return os.path.getsize(path)


def measure(cmd, tmp):
    """(wall s, CPU s (user + sys), max RSS MiB, exit code) of one run with stdout to /dev/null. The CPU
    time matters on a loaded machine, where the wall time mostly measures the others. GNU time measures: a child
    forked (or vforked) from this Python process would count Python's own RSS too (Linux keeps the
    pre-exec high-water mark in ru_maxrss)."""
    report = os.path.join(tmp, "time.txt")
    with open(os.devnull, "wb") as null:
        code = subprocess.run(["/usr/bin/time", "-f", "%e %U %S %M", "-o", report, *cmd], stdout=null,
                              stderr=subprocess.DEVNULL).returncode
    with open(report) as f:
        wall, user, system, kib = f.read().split()[-4:]
    return float(wall), float(user) + float(system), int(kib) / 1024, code


def machine():
    return f"{machine_line()}, load average {os.getloadavg()[0]:.1f} at start"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", default=os.path.join(ROOT, "build", "gateway", "asi-gateway"))
    ap.add_argument("--rs274", default=shutil.which("rs274") or "/usr/bin/rs274")
    ap.add_argument("--lines", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--results", help="append the table to this markdown file (bench/RESULTS.md)")
    args = ap.parse_args()

    tmp = tempfile.mkdtemp(prefix="gw-gcode-bench-")
    try:
        program = os.path.join(tmp, "bench.ngc")
        size = generate(program, args.lines)
        tools = os.path.join(tmp, "tools.tbl")
        with open(tools, "w") as f:
            f.write("T1 P1 D0 Z0 ;\n")
        runs = [("asi-gateway gcode plan (moves JSON)", [args.gateway, "gcode", "plan", program]),
                ("asi-gateway gcode plan --summary", [args.gateway, "gcode", "plan", "--summary", program])]
        if os.path.exists(args.rs274):
            runs.append(("LinuxCNC rs274 -g (canonical calls)", [args.rs274, "-g", "-t", tools, program]))
        else:
            print(f"rs274 not found at {args.rs274}: the peer is skipped", file=sys.stderr)
        plan_path = os.path.join(tmp, "plan.json")
        with open(plan_path, "wb") as f:
            subprocess.run([args.gateway, "gcode", "plan", program], stdout=f, check=True)
        plan_bytes = os.path.getsize(plan_path)
        os.remove(plan_path)
        rows = []
        for name, cmd in runs:
            results = [measure(cmd, tmp) for _ in range(args.repeat)]
            codes = {r[3] for r in results}
            secs = [r[0] for r in results]
            cpu = [r[1] for r in results]
            rss = [r[2] for r in results]
            rows.append((name, statistics.median(secs), min(secs), max(secs), statistics.median(cpu), max(rss), codes))
        when = datetime.datetime.now().strftime("%Y-%m-%d %H:%M")
        lines = [f"## G-code planning: {args.lines:,} lines (run of {when})", "",
                 f"`bench/gcode_plan.py`: a generated program of {args.lines:,} lines ({size / 1e6:.1f} MB: "
                 "G01 55 %, G02/G03 half circles 20 %, M03/M05 8 %, G04 7 %, G00 10 %), output to /dev/null, "
                 f"{args.repeat} runs each (wall time and max RSS by GNU time). The plan JSON is {plan_bytes / 1e6:.1f} MB.",
                 "",
                 f"Machine: {machine()}.", "",
                 "| command | wall s (median) | wall s (range) | CPU s (median, user+sys) | max RSS MiB | exit |",
                 "| --- | ---: | --- | ---: | ---: | --- |"]
        for name, med, lo, hi, cpu, rss, codes in rows:
            lines.append(f"| {name} | {med:.2f} | {lo:.2f}-{hi:.2f} | {cpu:.2f} | {rss:.1f} | "
                         f"{','.join(map(str, sorted(codes)))} |")
        text = "\n".join(lines) + "\n"
        print(text)
        if args.results:
            with open(args.results, "a") as f:
                f.write("\n" + text)
        return 0 if all(r[6] == {0} for r in rows) else 1
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
