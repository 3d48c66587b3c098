"""A controller that cannot be reached says so (issue 13, "Real controllers"): the real asi-gateway with
MQTT on a real mosquitto and four real-controller entries that cannot work: a path that does not exist,
a silent pty, a pty that answers garbage, and (as a user who may not open it) a mode-000 node. Each
must show state "unreachable" (never "stopped"), a last_error naming the path with the errno text and
the hint a person can act on, the time of the last attempt and of the next retry, over REST and in the
retained MQTT state (validated against openapi/asyncapi.yaml), and a log line that names the path and
is not repeated on every attempt. Then the missing port appears (ms2000-sim makes it) and the
controller connects.

Root opens a mode-000 node anyway, so as root the permission case runs a second gateway as "nobody"
(setpriv); it is skipped, with the reason printed, only when that is impossible.

Run by ctest (unreachable); by hand:
  /usr/bin/python3 tests/integration/ports/unreachable_test.py --gateway build/gateway/asi-gateway \
      --sim build/devices/sim/ms2000-sim --asyncapi openapi/asyncapi.yaml
"""

import argparse
import datetime
import json
import os
import shutil
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "api"))
sys.path.insert(0, os.path.join(HERE, "..", "..", "support"))
from fake_ports import garbage_port, silent_port  # noqa: E402
from gateway_fixture import Failure, Fixture, check, free_port, http_request, wait_until  # noqa: E402
from mqtt_api_test import Broker, Client, Contract, Gateway, payload_json  # noqa: E402

NOBODY = 65534


def parse_time(text):
    return datetime.datetime.strptime(text, "%Y-%m-%dT%H:%M:%S.%fZ")


def state_of(gw, cid):
    status, body = http_request(gw.port, "GET", f"/api/v1/controllers/{cid}")
    check(status == 200, f"GET {cid}: {status} {body}")
    return json.loads(body)


def unreachable_with(gw, cid, name):
    # Between two attempts (next_retry is null while one is under way).
    def pred():
        s = state_of(gw, cid)
        e = s["last_error"]
        return s if s["state"] == "unreachable" and e and e["name"] == name and s["next_retry"] else None
    return wait_until(f"{cid} unreachable ({name}) between attempts", pred, timeout=40)


def check_times(s):
    check(s["updated"] > "2000", f"updated {s['updated']}")
    check(s["last_attempt"] and s["next_retry"], f"times: {s}")
    check(parse_time(s["next_retry"]) > parse_time(s["last_attempt"]), f"next retry before the last attempt: {s}")


def test_missing(gw, missing):
    s = unreachable_with(gw, "missing", "port_not_found")
    e = s["last_error"]
    check(missing in e["text"] and "No such file or directory" in e["text"], f"text: {e}")
    check("/dev/serial/by-id" in e["hint"] and "unplugged" in e["hint"], f"hint: {e}")
    check_times(s)


def test_silent(gw, silent):
    s = unreachable_with(gw, "silent", "no_reply")
    e = s["last_error"]
    check(silent.link in e["text"] and "9600 baud" in e["text"], f"text: {e}")
    check("DIP switches 4 and 5" in e["hint"], f"hint: {e}")
    check_times(s)
    # It was asked only the harmless V (the resynchronisation probe), never a move.
    check(set(bytes(silent.received).split(b"\r")) <= {b"", b"V"}, f"sent {bytes(silent.received)[:80]!r}")


def test_garbage(gw, garbage):
    s = unreachable_with(gw, "garbage", "not_ms2000")
    e = s["last_error"]
    check(garbage.link in e["text"] and "\\x8F" in e["text"], f"text: {e}")
    check("another device" in e["hint"] and "DIP switches 4 and 5" in e["hint"], f"hint: {e}")
    check_times(s)


def test_mqtt_state(gw, broker, contract):
    late = Client(broker.port, f"late-{time.monotonic_ns()}")
    try:
        late.subscribe(gw.topic("controllers", "+", "state"))
        for cid, name in (("missing", "port_not_found"), ("silent", "no_reply"), ("garbage", "not_ms2000")):
            topic = gw.topic("controllers", cid, "state")

            def retained_state(t, payload, retained, props, topic=topic):
                return t == topic and retained
            _, p, _, _ = late.wait_for(f"retained state of {cid}", retained_state, timeout=20)
            contract.validate(topic, p)
            d = payload_json(p)["data"]
            check(d["state"] == "unreachable" and d["last_error"]["name"] == name and d["last_error"]["hint"],
                  f"retained MQTT state of {cid}: {d}")

            # And between two attempts, when the next one is due.
            def waiting(t, payload, retained, props, topic=topic):
                return t == topic and payload_json(payload)["data"]["next_retry"] is not None
            _, p, _, _ = late.wait_for(f"{cid} state with next_retry", waiting, timeout=30)
            contract.validate(topic, p)
    finally:
        late.close()


def test_log(gw, missing):
    # Several attempts have failed the same way by now; the reason is logged once (then once a minute).
    first = state_of(gw, "missing")["last_attempt"]
    wait_until("two more attempts on the missing port",
               lambda: parse_time(state_of(gw, "missing")["last_attempt"]) >
               parse_time(first) + datetime.timedelta(seconds=4), timeout=30)
    with open(gw.log_path) as f:
        lines = [line for line in f if "missing: unreachable: " in line]
    check(len(lines) == 1, f"{len(lines)} log lines for the missing port: {lines[:3]}")
    line = lines[0]
    check(missing in line and "No such file or directory" in line and "hint:" in line and "by-id" in line,
          f"log line: {line}")
    with open(gw.log_path) as f:
        text = f.read()
    check("garbage: unreachable: " in text and "silent: unreachable: " in text, "no log line for the ptys")


