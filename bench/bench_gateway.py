"""The real asi-gateway for the benchmarks: started with a config file, driven over HTTP, stopped.
Standard library only (Debian's /usr/bin/python3)."""

import datetime
import http.client
import json
import os
import socket
import subprocess
import time


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def parse_time(text):
    """An RFC 3339 timestamp of the API as seconds since the epoch (None stays None)."""
    return datetime.datetime.fromisoformat(text.replace("Z", "+00:00")).timestamp() if text else None


class Gateway:
    def __init__(self, binary, workdir, config, tls=None):
        """Starts `binary` with `config` (its http address and port, storage and logging are filled in) in
        `workdir`. `tls`: the ssl.SSLContext its requests use when the config has http.tls."""
        self.tls = tls
        self.port = free_port()
        config = dict(config)
        config["http"] = {**config.get("http", {}), "listen_address": "127.0.0.1", "port": self.port}
        config.setdefault("storage", {"path": os.path.join(workdir, "data")})
        config.setdefault("logging", {"level": "warn"})
        cfg = os.path.join(workdir, "gateway.json")
        with open(cfg, "w") as f:
            json.dump(config, f)
        self.log_path = os.path.join(workdir, "gateway.log")
        self.log = open(self.log_path, "w")
        self.proc = subprocess.Popen([binary, "--config", cfg], stdout=self.log, stderr=subprocess.STDOUT)

    def request(self, method, path, body=None, timeout=60):
        if self.tls:
            conn = http.client.HTTPSConnection("127.0.0.1", self.port, timeout=timeout, context=self.tls)
        else:
            conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=timeout)
        data = json.dumps(body) if body is not None else None
        conn.request(method, path, body=data, headers={"Content-Type": "application/json"} if data else {})
        r = conn.getresponse()
        text = r.read().decode()
        conn.close()
        try:
            return r.status, json.loads(text) if text else None
        except ValueError:
            return r.status, text

    def wait_ready(self, timeout=90):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"the gateway exited with {self.proc.returncode}; see {self.log_path}")
            try:
                if self.request("GET", "/api/v1/ready", timeout=5)[0] == 200:
                    return
            except (OSError, http.client.HTTPException):
                pass
            time.sleep(0.2)
        raise RuntimeError("the gateway did not become ready")

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.log.close()
