"""Shared fixture of the end-to-end API tests (http_api_test.py, ws_api_test.py): a scratch
directory, external ms2000-sims with control sockets, the real asi-gateway on a free loopback port
with a config file and a log, waiting for readiness, a plain HTTP helper, and the run/report
harness (every check runs, failures are listed, exit code 0 only when all passed).

Imported by the test scripts with their own directory on sys.path. Standard library only; timeouts
are generous (a loaded 2-core machine); nothing asserts wall-clock speed.
"""

import hashlib
import hmac
import http.client
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import traceback

TOKENS = {
    "viewer": "viewer-token-0123456789",
    "operator": "operator-token-0123456789",
    "admin": "admin-token-0123456789abc",
}
# MQTT command signing keys, one per role, named like the role (mqtt.commands.signing_keys).
SIGNING_KEYS = {
    "viewer": "5f0c8e1a9b3d47e2a6c4f8091d2e3b4c5a6f7e8d9c0b1a2f3e4d5c6b7a8f9e0d",
    "operator": "a1b2c3d4e5f60718293a4b5c6d7e8f90a1b2c3d4e5f60718293a4b5c6d7e8f91",
    "admin": "0f1e2d3c4b5a69788796a5b4c3d2e1f00f1e2d3c4b5a69788796a5b4c3d2e1f2",
}
WAIT = 60.0  # generous: a loaded 2-core machine


class Failure(Exception):
    pass


def check(cond, message):
    if not cond:
        raise Failure(message)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_until(what, fn, timeout=WAIT):
    """Polls fn until it returns something truthy (returned); connection errors count as "not yet"."""
    deadline = time.monotonic() + timeout
    last = None
    while time.monotonic() < deadline:
        try:
            last = fn()
            if last:
                return last
        except (OSError, http.client.HTTPException) as e:
            last = e
        time.sleep(0.1)
    raise Failure(f"timed out waiting for {what} (last: {last!r})")


def vm_kib(pid, field):
    """A process's /proc status field in KiB ("VmRSS", "VmHWM")."""
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith(field + ":"):
                return int(line.split()[1])
    raise AssertionError(f"no {field} in /proc/{pid}/status")


def auth_tokens():
    """The config's auth section: one token per role, named <role>1."""
    return {"tokens": [{"name": role + "1", "token": tok, "role": role} for role, tok in TOKENS.items()]}


def signing_keys_config():
    """mqtt.commands.signing_keys: one key per role, named like the role."""
    return [{"name": role, "role": role, "key": key} for role, key in SIGNING_KEYS.items()]


def signed_command(topic, message, role, ts_ms=None, nonce=None):
    """The payload of a signed MQTT command: `message` (a dict, or its JSON text) signed with the
    role's key (HMAC-SHA256 over topic, ts, nonce and body, one per line)."""
    body = message if isinstance(message, str) else json.dumps(message)
    ts = int(time.time() * 1000) if ts_ms is None else ts_ms
    nonce = nonce or os.urandom(12).hex()
    text = f"{topic}\n{ts}\n{nonce}\n{body}".encode()
    sig = hmac.new(bytes.fromhex(SIGNING_KEYS[role]), text, hashlib.sha256).hexdigest()
    return json.dumps({"key": role, "ts": ts, "nonce": nonce, "sig": sig, "body": body})


def signed_if_token(topic, payload):
    """A command written with a test token ({"token": TOKENS[role], ...}) as the same role's signed
    command, so that the tests read as before; anything else unchanged."""
    if isinstance(payload, dict):
        role = next((r for r, t in TOKENS.items() if payload.get("token") == t), None)
        if role:
            return signed_command(topic, {k: v for k, v in payload.items() if k != "token"}, role)
    return payload


