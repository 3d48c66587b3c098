#!/usr/bin/python3
"""Benchmark: the gateway's HTTP against nginx serving the same bytes (issue 16).

Starts the real asi-gateway (one simulated controller, in-process, default polling) and nginx-light
(one worker process) on free loopback ports. nginx serves files holding exactly the bytes the gateway
answered for each path, with the gateway's Content-Type, Cache-Control and X-Request-Id headers (nginx
adds Date, Last-Modified, ETag and Accept-Ranges of its own: a little more header to send). Then wrk
(-t2 -c64, --seconds each) loads each path on each server in interleaved rounds (gateway, nginx,
gateway, nginx ...) so that a change in the machine's load touches both alike. The gateway serves
from its one I/O thread, nginx from its one worker.

Paths: GET /api/v1/controllers/sim1 (the controller's state, about 1 kB) and GET /api/v1/health.
With --tls (issue 34) both serve HTTPS with the same self-signed P-256 certificate (Debian's openssl):
the gateway through http.tls, nginx with `ssl_protocols TLSv1.2 TLSv1.3`; wrk keeps its connections,
so this measures the encrypted requests, not handshakes (the issue's goal: a figure, no ratio set).
It prints one markdown table (median over the rounds of req/s, p50 and p99 latency as wrk reports
them, and the ratio gateway / nginx) and, with --results, appends it to bench/RESULTS.md.
Needs wrk and nginx-light (bench/setup installs them). Standard library only:

  scripts/build && bench/setup && /usr/bin/python3 bench/http_vs_nginx.py [--rounds 5] [--seconds 5] [--tls]
"""

import argparse
import http.client
import os
import re
import shutil
import ssl
import statistics
import subprocess
import sys
import tempfile
import time

sys.dont_write_bytecode = True
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_gateway import Gateway, free_port  # noqa: E402
from bench_machine import publish_section  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PATHS = ["/api/v1/controllers/sim1", "/api/v1/health"]
# Issue 16: req/s at least this share of nginx's, p99 at most 1.2x nginx's.
GOALS = {"/api/v1/controllers/sim1": 0.6, "/api/v1/health": 0.8}
MAX_P99_RATIO = 1.2


def fetch(port, path, tls=None):
    if tls:
        conn = http.client.HTTPSConnection("127.0.0.1", port, timeout=10, context=tls)
    else:
        conn = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    conn.request("GET", path)
    r = conn.getresponse()
    body = r.read()
    headers = dict(r.getheaders())
    conn.close()
    if r.status != 200:
        raise RuntimeError(f"GET {path} answered {r.status}: {body[:200]!r}")
    return body, headers


