"""The long proof of position recordings (issue 35): 100,000 camera triggers at 500 Hz, recorded by
the real asi-gateway from an external ms2000-sim's report port, in five trains of 20,000 with the
stage moved between them. Every frame is there, counted 0..99,999 with no loss marker, each at the
stage position of its train; the CSV download (streamed) is read back by pandas.
The simulator's clock runs --time-scale times faster than real time (default 4: the 200 s of
triggers take 50 s, and 2,000 frames a second reach the gateway, four times the issue's rate; 1 runs
the proof at 500 frames/s of real time).
Also: the gateway's resident memory while the 100,000-row CSV and JSON Lines downloads stream stays
within a few megabytes of what it was before (the rows are not gathered in memory).
"""

import argparse
import io
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gateway_fixture import (TOKENS, Failure, Fixture, auth_tokens, check, free_port, run_main,  # noqa: E402
                             vm_kib, wait_until)
from recordings_api_test import call, download, move_x  # noqa: E402
import recordings_api_test  # noqa: E402
from http_api_test import Contract  # noqa: E402

import pandas  # noqa: E402  (Debian python3-pandas)

TRAINS = 5
PER_TRAIN = 20_000
RATE_HZ = 500


def test_100k(fx, port, sim):
    status, rec = call(port, "POST", "/api/v1/controllers/ext2/recordings", {"name": "100k"})
    check(status == 201, f"start: {status} {rec}")
    rid = rec["id"]
    positions = []
    for t in range(TRAINS):
        x = 1000.0 * (t + 1)
        move_x(port, x)
        positions.append(x)
        edges = json.loads(sim.control("state"))["ttl_edges"]
        check(sim.control(f"pulse {PER_TRAIN} {RATE_HZ}") == "ok", "pulse")
        wait_until(f"train {t + 1} of {TRAINS}",
                   lambda: json.loads(sim.control("state"))["ttl_edges"] - edges >= PER_TRAIN,
                   timeout=PER_TRAIN / RATE_HZ * 3 + 60)  # real seconds: enough at any scale

        seen = {}

        def stored():
            _, body = call(port, "GET", f"/api/v1/recordings/{rid}", token=TOKENS["viewer"])
            seen.update(frames=body["frames"], losses=body["losses"])
            return body if body["frames"] >= (t + 1) * PER_TRAIN else None
        try:
            wait_until(f"{(t + 1) * PER_TRAIN} frames stored", stored)
        except Failure as e:
            raise Failure(f"{e}; the recording had {seen}, the simulator {sim.control('state')}") from e
    status, done = call(port, "POST", f"/api/v1/recordings/{rid}/stop")
    total = TRAINS * PER_TRAIN
    check(done["frames"] == total and done["losses"] == 0, f"every frame, none lost: {done}")

    before_kb = vm_kib(fx.gateway.pid, "VmRSS")
    _, text = download(port, rid, "csv")
    _, lines = download(port, rid, "jsonl")
    grown_mb = (vm_kib(fx.gateway.pid, "VmRSS") - before_kb) / 1024
    print(f"    downloads of {len(text) / 1e6:.1f} MB CSV and {len(lines) / 1e6:.1f} MB JSON Lines: "
          f"resident memory grew {grown_mb:.1f} MB")
    check(grown_mb < 8, f"the downloads grew the gateway by {grown_mb:.1f} MB: not streamed")
    frame = pandas.read_csv(io.StringIO(text))
    check(list(frame["index"]) == list(range(total)), "index 0..99,999 in order")
    check(frame["loss"].isna().all(), "no loss marker")
    for t, x in enumerate(positions):
        part = frame["X_um"][t * PER_TRAIN:(t + 1) * PER_TRAIN]
        check(((part - x).abs() < 0.5).all(), f"train {t + 1} at X={x}: {part.unique()[:5]}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    ap.add_argument("--sim", required=True)
    ap.add_argument("--openapi", required=True)
    ap.add_argument("--time-scale", type=float, default=4)
    args = ap.parse_args()
    with open(args.openapi) as f:
        recordings_api_test.CONTRACT = Contract(f.read())

    fx = Fixture("gw-recording-100k-")
    try:
        sim = fx.start_sim(args.sim, "ext2", "full", time_scale=args.time_scale, report=True)
        port = free_port()
        config = {
            "http": {"listen_address": "127.0.0.1", "port": port},
            "controllers": [{"id": "ext2", "port": sim.link, "report_port": sim.report_link, "baud": 115200}],
            "auth": auth_tokens(),
            "logging": {"level": "info"},
        }
        fx.start_gateway(args.gateway, config)
        fx.run("100,000 triggers at 500 Hz: frames 0..99,999, none lost, at the stage's positions", test_100k,
               fx, port, sim)
        return fx.stop_and_report()
    finally:
        fx.cleanup()


if __name__ == "__main__":
    run_main(main)
