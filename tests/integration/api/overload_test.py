#!/usr/bin/python3
"""Overload degrades, it does not disconnect (issue 16): 100 WebSocket clients that keep reading
survive a report load the gateway cannot carry in full, and each is told exactly what it missed.

The load: 4 report ports fed at 2,000 frames/s each (bench/report_generator.c, raw frames on ptys),
to 100 clients that take every event as its own message (no batch window): 800,000 WebSocket messages
a second, more than one I/O thread can write on any machine, so the hub must leave events out. The
clients are bench/fanout_client.c (one epoll process, light enough to keep reading). Checked: no
client closed, some events told missed (the overload happened), and for every client its events
plus what its gap events told it it missed equal the frames the gateway published, exactly.

Run by ctest with Debian's /usr/bin/python3 (stdlib only; cc builds the two C tools). Nothing
asserts wall-clock speed: the end waits for the gateway's own delivery counter to stand still.
"""

import argparse
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
sys.path.insert(0, os.path.join(ROOT, "bench"))
from bench_gateway import Gateway  # noqa: E402
from bench_sim import Sim  # noqa: E402
from fanout import build, metric_sum, pairs, read_line, stop_all, wait_for_report_ports  # noqa: E402

CONTROLLERS = 4
RATE_HZ = 2000
CLIENTS = 100
SECONDS = 3


def wait_until_delivered(gw):
    """Until the hub has handed out everything: its delivery counter still for two seconds."""
    last, still_since = None, time.monotonic()
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline:
        now = metric_sum(gw, "gw_events_delivered_total")
        if now != last:
            last, still_since = now, time.monotonic()
        elif time.monotonic() - still_since >= 2:
            return
        time.sleep(0.2)
    raise RuntimeError("the gateway kept delivering for five minutes after the frames stopped")


def run(args, tmp):
    generator_bin, client_bin = build(tmp, "report_generator"), build(tmp, "fanout_client")
    reports = os.path.join(tmp, "reports")
    os.makedirs(reports)
    generator = subprocess.Popen([generator_bin, reports, str(CONTROLLERS), str(RATE_HZ)],
                                 stdout=subprocess.PIPE, text=True)
    sims, gw, client = [], None, None
    try:
        read_line(generator, "ready")
        sims = [Sim(args.sim, tmp, f"c{i}", 115200) for i in range(CONTROLLERS)]
        config = {"controllers": [{"id": f"c{i}", "port": s.link, "report_port": os.path.join(reports, f"r{i}"),
                                   "baud": 115200} for i, s in enumerate(sims)],
                  "http": {"limits": {"max_connections": 500, "max_connections_per_address": 400}}}
        gw_dir = os.path.join(tmp, "gateway")
        os.makedirs(gw_dir)
        gw = Gateway(args.gateway, gw_dir, config)
        gw.wait_ready()
        wait_for_report_ports(gw)
        client = subprocess.Popen([client_bin, str(gw.port), str(CLIENTS), "-1", "controllers/+/reports"],
                                  stdout=subprocess.PIPE, text=True)
        read_line(client, "subscribed")
        time.sleep(1)  # every subscription in place before the first frame
        generator.send_signal(signal.SIGUSR1)
        time.sleep(SECONDS)
        generator.terminate()
        generator.stdout.readline()
        # The last frames read from the ptys, then every queue emptied (or told as a gap).
        published_before = -1
        while True:
            time.sleep(1)
            published = metric_sum(gw, "gw_controller_report_frames_total")
            if published == published_before:
                break
            published_before = published
        wait_until_delivered(gw)
        evicted = metric_sum(gw, "gw_events_evicted_subscribers_total")
        client.terminate()
        got = pairs(client.stdout.readline())
        return published, evicted, got
    finally:
        stop_all([client, generator])
        if gw:
            gw.stop()
        for s in sims:
            s.stop()


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--gateway", required=True)
    p.add_argument("--sim", required=True)
    args = p.parse_args()
    tmp = tempfile.mkdtemp(prefix="gw-overload-")
    try:
        published, evicted, got = run(args, tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"frames published {int(published)}; per client: events {int(got['min_events'])}..{int(got['max_events'])}, "
          f"accounted {int(got['min_accounted'])}..{int(got['max_accounted'])}; told missed {int(got['missed'])} "
          f"in all; closed {int(got['closed'])}; evicted {int(evicted)}")
    failures = []
    if published <= 0:
        failures.append("no frame was published")
    if got["clients"] != CLIENTS:
        failures.append(f"{int(got['clients'])} clients instead of {CLIENTS}")
    if got["closed"] != 0 or evicted != 0:
        failures.append(f"clients that kept reading were closed ({int(got['closed'])}, evicted {int(evicted)})")
    if got["missed"] == 0:
        failures.append("nothing was told missed: the load did not overload the gateway, the test proves nothing")
    if not (got["min_accounted"] == got["max_accounted"] == published):
        failures.append(f"a client's events plus what it was told it missed are {int(got['min_accounted'])}.."
                        f"{int(got['max_accounted'])}, not the {int(published)} frames published")
    for f in failures:
        print("FAIL:", f)
    print("overload test:", "FAILED" if failures else "passed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
