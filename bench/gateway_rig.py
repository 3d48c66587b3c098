"""What the benchmarks that drive a real asi-gateway share (standard library only).

A free loopback port, polling until a condition holds, one keep-alive HTTP connection, a stdlib
WebSocket client subscribed to a topic filter, starting the gateway from a config file and stopping
processes, a process's CPU time and resident memory, and the run's metadata (load average, commit). Imported by job_rss.py and store_latency.py,
which are run as `/usr/bin/python3 bench/NAME.py` (so bench/ is on sys.path).
"""

import base64
import http.client
import json
import os
import socket
import struct
import subprocess
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
TERMINAL = {"succeeded", "failed", "cancelled", "interrupted"}


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_until(what, fn, timeout=60.0):
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
    raise RuntimeError(f"timed out waiting for {what} (last: {last!r})")


class Http:
    """One keep-alive connection (one per thread)."""

    def __init__(self, port, timeout=60):
        self.port = port
        self.timeout = timeout
        self.conn = None

    def request(self, method, path, body=None, token=None):
        for attempt in range(3):
            try:
                if self.conn is None:
                    self.conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=self.timeout)
                headers = {"Content-Type": "application/json"} if body is not None else {}
                if token:
                    headers["Authorization"] = f"Bearer {token}"
                self.conn.request(method, path, body=None if body is None else json.dumps(body), headers=headers)
                r = self.conn.getresponse()
                return r.status, r.read().decode()
            except (OSError, http.client.HTTPException):
                if self.conn:
                    self.conn.close()
                self.conn = None
                if attempt == 2:
                    raise
                time.sleep(0.2)


class WsClient(threading.Thread):
    """A stdlib WebSocket client subscribed to `topic_filter`; the thread reads every message until the
    connection closes and hands each data frame to on_message(payload, monotonic receive time)."""

    def __init__(self, port, topic_filter):
        super().__init__(daemon=True)
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=60)
        key = base64.b64encode(os.urandom(16)).decode()
        self.sock.sendall((f"GET /api/v1/ws HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
                           f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n")
                          .encode())
        data = b""
        while b"\r\n\r\n" not in data:
            chunk = self.sock.recv(4096)
            if not chunk:
                raise RuntimeError("WebSocket upgrade: connection closed")
            data += chunk
        head, self.buf = data.split(b"\r\n\r\n", 1)
        if b" 101 " not in head.split(b"\r\n")[0]:
            raise RuntimeError(f"WebSocket upgrade refused: {head[:200]!r}")
        self.error = None
        self.send({"op": "subscribe", "id": 1, "topics": [topic_filter]})

    def send(self, obj):
        payload = json.dumps(obj).encode()
        mask = os.urandom(4)
        n = len(payload)
        header = bytes([0x81]) + (bytes([0x80 | n]) if n < 126 else bytes([0x80 | 126]) + struct.pack("!H", n))
        self.sock.sendall(header + mask + bytes(b ^ mask[i % 4] for i, b in enumerate(payload)))

    def _read(self, n):
        while len(self.buf) < n:
            chunk = self.sock.recv(65536)
            if not chunk:
                raise EOFError("closed")
            self.buf += chunk
        out, self.buf = self.buf[:n], self.buf[n:]
        return out

    def on_message(self, payload, received):
        """Called on the reader thread for every data frame."""

    def run(self):
        self.sock.settimeout(None)
        try:
            while True:
                b0, b1 = self._read(2)
                n = b1 & 0x7F
                if n == 126:
                    n = struct.unpack("!H", self._read(2))[0]
                elif n == 127:
                    n = struct.unpack("!Q", self._read(8))[0]
                payload = self._read(n)
                now = time.monotonic()
                op = b0 & 0x0F
                if op == 0x8:
                    self.error = f"closed by the gateway: {payload[2:].decode(errors='replace')}"
                    return
                if op == 0x9:  # ping: pong with the same payload (masked, as a client must)
                    mask = os.urandom(4)
                    self.sock.sendall(bytes([0x8A, 0x80 | len(payload)]) + mask +
                                      bytes(b ^ mask[i % 4] for i, b in enumerate(payload)))
                    continue
                self.on_message(payload, now)
        except (OSError, EOFError) as e:
            if self.error is None:
                self.error = str(e)


TICKS = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid):
    """User + system CPU time of a process (its threads included)."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICKS


def rss_mib(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return 0.0


def log_tail(tmp, n=30):
    """The last `n` lines of the gateway's log in the scratch directory `tmp`."""
    try:
        with open(os.path.join(tmp, "gateway.log")) as f:
            return "".join(f.readlines()[-n:])
    except OSError:
        return ""


def start_gateway(cmd, config, tmp, port, extra_args=()):
    """Writes `config` to tmp/gateway.json, runs [*cmd, "--config", that file, *extra_args] (cmd ends with
    the binary, after any wrapper) with its output in tmp/gateway.log and waits until GET /api/v1/ready
    answers 200. Returns the Popen."""
    cfg = os.path.join(tmp, "gateway.json")
    with open(cfg, "w") as f:
        json.dump(config, f)
    log = open(os.path.join(tmp, "gateway.log"), "w")
    proc = subprocess.Popen([*cmd, "--config", cfg, *extra_args], stdout=log, stderr=subprocess.STDOUT)
    log.close()

    def ready():
        if proc.poll() is not None:
            raise RuntimeError("the gateway exited at start-up:\n" + log_tail(tmp))
        return Http(port).request("GET", "/api/v1/ready")[0] == 200
    try:
        wait_until("gateway ready", ready)
    except Exception:
        stop_process(proc)
        raise
    return proc


def stop_process(p, timeout=20):
    """SIGTERM, then SIGKILL after `timeout` s."""
    if p and p.poll() is None:
        p.terminate()
        try:
            p.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


def load_average(decimals=2):
    try:
        return " ".join(f"{x:.{decimals}f}" for x in os.getloadavg())
    except OSError:
        return "?"


def git_commit():
    try:
        return subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                              check=False).stdout.strip()
    except OSError:
        return ""
