#!/usr/bin/python3
"""Benchmark: a command's round trip through a shared controller port against ser2net (issue 32).

The same command (`W X`) goes to a simulated MS-2000 (ms2000-sim, preset plain, replies paced at
--baud), each path on its own simulator so that no two share a port:

* ser2net (chardelay false), the client writing "W X\\r" over raw TCP;
* the gateway's shared TCP port, polling off and with the default polling (poll_ms 100,
  idle_poll_ms 500): the same raw TCP client;
* a pty client on the simulator's own pseudo-terminal (what a program does without a gateway), the
  gateway's shared pty (polling off), and socat relaying a pty of its own to the simulator's, bytes
  as they come and nothing checked: the least any program that shares a pty adds (a second
  pseudo-terminal to cross, and one process's turn).

The client is bench/roundtrip_client.c (built here with cc), --count round trips one after the other
after 50 unmeasured ones; rounds are interleaved and the tables give the median over rounds. CPU per
command: the server process's user+system time (/proc/PID/stat) over the run, divided by the round
trips (the gateway's includes its polls when polling is on). Issue 32's goals: shared TCP median at
most 1.1x ser2net's at 115200 and 1.2x at 4 Mbaud; p99 with the default polling at most 1.2x
ser2net's; shared pty median at most 1.1x the direct pty client's.

  scripts/build && bench/setup && /usr/bin/python3 bench/share_vs_ser2net.py [--rounds 5] [--count 5000]
"""

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile

sys.dont_write_bytecode = True
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_gateway import Gateway, free_port  # noqa: E402
from bench_machine import publish_section  # noqa: E402
from bench_sim import Sim, wait_for_path  # noqa: E402
from roundtrip_vs_ser2net import FIELDS, Ser2net, build_client  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TICK_US = 1e6 / os.sysconf("SC_CLK_TCK")
WARMUP = 50


