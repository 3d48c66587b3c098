#!/usr/bin/python3
"""Benchmark: a command's round trip through the gateway against ser2net (issue 16).

The same command (`W X`, the position of X) goes to a simulated MS-2000 (ms2000-sim, preset plain, its
replies paced at --baud) four ways, each on its own simulator so that no two clients share a port:

* ser2net (chardelay false: bytes are passed on at once), the client writing "W X\\r" over raw TCP;
* the gateway with polling off: REST (POST /api/v1/controllers/ID/command, keep-alive) and WebSocket
  ({"op":"command",...});
* the gateway with its default polling (poll_ms 100, idle_poll_ms 500): REST and WebSocket again, to
  see what polling costs a user command.

The client is bench/roundtrip_client.c (built here with cc), so that it is not what is measured:
--count round trips one after the other, after 50 unmeasured ones. Rounds are interleaved (every
target once per round) and the table gives the median over rounds of each figure. Run at two paces:
115200 baud (a real controller's top rate) and 4,000,000 (a pty is as fast as the machine; the
gateway's own cost shows). Issue 16's goals: REST median at most 1.3x and WebSocket at most 1.2x
ser2net's; with default polling the p99 at most 10 % over polling off.

  scripts/build && bench/setup && /usr/bin/python3 bench/roundtrip_vs_ser2net.py [--rounds 5] [--count 5000]
"""

import argparse
import os
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import time

sys.dont_write_bytecode = True
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_gateway import Gateway, free_port  # noqa: E402
from bench_machine import publish_section  # noqa: E402
from bench_sim import Sim  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FIELDS = ["n", "p50", "p90", "p99", "max", "mean"]


def wait_for_port(port, proc, what, timeout=10):
    deadline = time.monotonic() + timeout
    while True:
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1).close()
            return
        except OSError:
            if proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"{what} did not start")
            time.sleep(0.05)


class Ser2net:
    def __init__(self, workdir, device):
        self.port = free_port()
        conf = os.path.join(workdir, "ser2net.yaml")
        with open(conf, "w") as f:
            f.write(f"""connection: &bench
  accepter: tcp,127.0.0.1,{self.port}
  connector: serialdev,{device},115200n81,local
  options:
    chardelay: false
    kickolduser: true
""")
        self.proc = subprocess.Popen(["ser2net", "-n", "-u", "-c", conf, "-P", os.path.join(workdir, "ser2net.pid")],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        wait_for_port(self.port, self.proc, "ser2net")

    def stop(self):
        self.proc.terminate()
        self.proc.wait(10)


def build_client(workdir):
    out = os.path.join(workdir, "roundtrip_client")
    subprocess.run(["cc", "-O2", "-std=c11", "-o", out, os.path.join(ROOT, "bench", "roundtrip_client.c")],
                   check=True)
    return out


def measure(client, mode, port, count, controller=None):
    args = [client, mode, str(port), str(count)] + ([controller] if controller else [])
    out = subprocess.run(args, capture_output=True, text=True, timeout=600)
    if out.returncode != 0:
        raise RuntimeError(f"{' '.join(args[1:])}: {out.stderr.strip()}")
    return dict(zip(FIELDS, map(float, out.stdout.split())))


def run_pace(args, client, baud, tmp):
    """{target: [runs]} for one baud rate."""
    work = tempfile.mkdtemp(prefix=f"b{baud}-", dir=tmp)
    sims, servers = [], []
    try:
        sims = [Sim(args.sim, work, name, baud) for name in ("s2n", "quiet", "polled")]
        ser2net = Ser2net(work, sims[0].link)
        servers.append(ser2net)
        gateways = {}
        for label, sim, poll in (("polling off", sims[1], 0), ("default polling", sims[2], None)):
            controller = {"id": "rt", "port": sim.link, "baud": 115200}
            if poll is not None:
                controller["poll_ms"] = poll
            gw_dir = tempfile.mkdtemp(prefix="gw-", dir=work)
            gw = Gateway(args.gateway, gw_dir, {"controllers": [controller]})
            servers.append(gw)
            gw.wait_ready()
            gateways[label] = gw
        targets = [("ser2net", "line", ser2net.port)]
        for label, gw in gateways.items():
            targets += [(f"REST, {label}", "http", gw.port), (f"WebSocket, {label}", "ws", gw.port)]
        runs = {}
        for r in range(args.rounds):
            for name, mode, port in targets:
                m = measure(client, mode, port, args.count, None if mode == "line" else "rt")
                runs.setdefault(name, []).append(m)
                print(f"{baud:>8} baud round {r + 1}: {name:28} p50 {m['p50']:8.1f} us  p99 {m['p99']:8.1f} us",
                      flush=True)
        return runs
    finally:
        for s in servers:
            s.stop()
        for s in sims:
            s.stop()


def med(runs, key):
    return statistics.median(r[key] for r in runs)


def table(results):
    lines = ["| baud | path | p50 us | p90 us | p99 us | mean us | p50 vs ser2net (goal) |",
             "|---:|---|---:|---:|---:|---:|---:|"]
    verdicts = []
    for baud, runs in results.items():
        base = med(runs["ser2net"], "p50")
        for name, rs in runs.items():
            ratio = med(rs, "p50") / base
            goal = ""
            if name.startswith("REST"):
                goal = " (<= 1.3)"
                verdicts.append(ratio <= 1.3)
            elif name.startswith("WebSocket"):
                goal = " (<= 1.2)"
                verdicts.append(ratio <= 1.2)
            lines.append(f"| {baud} | {name} | {med(rs, 'p50'):.1f} | {med(rs, 'p90'):.1f} | {med(rs, 'p99'):.1f} | "
                         f"{med(rs, 'mean'):.1f} | {ratio:.2f}x{goal} |")
    lines += ["", "| baud | path | p99 polling off us | p99 default polling us | growth (goal <= 10 %) |",
              "|---:|---|---:|---:|---:|"]
    for baud, runs in results.items():
        for kind in ("REST", "WebSocket"):
            off, on = med(runs[f"{kind}, polling off"], "p99"), med(runs[f"{kind}, default polling"], "p99")
            growth = (on / off - 1) * 100
            verdicts.append(growth <= 10)
            lines.append(f"| {baud} | {kind} | {off:.1f} | {on:.1f} | {growth:+.1f} % |")
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
    tmp = tempfile.mkdtemp(prefix="gw-rt-bench-")
    try:
        client = build_client(tmp)
        load_before = os.getloadavg()
        results = {baud: run_pace(args, client, baud, tmp) for baud in (args.baud or [115200, 4000000])}
        load_after = os.getloadavg()
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    text, met = table(results)
    details = f"`W X`, {args.count} round trips per run, medians of {args.rounds} interleaved rounds."
    return publish_section("Command round trip against ser2net", "bench/roundtrip_vs_ser2net.py", details,
                           load_before, load_after, text, met, args.results)


if __name__ == "__main__":
    sys.exit(main())
