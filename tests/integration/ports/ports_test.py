"""Port discovery end to end (issue 13, "Real controllers"): `asi-gateway ports` and GET /api/v1/ports
on real pseudo-terminals: an external ms2000-sim, a pty that answers garbage, one that answers another
device's text, a silent one, a missing path, a regular file, a port another program holds (flock and
TIOCEXCL) and, as a non-root user, a port that user may not open. The printed "controllers" entry is
pasted into a gateway config and must connect; the REST route is admin-only, validates its query,
reports the gateway's own ports in_use, and never blocks the I/O thread (health answers during a scan).

Run by ctest (ports); by hand:
  /usr/bin/python3 tests/integration/ports/ports_test.py --gateway build/gateway/asi-gateway \
      --sim build/devices/sim/ms2000-sim --openapi openapi/openapi.yaml
"""

import argparse
import fcntl
import json
import os
import re
import shutil
import subprocess
import sys
import termios
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "api"))
sys.path.insert(0, os.path.join(HERE, "..", "..", "support"))
from fake_ports import garbage_port, other_device_port, silent_port  # noqa: E402
from gateway_fixture import TOKENS, Fixture, auth_tokens, check, free_port, http_request, wait_until  # noqa: E402

import yaml  # noqa: E402  Debian python3-yaml
import jsonschema  # noqa: E402  Debian python3-jsonschema

ONLY_PROBE_BYTES = re.compile(rb"^(\r|V\r|BU X\r)*$")


def run_ports(gateway, *args, user=None, timeout=60):
    cmd = [gateway, "ports", *args]
    if user is not None:
        cmd = ["setpriv", f"--reuid={user}", f"--regid={user}", "--clear-groups", *cmd]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    return p.returncode, p.stdout, p.stderr


def scan_json(gateway, *paths, extra=()):
    args = ["--only-paths", "--json", *extra]
    for p in paths:
        args += ["--path", p]
    code, out, err = run_ports(gateway, *args)
    check(code in (0, 1), f"ports exited {code}: {err}")
    return code, json.loads(out)


def by_path(scan):
    return {p["path"]: p for p in scan["ports"]}


class Env:
    def __init__(self, fx, gateway, sim):
        self.fx = fx
        self.gateway = gateway
        self.sim = fx.start_sim(sim, "stage", "full")
        self.garbage = garbage_port(os.path.join(fx.tmp, "garbage", "port"))
        self.other = other_device_port(os.path.join(fx.tmp, "modem", "port"))
        self.silent = silent_port(os.path.join(fx.tmp, "silent", "port"))
        self.missing = os.path.join(fx.tmp, "unplugged", "port")
        self.regular = os.path.join(fx.tmp, "notes.txt")
        with open(self.regular, "w") as f:
            f.write("not a serial port\n")

    def close(self):
        for p in (self.garbage, self.other, self.silent):
            p.close()


def test_cli_statuses(env):
    started = time.monotonic()
    code, scan = scan_json(env.gateway, env.sim.link, env.garbage.link, env.other.link, env.silent.link,
                           env.missing, env.regular)
    took = time.monotonic() - started
    ports = by_path(scan)
    check(code == 0, f"exit {code} although an MS-2000 was found")
    sim = ports[env.sim.link]
    check(sim["status"] == "ms2000", f"sim: {sim}")
    check(sim["baud"] == 115200 and sim["version"] == "9.50", f"sim baud/version: {sim}")
    check(sim["build"]["name"] == "STD_XYZ_SCAN" and sim["build"]["motor_axes"] == "XYZ", f"sim build: {sim}")
    check("ring_buffer" in sim["build"]["modules"] and "array" in sim["build"]["modules"], f"modules: {sim}")
    check(sim["device"].startswith("/dev/pts/"), f"sim device {sim['device']}")
    g = ports[env.garbage.link]
    check(g["status"] == "not_ms2000" and "\\x8F" in g["text"] and g["hint"], f"garbage: {g}")
    check("\x8f" not in json.dumps(g, ensure_ascii=False), "controller bytes reach the JSON unescaped")
    o = ports[env.other.link]
    check(o["status"] == "not_ms2000" and "OK" in o["text"], f"other device: {o}")
    s = ports[env.silent.link]
    check(s["status"] == "no_answer" and "DIP switches 4 and 5" in s["hint"], f"silent: {s}")
    for baud in ("115200", "9600", "19200", "28800", "38400", "57600"):
        check(baud in s["text"], f"silent port not tried at {baud}: {s['text']}")
    m = ports[env.missing]
    check(m["status"] == "not_found" and "No such file" in m["text"] and "by-id" in m["hint"], f"missing: {m}")
    r = ports[env.regular]
    check(r["status"] == "not_a_tty", f"regular file: {r}")
    with open(env.regular) as f:
        check(f.read() == "not a serial port\n", "the probe wrote into a regular file")
    check(scan["controllers"] == [{"id": "stage1", "port": env.sim.link, "baud": 115200}],
          f"config entries {scan['controllers']}")
    # Harmless queries only: the non-MS-2000 ports heard nothing but CR, V and never BU X or a move.
    for fake in (env.garbage, env.other, env.silent):
        check(ONLY_PROBE_BYTES.match(bytes(fake.received)) and b"BU" not in fake.received,
              f"{fake.link} received {bytes(fake.received)!r}")
    # In parallel: six ports, the slowest (silent, six rates) bounds the total.
    check(took < 10, f"the scan took {took:.1f} s")


