#!/usr/bin/python3
"""The gateway behind a real nginx (issue 34): the server block of docker/reverse-proxy/nginx.conf,
with only its certificate paths, ports and server name replaced, terminating TLS in front of the real
asi-gateway on loopback with tokens and http.trusted_proxies ["127.0.0.1"].

The test's client connects from 127.0.0.2 (another loopback address), so the proxy (127.0.0.1) and
the client are told apart. Checks:
  - HTTPS through nginx: health, and a move whose audit entry names the client (127.0.0.2), not the
    proxy, and not what the client wrote into X-Forwarded-For itself;
  - a client that is not a trusted proxy cannot forge its address: its X-Forwarded-For is ignored;
  - WSS through nginx: a command runs, and its audit entry names the client;
  - a page's Origin passes the browser rules through the proxy (nginx passes Host with its port);
  - more WebSockets through the proxy than one address may hold (max_connections_per_address 2)
    are all served: the proxy speaks for many clients.

Skipped (exit 77) without nginx (scripts/install-deps --tests installs nginx-light).
Run by ctest with Debian's /usr/bin/python3 (python3-websockets). Exit code 0 when every check passed.
"""

import argparse
import asyncio
import json
import os
import shutil
import socket
import ssl
import subprocess
import sys

import websockets

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gateway_fixture import (TOKENS, WAIT, Fixture, auth_tokens, check, free_port, http_request,  # noqa: E402
                             run_main, self_signed_certificate, wait_until)

HERE = os.path.dirname(os.path.abspath(__file__))
EXAMPLE = os.path.join(HERE, "..", "..", "..", "docker", "reverse-proxy", "nginx.conf")
CLIENT = "127.0.0.2"


def request(port, ctx, method, path, body=None, headers=None, token=TOKENS["admin"]):
    """One request from CLIENT: over HTTPS to nginx with `ctx`, else plain to the gateway."""
    return http_request(port, method, path, body, token=token, tls=ctx, headers=headers, source=CLIENT,
                        host="localhost" if ctx else "127.0.0.1")


def start_nginx(fx, gateway_port, proxy_port, cert, key):
    with open(EXAMPLE) as f:
        server = f.read()
    for old, new in (("listen 443 ssl;", f"listen 127.0.0.1:{proxy_port} ssl;"),
                     ("server_name gateway.lab.example;", "server_name localhost;"),
                     ("/etc/ssl/asi-gateway/fullchain.pem", cert), ("/etc/ssl/asi-gateway/privkey.pem", key),
                     ("http://127.0.0.1:8080", f"http://127.0.0.1:{gateway_port}")):
        check(old in server, f"the example no longer has {old!r}")
        server = server.replace(old, new)
    prefix = os.path.join(fx.tmp, "nginx")
    os.makedirs(os.path.join(prefix, "logs"), exist_ok=True)
    conf = os.path.join(prefix, "nginx.conf")
    with open(conf, "w") as f:
        f.write(f"""error_log {prefix}/logs/error.log;
pid {prefix}/nginx.pid;
events {{ worker_connections 256; }}
http {{
    access_log off;
    client_body_temp_path {prefix}/body;
    proxy_temp_path {prefix}/proxy;
    fastcgi_temp_path {prefix}/fastcgi;
    uwsgi_temp_path {prefix}/uwsgi;
    scgi_temp_path {prefix}/scgi;
{server}
}}
""")
    proc = subprocess.Popen(["nginx", "-p", prefix, "-c", conf, "-g", "daemon off; master_process off;"],
                            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)
    fx.procs.append(proc)

    def up():
        if proc.poll() is not None:
            with open(os.path.join(prefix, "logs", "error.log")) as f:
                raise AssertionError(f"nginx exited: {f.read()[-1500:]}")
        with socket.create_connection(("127.0.0.1", proxy_port), timeout=1):
            return True

    wait_until("nginx listening", up)
    return proc


def last_audit(gateway_port, action):
    status, text = request(gateway_port, None, "GET", "/api/v1/audit?limit=20")
    check(status == 200, f"audit: {status} {text[:200]}")
    return next((e for e in json.loads(text)["entries"] if e["action"] == action), None)


def test_https_through_proxy(proxy_port, gateway_port, ctx):
    status, text = request(proxy_port, ctx, "GET", "/api/v1/health")
    check(status == 200, f"health through nginx: {status} {text[:200]}")
    status, text = request(proxy_port, ctx, "POST", "/api/v1/controllers/sim1/move",
                           {"axes": {"X": 321}, "wait": True}, headers={"X-Forwarded-For": "6.6.6.6"})
    check(status == 200, f"move through nginx: {status} {text[:300]}")
    entry = last_audit(gateway_port, "move")
    check(entry and entry["address"] == CLIENT, f"the audit entry of the move: {entry}")


