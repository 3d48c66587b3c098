#!/usr/bin/python3
"""End-to-end test of restart recovery under kill -9 loops: the real asi-gateway and an external
ms2000-sim (planar build: ARRAY and RING BUFFER modules, host-driven scans) with its control socket,
a temporary job store.

Each cycle a job changes a controller setting (a firmware array sets TTL IN0 to ARRAY mode 7, a
ring-buffer tour to 1, a host scan sets the fast axis's SPEED), the gateway is killed with SIGKILL
mid-job and started again; its recovery must bring the simulator back to the settings it had before
the first job. The gateway's new drivers identify the controller while it still has the crashed
run's settings, so a value to restore taken from their snapshot would be the crashed run's (issue 12,
point 3). The settings are read from the simulator itself (control socket `state`), after every
recovery.

Run by ctest with Debian's /usr/bin/python3; standard library only. Exit code 0 when every check
passed.
"""

import argparse
import json
import os
import sys
import time

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gateway_fixture import WAIT, Failure, Fixture, auth_tokens, check, free_port, http_request, wait_until  # noqa: E402

TIME_SCALE = 5

JOBS = [
    ("array", {"grid": {"columns": 4, "rows": 3, "column_step_mm": 4, "row_step_mm": 4}, "a1": {"X": 0, "Y": 0}},
     lambda st: st["ttl"]["in0_mode"] == 7, "IN0 in ARRAY mode (7)"),
    ("ring_buffer", {"positions": [{"X": 500, "Y": 0}, {"X": 1000, "Y": 500}], "trigger": "ttl"},
     lambda st: st["ttl"]["in0_mode"] == 1, "IN0 stepping the ring buffer (1)"),
    ("scan", {"fast": {"start_mm": 0, "stop_mm": 0.2, "encoder_divide": 24},
              "slow": {"start_mm": 0, "stop_mm": 0.2, "lines": 3}, "speed_mm_s": 0.1},
     lambda st: abs(st["axes"]["X"]["speed"] - 0.1) < 1e-6, "the scan speed on X (0.1 mm/s)"),
]


def settings(sim):
    st = json.loads(sim.control("state"))
    return st["ttl"]["in0_mode"], st["ttl"]["out0_mode"], st["axes"]["X"]["speed"]


def wait_quiet(sim):
    """The simulator has not been busy for 0.3 s (a crashed run's last move has ended)."""
    still = [0]

    def quiet():
        busy = json.loads(sim.control("state"))["busy"]
        still[0] = 0 if busy else still[0] + 1
        return still[0] >= 3

    wait_until("the simulator idle", quiet)


def get_job(port, job_id):
    status, text = http_request(port, "GET", f"/api/v1/jobs/{job_id}")
    check(status == 200, f"GET job {job_id}: {status} {text[:300]}")
    return json.loads(text)


def test_kill_loop(fx, sim, args, config, cycles):
    port = config["http"]["port"]
    before = settings(sim)
    check(before[0] == 0, f"IN0 starts at mode {before[0]}")
    for cycle in range(1, cycles + 1):
        type_, spec, changed, what = JOBS[(cycle - 1) % len(JOBS)]
        status, text = http_request(port, "POST", "/api/v1/jobs", {"controller": "ext1", "type": type_, "spec": spec})
        check(status == 201, f"cycle {cycle}: submit {type_}: {status} {text[:300]}")
        job = json.loads(text)
        if type_ != "scan":
            check(job["path"] == "firmware", f"cycle {cycle}: {type_} runs {job['path']}")
        wait_until(f"cycle {cycle}: {what}", lambda: changed(json.loads(sim.control("state"))))

        fx.gateway.kill()  # SIGKILL: no shutdown path runs
        fx.gateway.wait(timeout=WAIT)
        fx.start_gateway(args.gateway, config)
        wait_until(f"cycle {cycle}: the job interrupted", lambda: get_job(port, job["id"])["state"] == "interrupted")
        try:
            wait_until(f"cycle {cycle}: the settings from before the first job",
                       lambda: (lambda s: s[0] == before[0] and s[1] == before[1] and abs(s[2] - before[2]) < 1e-3)(
                           settings(sim)), timeout=15)
        except Failure:
            raise Failure(f"cycle {cycle} ({type_}): IN0, OUT0, SPEED X are {settings(sim)} after the recovery, "
                          f"{before} before the first job")
        wait_quiet(sim)
    check(settings(sim) == before, f"after {cycles} crashes: {settings(sim)}, before the first job: {before}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    ap.add_argument("--sim", required=True)
    ap.add_argument("--cycles", type=int, default=20)
    args = ap.parse_args()
    fx = Fixture("gw-recovery-")
    try:
        sim = fx.start_sim(args.sim, "ext1", "planar", time_scale=TIME_SCALE)
        config = {
            "http": {"listen_address": "127.0.0.1", "port": free_port()},
            "controllers": [{"id": "ext1", "port": sim.link, "baud": 115200, "poll_ms": 50,
                             "command_timeout_ms": 2000}],
            "auth": auth_tokens(),
            "logging": {"level": "info"},
        }
        fx.start_gateway(args.gateway, config)
        fx.run(f"{args.cycles} kill -9 in a row end with the settings from before the first job", test_kill_loop,
               fx, sim, args, config, args.cycles)
        fx.gateway.terminate()
        fx.expect_exit_0()
        fx.finish_log(80)
    finally:
        fx.cleanup()
    return fx.report()


if __name__ == "__main__":
    started = time.monotonic()
    code = main()
    print(f"({time.monotonic() - started:.1f} s)")
    sys.exit(code)