def cpu_us(pid):
    """User + system CPU time of a process so far, in microseconds."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) * TICK_US


def measure(client, mode, where, count, server_pid):
    before = cpu_us(server_pid) if server_pid else 0.0
    out = subprocess.run([client, mode, str(where), str(count)], capture_output=True, text=True, timeout=600)
    if out.returncode != 0:
        raise RuntimeError(f"{mode} {where}: {out.stderr.strip()}")
    m = dict(zip(FIELDS, map(float, out.stdout.split())))
    m["cpu"] = (cpu_us(server_pid) - before) / (count + WARMUP) if server_pid else float("nan")
    return m


class SocatRelay:
    """socat between a pty of its own (at `link`) and the simulator's: raw, no line handling."""

    def __init__(self, workdir, device):
        self.link = os.path.join(workdir, "socat-pty")
        self.proc = subprocess.Popen(["socat", f"PTY,link={self.link},rawer", f"{device},rawer"],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        wait_for_path(self.link, self.proc, "socat")

    def stop(self):
        self.proc.terminate()
        self.proc.wait(10)


def run_pace(args, client, baud, tmp):
    """{target: [runs]} for one baud rate."""
    work = tempfile.mkdtemp(prefix=f"b{baud}-", dir=tmp)
    sims, servers = [], []
    try:
        sims = {name: Sim(args.sim, work, name, baud) for name in ("s2n", "quiet", "polled", "direct", "relayed")}
        ser2net = Ser2net(work, sims["s2n"].link)
        servers.append(ser2net)
        socat = SocatRelay(work, sims["relayed"].link)
        servers.append(socat)
        shares = {}
        for label, sim, poll in (("polling off", sims["quiet"], 0), ("default polling", sims["polled"], None)):
            tcp = free_port()
            pty = os.path.join(work, f"share-{label.split()[0]}")
            controller = {"id": "rt", "port": sim.link, "baud": 115200,
                          "share": {"pty": pty, "tcp": f"127.0.0.1:{tcp}"}}
            if poll is not None:
                controller["poll_ms"] = poll
            gw = Gateway(args.gateway, tempfile.mkdtemp(prefix="gw-", dir=work), {"controllers": [controller]})
            servers.append(gw)
            gw.wait_ready()
            shares[label] = (gw, tcp, pty)
        targets = [("ser2net", "line", ser2net.port, ser2net.proc.pid)]
        for label, (gw, tcp, _) in shares.items():
            targets.append((f"shared TCP, {label}", "line", tcp, gw.proc.pid))
        targets.append(("direct pty", "pty", sims["direct"].link, None))
        gw, _, pty = shares["polling off"]
        targets.append(("shared pty, polling off", "pty", pty, gw.proc.pid))
        targets.append(("socat pty relay", "pty", socat.link, socat.proc.pid))
        runs = {}
        for r in range(args.rounds):
            for name, mode, where, pid in targets:
                m = measure(client, mode, where, args.count, pid)
                runs.setdefault(name, []).append(m)
                print(f"{baud:>8} baud round {r + 1}: {name:28} p50 {m['p50']:8.1f} us  p99 {m['p99']:8.1f} us"
                      f"  cpu {m['cpu']:6.1f} us/cmd", flush=True)
        return runs
    finally:
        for s in servers:
            s.stop()
        for s in sims.values() if isinstance(sims, dict) else sims:
            s.stop()


def med(runs, key):
    return statistics.median(r[key] for r in runs)


def table(results):
    lines = ["| baud | path | p50 us | p90 us | p99 us | server CPU us/command | p50 vs base (goal) | p99 vs ser2net (goal) |",
             "|---:|---|---:|---:|---:|---:|---:|---:|"]
    verdicts = []
    for baud, runs in results.items():
        s2n50, s2n99 = med(runs["ser2net"], "p50"), med(runs["ser2net"], "p99")
        direct50 = med(runs["direct pty"], "p50")
        tcp_goal = 1.1 if baud <= 115200 else 1.2
        for name, rs in runs.items():
            p50, p99, cpu = med(rs, "p50"), med(rs, "p99"), med(rs, "cpu")
            ratio50, ratio99 = "", ""
            if name.startswith("shared TCP"):
                ratio50 = f"{p50 / s2n50:.2f}x of ser2net (<= {tcp_goal})"
                verdicts.append(p50 / s2n50 <= tcp_goal)
                if "default polling" in name:
                    ratio99 = f"{p99 / s2n99:.2f}x (<= 1.2)"
                    verdicts.append(p99 / s2n99 <= 1.2)
            elif name.startswith("shared pty"):
                ratio50 = f"{p50 / direct50:.2f}x of direct (<= 1.1)"
                verdicts.append(p50 / direct50 <= 1.1)
            elif name.startswith("socat"):
                ratio50 = f"{p50 / direct50:.2f}x of direct"
            cpu_text = "" if cpu != cpu else f"{cpu:.1f}"
            lines.append(f"| {baud} | {name} | {p50:.1f} | {med(rs, 'p90'):.1f} | {p99:.1f} | {cpu_text} | "
                         f"{ratio50} | {ratio99} |")
    return "\n".join(lines), all(verdicts)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--gateway", default=os.path.join(ROOT, "build", "gateway", "asi-gateway"))
    p.add_argument("--sim", default=os.path.join(ROOT, "build", "devices", "sim", "ms2000-sim"))
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("--count", type=int, default=5000)
    p.add_argument("--baud", type=int, action="append", default=[], help="pace (repeatable; default 115200 and 4000000)")
    p.add_argument("--results", default="", help="append the tables to this file (e.g. bench/RESULTS.md)")
    args = p.parse_args()
    if not shutil.which("ser2net"):
        sys.exit("ser2net is missing: run bench/setup")
    tmp = tempfile.mkdtemp(prefix="gw-share-bench-")
    try:
        client = build_client(tmp)
        load_before = os.getloadavg()
        results = {baud: run_pace(args, client, baud, tmp) for baud in (args.baud or [115200, 4000000])}
        load_after = os.getloadavg()
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    text, met = table(results)
    details = (f"`W X`, {args.count} round trips per run, medians of {args.rounds} interleaved rounds; server CPU "
               "from /proc (the gateway's includes its polls).")
    return publish_section("Shared port round trip against ser2net", "bench/share_vs_ser2net.py", details,
                           load_before, load_after, text, met, args.results)


if __name__ == "__main__":
    sys.exit(main())