class Nginx:
    """nginx (one worker) serving `files` {path: (bytes, headers)} from a scratch root."""

    def __init__(self, workdir, files, tls_files=None, tls=None):
        """`tls_files`: (certificate, key) for HTTPS; `tls`: the client context that trusts it."""
        self.port = free_port()
        # nginx started as root reads as its worker user: the scratch tree must be readable by all.
        os.chmod(workdir, 0o755)
        root = os.path.join(workdir, "www")
        for path, (body, _) in files.items():
            target = os.path.join(root, path.lstrip("/"))
            os.makedirs(os.path.dirname(target), exist_ok=True)
            with open(target, "wb") as f:
                f.write(body)
            os.chmod(target, 0o644)
        # The gateway's own headers, the same for every path here.
        headers = next(iter(files.values()))[1]
        extra = "\n".join(f"    add_header {name} {headers[name]};" for name in ("Cache-Control", "X-Request-Id")
                          if name in headers)
        tls_lines = ""
        if tls_files:
            tls_lines = (f"    ssl_certificate {tls_files[0]};\n    ssl_certificate_key {tls_files[1]};\n"
                         "    ssl_protocols TLSv1.2 TLSv1.3;")
        conf = os.path.join(workdir, "nginx.conf")
        with open(conf, "w") as f:
            f.write(f"""worker_processes 1;
daemon off;
pid {workdir}/nginx.pid;
error_log {workdir}/nginx-error.log;
events {{ worker_connections 1024; }}
http {{
  access_log off;
  default_type application/json;
  types {{ }}
  client_body_temp_path {workdir}/tmp;
  proxy_temp_path {workdir}/tmp;
  fastcgi_temp_path {workdir}/tmp;
  uwsgi_temp_path {workdir}/tmp;
  scgi_temp_path {workdir}/tmp;
  server {{
    listen 127.0.0.1:{self.port}{" ssl" if tls_files else ""};
{tls_lines}
    root {root};
{extra}
  }}
}}
""")
        self.proc = subprocess.Popen(["nginx", "-c", conf, "-e", os.path.join(workdir, "nginx-error.log")],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 10
        while True:
            try:
                fetch(self.port, PATHS[-1], tls)
                return
            except OSError:
                if self.proc.poll() is not None or time.monotonic() > deadline:
                    raise RuntimeError("nginx did not start; see nginx-error.log")
                time.sleep(0.1)

    def stop(self):
        self.proc.terminate()
        self.proc.wait(10)


UNITS = {"us": 1e-3, "ms": 1.0, "s": 1e3}


def wrk(port, path, seconds, threads, connections, scheme="http"):
    """{'rps', 'p50', 'p99'} (latencies in ms) from one wrk run."""
    out = subprocess.run(["wrk", f"-t{threads}", f"-c{connections}", f"-d{seconds}s", "--latency",
                          f"{scheme}://127.0.0.1:{port}{path}"], capture_output=True, text=True, check=True).stdout
    r = {"rps": float(re.search(r"Requests/sec:\s+([\d.]+)", out).group(1))}
    for pct, key in (("50", "p50"), ("99", "p99")):
        m = re.search(rf"^\s+{pct}%\s+([\d.]+)(us|ms|s)\s*$", out, re.M)
        r[key] = float(m.group(1)) * UNITS[m.group(2)]
    errors = re.search(r"Non-2xx or 3xx responses: (\d+)", out)
    if errors:
        raise RuntimeError(f"wrk saw {errors.group(1)} error answers on {path}")
    return r


def median_of(runs, key):
    return statistics.median(r[key] for r in runs)


def table(results, rounds, seconds, threads, connections):
    lines = ["| path | gateway req/s | nginx req/s | ratio (goal) | gateway p50 ms | nginx p50 ms | "
             "gateway p99 ms | nginx p99 ms | p99 ratio (goal <= 1.2) |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    verdicts = []
    for path in PATHS:
        g, n = results[(path, "gateway")], results[(path, "nginx")]
        ratio = median_of(g, "rps") / median_of(n, "rps")
        p99_ratio = median_of(g, "p99") / median_of(n, "p99")
        goal = GOALS[path]
        lines.append(f"| `{path}` | {median_of(g, 'rps'):,.0f} | {median_of(n, 'rps'):,.0f} | "
                     f"{ratio:.2f}x (>= {goal}) | {median_of(g, 'p50'):.2f} | {median_of(n, 'p50'):.2f} | "
                     f"{median_of(g, 'p99'):.2f} | {median_of(n, 'p99'):.2f} | {p99_ratio:.2f}x |")
        verdicts.append(ratio >= goal and p99_ratio <= MAX_P99_RATIO)
    lines.append("")
    lines.append(f"Medians of {rounds} interleaved rounds; each run is `wrk -t{threads} -c{connections} "
                 f"-d{seconds}s` on loopback, wrk on the same machine as the servers.")
    return "\n".join(lines), all(verdicts)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--gateway", default=os.path.join(ROOT, "build", "gateway", "asi-gateway"))
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("--seconds", type=int, default=5)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--connections", type=int, default=64)
    p.add_argument("--results", default="", help="append the table to this file (e.g. bench/RESULTS.md)")
    p.add_argument("--tls", action="store_true", help="HTTPS on both (the gateway's http.tls)")
    args = p.parse_args()
    for tool in ("wrk", "nginx"):
        if not shutil.which(tool):
            sys.exit(f"{tool} is missing: run bench/setup")

    tmp = tempfile.mkdtemp(prefix="gw-http-bench-")
    gw = nginx = None
    tls_files, tls = None, None
    scheme = "https" if args.tls else "http"
    try:
        http_config = {"limits": {"max_connections_per_address": 200}}
        if args.tls:
            tls_files = (os.path.join(tmp, "server.crt"), os.path.join(tmp, "server.key"))
            subprocess.run(["openssl", "req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:P-256",
                            "-nodes", "-keyout", tls_files[1], "-out", tls_files[0], "-days", "1", "-subj",
                            "/CN=localhost", "-addext", "subjectAltName=IP:127.0.0.1"], check=True,
                           capture_output=True)
            for f in tls_files:
                os.chmod(f, 0o644)  # nginx's worker reads them as its own user
            tls = ssl.create_default_context(cafile=tls_files[0])
            http_config["tls"] = {"cert_file": tls_files[0], "key_file": tls_files[1]}
        # Every load comes from 127.0.0.1: the per-address connection limit (64) must not refuse wrk's.
        gw = Gateway(args.gateway, tmp, {"simulate": {"count": 1, "directory": os.path.join(tmp, "sim")},
                                         "http": http_config}, tls=tls)
        gw.wait_ready()
        files = {path: fetch(gw.port, path, tls) for path in PATHS}
        nginx = Nginx(tmp, files, tls_files, tls)
        load_before = os.getloadavg()
        results = {}
        for r in range(args.rounds):
            for path in PATHS:
                for name, port in (("gateway", gw.port), ("nginx", nginx.port)):
                    run = wrk(port, path, args.seconds, args.threads, args.connections, scheme)
                    results.setdefault((path, name), []).append(run)
                    print(f"round {r + 1}: {name:8} {path:28} {run['rps']:>10,.0f} req/s  p50 {run['p50']:.2f} ms"
                          f"  p99 {run['p99']:.2f} ms", flush=True)
        load_after = os.getloadavg()
    finally:
        if nginx:
            nginx.stop()
        if gw:
            gw.stop()
        shutil.rmtree(tmp, ignore_errors=True)

    text, met = table(results, args.rounds, args.seconds, args.threads, args.connections)
    bodies = f"Bodies: {len(files[PATHS[0]][0])} and {len(files[PATHS[1]][0])} bytes."
    title = "HTTPS against nginx with TLS" if args.tls else "HTTP against nginx"
    script = "bench/http_vs_nginx.py --tls" if args.tls else "bench/http_vs_nginx.py"
    return publish_section(title, script, bodies, load_before, load_after, text, met, args.results)


if __name__ == "__main__":
    sys.exit(main())
