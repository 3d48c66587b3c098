#!/usr/bin/python3
"""Third-party MS-2000 drivers, unmodified, through the gateway's shared ports (issue 32): the runners
of tests/integration/share/third_party/ (python-microscope, navigate, asitiger, mesoSPIM, and
storm-control when a checkout is given in $STORM_CONTROL_SRC) drive one external ms2000-sim through
the gateway's shared pty, then through its RFC 2217 TCP port, while REST clients read the controller
all along and the gateway polls it. Every driver step must pass; afterwards the gateway still has the
controller connected, and its positions agree with the simulator's.

The drivers come from PyPI into a virtual environment (third_party/setup-venv, hashed lock); without
a reachable package index and no environment yet, the test is skipped (exit 77). navigate is left out
of the RFC 2217 run: pyserial's rfc2217 client refuses the write_timeout navigate sets (a limit of the
client, not of the port; third_party/README.md). WHERE answers without decimals (the simulator's
--where-decimals 0), because mesoSPIM reads positions with int().

Run by ctest with Debian's /usr/bin/python3.
"""

import argparse
import os
import subprocess
import sys
import threading

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "api"))
from gateway_fixture import Failure, Fixture, check, free_port, http_request, run_main, wait_until  # noqa: E402

THIRD_PARTY = os.path.join(HERE, "third_party")
SKIPPED = 77


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    ap.add_argument("--sim", required=True)
    ap.add_argument("--venv", required=True, help="where the drivers' virtual environment is made (reused)")
    args = ap.parse_args()
    setup = subprocess.run([os.path.join(THIRD_PARTY, "setup-venv"), args.venv])
    if setup.returncode == SKIPPED:
        print("skipped: the package index cannot be reached and the drivers are not installed")
        return SKIPPED
    check(setup.returncode == 0, f"setup-venv failed ({setup.returncode})")
    python = os.path.join(args.venv, "bin", "python")

    fx = Fixture("share-drivers-")
    try:
        link = os.path.join(fx.tmp, "ext", "port")
        control = os.path.join(fx.tmp, "ext.control.sock")
        fx.procs.append(subprocess.Popen([args.sim, "--preset", "full", "--name", "ext", "--link", link,
                                          "--no-report-port", "--where-decimals", "0", "--control", control],
                                         stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT))
        wait_until("ms2000-sim", lambda: os.path.exists(link) and os.path.exists(control))
        http_port, tcp = free_port(), free_port()
        pty = os.path.join(fx.tmp, "ext-share")
        fx.start_gateway(args.gateway, {
            "http": {"port": http_port}, "simulate": {"count": 0},
            "controllers": [{"id": "ext", "port": link, "baud": 115200,
                             "share": {"pty": pty, "tcp": f"127.0.0.1:{tcp}"}}]})
        wait_until("ext connected", lambda: '"state":"connected"' in http_request(
            http_port, "GET", "/api/v1/controllers/ext", token=None)[1].replace(" ", ""))

        # REST readers all along: the gateway serves them while the drivers use the shared ports.
        stop, errors, reads = threading.Event(), [], [0]

        def reader():
            while not stop.is_set():
                status, _ = http_request(http_port, "GET", "/api/v1/controllers/ext", token=None)
                if status != 200:
                    errors.append(status)
                reads[0] += 1

        t = threading.Thread(target=reader)
        t.start()
        try:
            runs = [["--port", pty],
                    ["--port", f"rfc2217://127.0.0.1:{tcp}", "--only", "asitiger", "microscope", "mesospim", "storm"]]
            for extra in runs:
                done = subprocess.run([python, os.path.join(THIRD_PARTY, "run_all.py"), *extra], timeout=1200)
                fx.run(f"third-party drivers through {extra[1]}", check, done.returncode == 0,
                       f"run_all.py {' '.join(extra)} exited {done.returncode}")
        finally:
            stop.set()
            t.join()
        fx.run("REST answered all along", check, not errors and reads[0] > 0, f"{reads[0]} reads, errors {errors[:5]}")
        status, body = http_request(http_port, "GET", "/api/v1/controllers/ext", token=None)
        fx.run("the controller is still connected", check, status == 200 and '"connected"' in body, body[:300])
        fx.finish_log(60)
        return fx.report()
    finally:
        fx.cleanup()


if __name__ == "__main__":
    run_main(main)