def test_forged_header_ignored(gateway_port):
    status, text = request(gateway_port, None, "POST", "/api/v1/controllers/sim1/move", {"axes": {"X": 123}},
                           headers={"X-Forwarded-For": "6.6.6.6"})
    check(status == 200, f"direct move: {status} {text[:300]}")
    entry = last_audit(gateway_port, "move")
    check(entry and entry["address"] == CLIENT and entry["detail"]["axes"]["X"] == 123,
          f"a forged X-Forwarded-For from a non-proxy was believed: {entry}")


def wss_connect(proxy_port, ctx):
    url = f"wss://localhost:{proxy_port}/api/v1/ws?access_token={TOKENS['operator']}"
    return websockets.connect(url, ssl=ctx, open_timeout=WAIT, local_addr=(CLIENT, 0))


def test_wss_through_proxy(proxy_port, gateway_port, ctx):
    async def go():
        async with wss_connect(proxy_port, ctx) as ws:
            await ws.send(json.dumps({"op": "command", "id": "z", "controller": "sim1", "operation": "move",
                                      "args": {"axes": {"Y": 55}}}))
            while True:
                m = json.loads(await asyncio.wait_for(ws.recv(), WAIT))
                if m.get("id") == "z":
                    return m

    answer = asyncio.run(go())
    check(answer["type"] == "result", f"the move over WSS through nginx: {answer}")
    entry = last_audit(gateway_port, "move")
    check(entry and entry["transport"] == "websocket" and entry["address"] == CLIENT,
          f"the audit entry of the WebSocket move: {entry}")


def test_origin_through_proxy(proxy_port, ctx):
    status, text = request(proxy_port, ctx, "POST", "/api/v1/controllers/sim1/move", {"axes": {"X": 10}},
                           headers={"Origin": f"https://localhost:{proxy_port}"})
    check(status == 200, f"a same-origin page's POST through nginx: {status} {text[:300]}")
    status, text = request(proxy_port, ctx, "POST", "/api/v1/controllers/sim1/move", {"axes": {"X": 10}},
                           headers={"Origin": "https://evil.example"})
    check(status == 403, f"a foreign page's POST through nginx: {status} {text[:200]}")


def test_proxy_not_held_to_one_address(proxy_port, ctx):
    async def go():
        sockets = []
        try:
            for _ in range(4):
                ws = await wss_connect(proxy_port, ctx)
                sockets.append(ws)
                await ws.send(json.dumps({"op": "ping", "id": len(sockets)}))
                m = json.loads(await asyncio.wait_for(ws.recv(), WAIT))
                while m.get("type") != "pong":
                    m = json.loads(await asyncio.wait_for(ws.recv(), WAIT))
            return len(sockets)
        finally:
            for ws in sockets:
                await ws.close()

    check(asyncio.run(go()) == 4, "not every WebSocket through the proxy was served")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    args = ap.parse_args()
    if not shutil.which("nginx"):
        print("nginx is not installed (scripts/install-deps --tests installs nginx-light): skipped")
        return 77
    fx = Fixture("gw-proxy-test-")
    try:
        cert, key = self_signed_certificate(fx.tmp)
        ctx = ssl.create_default_context(cafile=cert)
        gateway_port, proxy_port = free_port(), free_port()
        fx.start_gateway(args.gateway, {
            "http": {"listen_address": "127.0.0.1", "port": gateway_port, "trusted_proxies": ["127.0.0.1"],
                     "limits": {"max_connections_per_address": 2}},
            "auth": auth_tokens(),
            "simulate": {"count": 1, "time_scale": 10, "directory": os.path.join(fx.tmp, "sims")},
            "logging": {"level": "info"}})
        start_nginx(fx, gateway_port, proxy_port, cert, key)
        fx.run("HTTPS through nginx: the audit names the client", test_https_through_proxy, proxy_port,
               gateway_port, ctx)
        fx.run("X-Forwarded-For from a non-proxy is ignored", test_forged_header_ignored, gateway_port)
        fx.run("WSS through nginx: the audit names the client", test_wss_through_proxy, proxy_port, gateway_port, ctx)
        fx.run("a page's Origin passes through the proxy, a foreign one does not", test_origin_through_proxy,
               proxy_port, ctx)
        fx.run("the proxy is not held to one address's connections", test_proxy_not_held_to_one_address,
               proxy_port, ctx)
        return fx.stop_and_report()
    finally:
        fx.cleanup()


if __name__ == "__main__":
    run_main(main)