def self_signed_certificate(directory, name="server", host="localhost"):
    """Writes <name>.crt and <name>.key (a new P-256 key, a one-day certificate for `host` and
    127.0.0.1) with Debian's openssl; returns their paths."""
    cert, key = os.path.join(directory, name + ".crt"), os.path.join(directory, name + ".key")
    subprocess.run(["openssl", "req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:P-256", "-nodes",
                    "-keyout", key, "-out", cert, "-days", "1", "-subj", "/CN=" + host,
                    "-addext", f"subjectAltName=DNS:{host},IP:127.0.0.1"],
                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return cert, key


def http_request(port, method, path, body=None, token=TOKENS["admin"], tls=None, headers=None, source=None,
                 host="127.0.0.1"):
    """(status, body text) of one request on its own connection; no Authorization without a token.
    `tls`: an ssl.SSLContext for an HTTPS gateway; `headers`: more request headers; `source`: the
    local address to connect from (another loopback address, as a second machine would)."""
    source_address = (source, 0) if source else None
    if tls:
        conn = http.client.HTTPSConnection(host, port, timeout=WAIT, context=tls, source_address=source_address)
    else:
        conn = http.client.HTTPConnection(host, port, timeout=WAIT, source_address=source_address)
    headers = dict(headers or {})
    if token:
        headers["Authorization"] = f"Bearer {token}"
    data = None
    if body is not None:
        data = json.dumps(body)
        headers["Content-Type"] = "application/json"
    conn.request(method, path, body=data, headers=headers)
    r = conn.getresponse()
    text = r.read().decode()
    conn.close()
    return r.status, text


class Sim:
    """An external ms2000-sim process: its serial link, report link (or None) and control socket."""

    def __init__(self, link, report_link, control_path):
        self.link = link
        self.report_link = report_link
        self.control_path = control_path

    def control(self, line):
        """One control-socket command; its one-line answer."""
        with socket.socket(socket.AF_UNIX) as s:
            s.settimeout(WAIT)
            s.connect(self.control_path)
            s.sendall(line.encode() + b"\n")
            data = b""
            while not data.endswith(b"\n"):
                chunk = s.recv(4096)
                if not chunk:
                    break
                data += chunk
            return data.decode().strip()


class Fixture:
    """The scratch directory, the processes started in it, and the pass/fail record."""

    def __init__(self, prefix):
        self.tmp = tempfile.mkdtemp(prefix=prefix)
        self.procs = []
        self.passed = []
        self.failures = []
        self.gateway = None
        self.log_path = None
        self._log = None

    def run(self, name, fn, *a):
        try:
            fn(*a)
            self.passed.append(name)
            print(f"[ OK ] {name}", flush=True)
        except Exception as e:  # noqa: BLE001 - every failure is reported, then the next test runs
            self.failures.append((name, e))
            print(f"[FAIL] {name}: {e}", flush=True)
            if not isinstance(e, Failure):
                traceback.print_exc()

    def start_sim(self, sim, name, preset, time_scale=None, report=False):
        """Starts ms2000-sim `name` with a control socket (and a report port when `report`)."""
        link = os.path.join(self.tmp, name, "port")
        report_link = os.path.join(self.tmp, name, "report") if report else None
        control_path = os.path.join(self.tmp, name + ".control.sock")
        cmd = [sim, "--preset", preset, "--name", name, "--link", link]
        cmd += ["--report-link", report_link] if report else ["--no-report-port"]
        if time_scale is not None:
            cmd += ["--time-scale", str(time_scale)]
        cmd += ["--control", control_path]
        self.procs.append(subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT))
        paths = [p for p in (link, report_link, control_path) if p]
        wait_until(f"ms2000-sim {name}", lambda: all(os.path.exists(p) for p in paths))
        return Sim(link, report_link, control_path)

    def start_gateway(self, gateway, config, extra_args=(), tls=None):
        """Writes `config`, starts the gateway (with `extra_args` after --config) with its output in a
        log file and waits until /api/v1/ready answers 200 (over HTTPS with the ssl.SSLContext `tls`).
        Returns the process. Called again after the gateway stopped (a restart), the log continues in
        the same file. Its stdin is not a terminal, as for a service (SIGHUP reloads, not stops)."""
        # Every test gateway gets its own job store: one gateway per storage directory (storage lock).
        config = dict(config)
        config.setdefault("storage", {"path": os.path.join(self.tmp, "store")})
        cfg = os.path.join(self.tmp, "gateway.json")
        with open(cfg, "w") as f:
            json.dump(config, f)
        self.log_path = os.path.join(self.tmp, "gateway.log")
        if self._log:
            self._log.close()
        self._log = open(self.log_path, "a")
        self.gateway = subprocess.Popen([gateway, "--config", cfg, *extra_args], stdin=subprocess.DEVNULL,
                                        stdout=self._log, stderr=subprocess.STDOUT)
        self.procs.append(self.gateway)
        port = config["http"]["port"]
        proc = self.gateway

        def ready():
            if proc.poll() is not None:  # exited at start-up: say why instead of waiting
                with open(self.log_path) as log:
                    tail = log.read()[-2000:]
                raise Failure(f"the gateway exited with {proc.returncode} at start-up:\n{tail}")
            return http_request(port, "GET", "/api/v1/ready", token=None, tls=tls)[0] == 200

        wait_until("gateway ready", ready)
        return self.gateway

    def expect_exit_0(self):
        """After a SIGTERM: records "SIGTERM exits 0"."""
        try:
            code = self.gateway.wait(timeout=WAIT)
        except subprocess.TimeoutExpired:
            code = None
        if code == 0:
            self.passed.append("SIGTERM exits 0")
            print("[ OK ] SIGTERM exits 0")
        else:
            self.failures.append(("SIGTERM exits 0", Failure(f"exit code {code}")))
            print(f"[FAIL] SIGTERM exits 0: exit code {code}")

    def finish_log(self, tail_lines):
        """Closes the gateway log; prints its tail when something failed."""
        if self._log:
            self._log.close()
            self._log = None
        if self.failures and self.log_path:
            print("---- gateway log (tail) ----")
            with open(self.log_path) as f:
                print("".join(f.readlines()[-tail_lines:]))

    def cleanup(self):
        if self._log:
            self._log.close()
            self._log = None
        for p in self.procs:
            if p.poll() is None:
                p.kill()
                p.wait()
        if not os.environ.get("GW_KEEP_TMP"):
            shutil.rmtree(self.tmp, ignore_errors=True)

    def stop_and_report(self, tail_lines=60):
        """The end of a test script: SIGTERM to the gateway (recorded as "SIGTERM exits 0"), the log's
        tail when something failed, the summary; the exit code."""
        self.gateway.terminate()
        self.expect_exit_0()
        self.finish_log(tail_lines)
        return self.report()

    def report(self, extra=""):
        """Prints the summary; the exit code."""
        print(f"\n{len(self.passed)} passed, {len(self.failures)} failed{extra}")
        for name, e in self.failures:
            print(f"FAILED: {name}: {e}")
        return 1 if self.failures else 0


def axis_position(port, controller, axis="X"):
    """An axis's position (um) in the controller's polled snapshot (GET /api/v1/controllers/{id})."""
    status, body = http_request(port, "GET", f"/api/v1/controllers/{controller}", token=TOKENS["viewer"])
    check(status == 200, f"GET {controller}: {status} {body}")
    return next(a["position_um"] for a in json.loads(body)["axes"] if a["axis"] == axis)


def run_main(main):
    """A test script's entry point: exits with main()'s code; a Failure while setting up exits 1."""
    try:
        sys.exit(main())
    except Failure as e:
        print(f"setup failed: {e}")
        sys.exit(1)