def test_plugged_later(fx, gw, sim, missing):
    proc = subprocess.Popen([sim, "--preset", "plain", "--name", "late", "--link", missing, "--no-report-port"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)
    fx.procs.append(proc)
    s = wait_until("the plugged-in controller connected",
                   lambda: (lambda s: s if s["state"] == "connected" else None)(state_of(gw, "missing")), timeout=40)
    check(s["next_retry"] is None and s["identity"], f"connected: {s}")


def test_permission_denied(fx, binary):
    denied_dir = os.path.join(fx.tmp, "shared")
    os.makedirs(denied_dir, exist_ok=True)
    node = os.path.join(denied_dir, "denied-port")
    with open(node, "w"):
        pass
    os.chmod(node, 0)
    as_user = None
    if os.geteuid() == 0:
        if not shutil.which("setpriv"):
            print("  (skipped: running as root, where mode 000 does not deny, and no setpriv to become nobody)")
            return
        as_user = NOBODY
        os.chmod(fx.tmp, 0o711)
        os.chmod(denied_dir, 0o777)
    port = free_port()
    config = {"http": {"listen_address": "127.0.0.1", "port": port},
              "storage": {"path": os.path.join(denied_dir, "store")},
              "controllers": [{"id": "denied", "port": node, "baud": 9600}], "logging": {"level": "info"}}
    cfg = os.path.join(denied_dir, "denied.json")
    with open(cfg, "w") as f:
        json.dump(config, f)
    os.chmod(cfg, 0o644)
    cmd = [binary, "--config", cfg]
    if as_user is not None:
        cmd = ["setpriv", f"--reuid={as_user}", f"--regid={as_user}", "--clear-groups", *cmd]
    log_path = os.path.join(fx.tmp, "denied.log")
    with open(log_path, "w") as log:
        proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT)
    fx.procs.append(proc)
    try:
        def denied():
            if proc.poll() is not None:
                with open(log_path) as f:
                    raise Failure(f"gateway exited {proc.returncode}: {f.read()[-1500:]}")
            status, body = http_request(port, "GET", "/api/v1/controllers/denied", token=None)
            s = json.loads(body) if status == 200 else {}
            return s if s.get("state") == "unreachable" and s["last_error"]["name"] == "permission_denied" else None
        s = wait_until("denied unreachable (permission_denied)", denied, timeout=30)
        e = s["last_error"]
        check(node in e["text"] and "Permission denied" in e["text"] and "dialout" in e["hint"], f"denied: {e}")
        with open(log_path) as f:
            check("Permission denied" in f.read(), "no log line for the denied port")
    finally:
        proc.terminate()
        proc.wait(timeout=30)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    ap.add_argument("--sim", required=True)
    ap.add_argument("--asyncapi", required=True)
    args = ap.parse_args()
    fx = Fixture("asi-unreachable-")
    contract = Contract(args.asyncapi)
    gw = None
    fakes = []
    try:
        broker = Broker(fx, "broker")
        broker.start()
        missing = os.path.join(fx.tmp, "unplugged", "port")
        silent = silent_port(os.path.join(fx.tmp, "silent", "port"))
        garbage = garbage_port(os.path.join(fx.tmp, "garbage", "port"))
        fakes = [silent, garbage]
        gw = Gateway(fx, args.gateway, "gw-u", [f"mqtt://127.0.0.1:{broker.port}"])
        gw.extra = []  # no simulated controllers: only the real-controller entries below
        gw.config["controllers"] = [
            {"id": "missing", "port": missing, "baud": 115200},
            {"id": "silent", "port": silent.link, "baud": 9600, "command_timeout_ms": 200},
            {"id": "garbage", "port": garbage.link, "baud": 9600, "command_timeout_ms": 200},
        ]
        gw.start(wait_ready=False)
        wait_until("gateway health", lambda: http_request(gw.port, "GET", "/api/v1/health", token=None)[0] == 200)
        fx.run("missing path: unreachable, port_not_found, by-id hint", test_missing, gw, missing)
        fx.run("silent pty: unreachable, no_reply, DIP switch hint", test_silent, gw, silent)
        fx.run("garbage pty: unreachable, not_ms2000, sample escaped", test_garbage, gw, garbage)
        fx.run("MQTT retained state says unreachable, with hint", test_mqtt_state, gw, broker, contract)
        fx.run("log names the path, once for repeated attempts", test_log, gw, missing)
        fx.run("the missing port appears: connected", test_plugged_later, fx, gw, args.sim, missing)
        fx.run("permission denied: unreachable, dialout hint", test_permission_denied, fx, args.gateway)
    except Exception as e:  # noqa: BLE001
        fx.failures.append(("setup", e))
        print(f"[FAIL] setup: {e}")
    finally:
        if fx.failures and gw and gw.proc:
            print(f"---- {gw.name} log (tail) ----\n{gw.tail(60)}")
        for f in fakes:
            f.close()
        code = fx.report()
        fx.cleanup()
    return code


if __name__ == "__main__":
    sys.exit(main())