def test_cli_text_and_exit_codes(env):
    code, out, err = run_ports(env.gateway, "--only-paths", "--path", env.sim.link, "--path", env.silent.link)
    check(code == 0, f"exit {code}: {err}")
    entry = '{"id": "stage1", "port": "%s", "baud": 115200}' % env.sim.link
    check(entry in out, f"no config entry in:\n{out}")
    check("MS-2000 at 115200 baud, version 9.50, build STD_XYZ_SCAN, axes XYZ" in out, out)
    check("no answer" in out and "hint:" in out, out)
    code, out, err = run_ports(env.gateway, "--only-paths", "--path", env.silent.link, "--baud", "9600")
    check(code == 1 and "at 9600 baud" in out and "115200" not in out.split("hint:")[0], f"{code}: {out}")
    code, out, err = run_ports(env.gateway, "--only-paths")
    check(code == 2 and "--path" in err, f"--only-paths alone: {code} {err}")
    code, out, err = run_ports(env.gateway, "--baud", "1234", "--path", env.silent.link)
    check(code != 0 and code != 1, f"--baud 1234 accepted: {code}")


def test_busy_ports_left_alone(env):
    # flock, as pyserial's exclusive=True and the gateway itself take it.
    holder = os.open(env.garbage.link, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    try:
        fcntl.flock(holder, fcntl.LOCK_EX | fcntl.LOCK_NB)
        before = len(env.garbage.received)
        _, scan = scan_json(env.gateway, env.garbage.link)
        p = by_path(scan)[env.garbage.link]
        check(p["status"] == "busy" and "flock" in p["text"], f"flocked: {p}")
        check(len(env.garbage.received) == before, "the probe wrote to a locked port")
    finally:
        os.close(holder)
    # Exclusive mode (TIOCEXCL), as minicom and screen set it: root can open it, but must not use it.
    holder = os.open(env.other.link, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    try:
        fcntl.ioctl(holder, termios.TIOCEXCL)
        before = len(env.other.received)
        _, scan = scan_json(env.gateway, env.other.link)
        p = by_path(scan)[env.other.link]
        check(p["status"] == "busy" and "TIOCEXCL" in p["text"], f"exclusive: {p}")
        check(len(env.other.received) == before, "the probe wrote to a port in exclusive mode")
    finally:
        fcntl.ioctl(holder, termios.TIOCNXCL)
        os.close(holder)


def test_permission_denied(env):
    if os.geteuid() != 0:
        path = os.path.join(env.fx.tmp, "denied")
        with open(path, "w"):
            pass
        os.chmod(path, 0)
        code, out, err = run_ports(env.gateway, "--only-paths", "--json", "--path", path)
    else:
        # root opens a mode-000 node anyway: the case is run as "nobody", who may not.
        if not shutil.which("setpriv"):
            print("  (skipped: running as root and no setpriv to become another user)")
            return
        shared = os.path.join(env.fx.tmp, "shared")
        os.makedirs(shared, exist_ok=True)
        os.chmod(env.fx.tmp, 0o711)
        os.chmod(shared, 0o755)
        path = os.path.join(shared, "denied")
        with open(path, "w"):
            pass
        os.chmod(path, 0)
        code, out, err = run_ports(env.gateway, "--only-paths", "--json", "--path", path, user=65534)
    check(code == 1, f"exit {code}: {err}")
    p = by_path(json.loads(out))[path]
    check(p["status"] == "permission_denied" and "Permission denied" in p["text"] and "dialout" in p["hint"],
          f"denied: {p}")


def start_gateway(fx, gateway, controllers):
    port = free_port()
    config = {"http": {"listen_address": "127.0.0.1", "port": port}, "auth": auth_tokens(),
              "storage": {"path": os.path.join(fx.tmp, "store")}, "controllers": controllers,
              "logging": {"level": "info"}}
    cfg = os.path.join(fx.tmp, "gateway.json")
    with open(cfg, "w") as f:
        json.dump(config, f)
    fx.log_path = os.path.join(fx.tmp, "gateway.log")  # its tail is printed when a check failed
    log = open(fx.log_path, "a")
    proc = subprocess.Popen([gateway, "--config", cfg], stdout=log, stderr=subprocess.STDOUT)
    log.close()
    fx.procs.append(proc)
    return proc, port


def controller_state(port, cid):
    status, body = http_request(port, "GET", f"/api/v1/controllers/{cid}")
    check(status == 200, f"GET controller {cid}: {status} {body}")
    return json.loads(body)


def test_pasted_entry_and_rest(env, openapi):
    _, scan = scan_json(env.gateway, env.sim.link)
    entries = scan["controllers"]
    proc, port = start_gateway(env.fx, env.gateway, entries)
    try:
        wait_until("the pasted controller connected",
                   lambda: controller_state(port, "stage1")["state"] == "connected")
        # The gateway holds its port: a second program's probe finds it busy and leaves it alone.
        _, scan = scan_json(env.gateway, env.sim.link)
        p = by_path(scan)[env.sim.link]
        check(p["status"] == "busy", f"the gateway's port from outside: {p}")
        check(controller_state(port, "stage1")["state"] == "connected", "the probe disturbed the gateway")

        # REST: admin only; problem+json errors; the gateway's own port in_use.
        q = f"/api/v1/ports?only_paths=true&path={env.sim.link},{env.silent.link}"
        status, body = http_request(port, "GET", q, token=TOKENS["operator"])
        check(status == 403 and json.loads(body)["type"].endswith("/forbidden"), f"operator: {status} {body}")
        for bad in ("/api/v1/ports?only_paths=true", f"/api/v1/ports?path={env.regular}",
                    "/api/v1/ports?path=relative/port", "/api/v1/ports?colour=red"):
            status, body = http_request(port, "GET", bad)
            check(status in (400, 422) and json.loads(body)["type"].endswith("/invalid-value"),
                  f"{bad}: {status} {body}")

        result = {}

        def scan_rest():
            result["response"] = http_request(port, "GET", q)

        t = threading.Thread(target=scan_rest)
        t.start()
        time.sleep(0.2)
        # While the scan waits for the silent port at every rate, the I/O thread still serves.
        worst = 0.0
        while t.is_alive():
            t0 = time.monotonic()
            status, _ = http_request(port, "GET", "/api/v1/health", token=None)
            worst = max(worst, time.monotonic() - t0)
            check(status == 200, f"health during a scan: {status}")
            time.sleep(0.05)
        t.join()
        check(worst < 0.5, f"health took {worst:.2f} s during a port scan")
        status, body = result["response"]
        check(status == 200, f"GET {q}: {status} {body}")
        scan = json.loads(body)
        ports = by_path(scan)
        check(ports[env.sim.link]["status"] == "in_use" and ports[env.sim.link]["controller"] == "stage1",
              f"own port: {ports[env.sim.link]}")
        check(ports[env.silent.link]["status"] == "no_answer", f"silent over REST: {ports[env.silent.link]}")
        validator = jsonschema.Draft202012Validator({"$ref": "#/components/schemas/PortScan"},
                                                    resolver=jsonschema.RefResolver(base_uri="", referrer=openapi))
        errors = [e.message for e in validator.iter_errors(scan)]
        check(not errors, f"GET /api/v1/ports does not match openapi PortScan: {errors[:3]}")
    finally:
        proc.terminate()
        proc.wait(timeout=30)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    ap.add_argument("--sim", required=True)
    ap.add_argument("--openapi", required=True)
    args = ap.parse_args()
    with open(args.openapi) as f:
        openapi = yaml.safe_load(f)
    fx = Fixture("asi-ports-")
    env = None
    try:
        env = Env(fx, args.gateway, args.sim)
        fx.run("ports: statuses of sim, garbage, other device, silent, missing, regular file", test_cli_statuses, env)
        fx.run("ports: text output, config entry and exit codes", test_cli_text_and_exit_codes, env)
        fx.run("ports: busy ports (flock, TIOCEXCL) are left alone", test_busy_ports_left_alone, env)
        fx.run("ports: permission denied", test_permission_denied, env)
        fx.run("ports: pasted entry connects; GET /api/v1/ports", test_pasted_entry_and_rest, env, openapi)
    except Exception as e:  # noqa: BLE001
        fx.failures.append(("setup", e))
        print(f"[FAIL] setup: {e}")
    finally:
        fx.finish_log(60)
        if env:
            env.close()
        code = fx.report()
        fx.cleanup()
    return code


if __name__ == "__main__":
    sys.exit(main())
