"""The real asi-gateway for the tests: an external ms2000-sim with a control socket (to make a
command fail or unplug the port) plus simulated controllers in the gateway, on a free loopback
port, with a config file holding one token per role. Like tests/integration/api/gateway_fixture.py,
written again here because this package's tests run in their own virtual environment."""

from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import tempfile
import time
import urllib.error
import urllib.request
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

TOKENS = {
    "viewer": "viewer-token-0123456789",
    "operator": "operator-token-0123456789",
    "admin": "admin-token-0123456789abc",
}
STARTUP_S = 90.0  # generous: a loaded 2-core machine


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


def wait_until(what: str, check: Callable[[], bool], timeout_s: float = STARTUP_S) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if check():
            return
        time.sleep(0.1)
    raise TimeoutError(f"timed out waiting for {what}")


@dataclass
class Sim:
    """An ms2000-sim process and its control socket."""

    name: str
    link: str
    control_path: str
    report_link: str | None = None  # its report port (TTL_REPORT frames), when it has one

    def pulse(self, n: int, rate_hz: float) -> None:
        """`n` trigger edges on IN0 at `rate_hz`, waited for to the last one (each is a report
        frame when the input is armed)."""
        edges = json.loads(self.control("state"))["ttl_edges"]
        if self.control(f"pulse {n} {rate_hz}") != "ok":
            raise RuntimeError(f"{self.name}: pulse refused")
        wait_until(f"{n} edges", lambda: json.loads(self.control("state"))["ttl_edges"] - edges >= n, 60)

    def control(self, line: str) -> str:
        with socket.socket(socket.AF_UNIX) as s:
            s.settimeout(30)
            s.connect(self.control_path)
            s.sendall(line.encode() + b"\n")
            data = b""
            while not data.endswith(b"\n"):
                chunk = s.recv(4096)
                if not chunk:
                    break
                data += chunk
        return data.decode().strip()


@dataclass
class RunningGateway:
    url: str
    port: int
    tmp: Path
    log_path: Path
    ext: Sim  # "ext1", a plain XYZ controller behind a control socket
    cam: Sim  # "cam1", STD_XYZ_SCAN with a report port: its pulses are recorded frames
    tokens: dict[str, str] = field(default_factory=lambda: dict(TOKENS))

    def log_tail(self, lines: int = 60) -> str:
        return "".join(self.log_path.read_text(errors="replace").splitlines(True)[-lines:])


class GatewayProcesses:
    """Starts and stops the simulator and the gateway; `start()` returns the running gateway."""

    def __init__(self, gateway_bin: str, sim_bin: str) -> None:
        self.gateway_bin = gateway_bin
        self.sim_bin = sim_bin
        self.tmp = Path(tempfile.mkdtemp(prefix="asi-gateway-pyclient-"))
        self.procs: list[subprocess.Popen[bytes]] = []

    def start_sim(self, name: str, preset: str, report: bool = False) -> Sim:
        link = str(self.tmp / name / "port")
        report_link = str(self.tmp / name / "report") if report else None
        control = str(self.tmp / f"{name}.control.sock")
        cmd = [self.sim_bin, "--preset", preset, "--name", name, "--link", link]
        cmd += ["--report-link", report_link] if report_link else ["--no-report-port"]
        cmd += ["--control", control]
        self.procs.append(subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT))
        paths = [p for p in (link, report_link, control) if p]
        wait_until(f"ms2000-sim {name}", lambda: all(os.path.exists(p) for p in paths))
        return Sim(name, link, control, report_link)

    def start(self) -> RunningGateway:
        ext = self.start_sim("ext1", "plain")
        cam = self.start_sim("cam1", "full", report=True)
        port = free_port()
        config = {
            "http": {"listen_address": "127.0.0.1", "port": port},
            "controllers": [
                {"id": "ext1", "port": ext.link, "baud": 115200},
                {"id": "cam1", "port": cam.link, "report_port": cam.report_link, "baud": 115200},
            ],
            # sim1: STD_XYZ_SCAN (ARRAY module), sim2: STD_XYZ (plain); real time.
            "simulate": {"count": 2, "time_scale": 1, "directory": str(self.tmp / "sim")},
            "storage": {"path": str(self.tmp / "store")},
            "auth": {"tokens": [{"name": f"{role}1", "token": tok, "role": role} for role, tok in TOKENS.items()]},
            "logging": {"level": "info"},
        }
        config_path = self.tmp / "gateway.json"
        config_path.write_text(json.dumps(config))
        log_path = self.tmp / "gateway.log"
        with open(log_path, "ab") as log:
            proc = subprocess.Popen([self.gateway_bin, "--config", str(config_path)], stdout=log, stderr=log)
        self.procs.append(proc)
        url = f"http://127.0.0.1:{port}"

        def ready() -> bool:
            if proc.poll() is not None:
                raise RuntimeError(f"the gateway exited with {proc.returncode}:\n{log_path.read_text()[-2000:]}")
            try:
                with urllib.request.urlopen(url + "/api/v1/ready", timeout=5) as r:
                    return bool(r.status == 200)
            except (urllib.error.URLError, OSError):
                return False

        wait_until("the gateway to be ready", ready)
        return RunningGateway(url=url, port=port, tmp=self.tmp, log_path=log_path, ext=ext, cam=cam)

    def stop(self) -> None:
        for p in reversed(self.procs):
            if p.poll() is None:
                p.terminate()
                try:
                    p.wait(timeout=20)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait()
        shutil.rmtree(self.tmp, ignore_errors=True)
