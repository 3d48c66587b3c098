#!/usr/bin/python3
"""HTTPS and WSS (http.tls, issue 34) end to end: the real asi-gateway with a self-signed certificate
made by Debian's openssl, tokens, one simulated controller.

Checks:
  - a client that verifies the certificate (the test CA is the certificate) gets /api/v1/health and a
    move over HTTPS, with TLS 1.2 or newer; one that trusts nothing else refuses the certificate;
  - a client that offers only TLS 1.1 gets no connection;
  - WSS: a WebSocket over TLS subscribes and runs a command;
  - plain HTTP to the TLS port gets no answer, and the gateway keeps serving;
  - a client that connects and never finishes its handshake is closed after the header timeout and
    counted (gw_http_tls_handshake_failures_total);
  - SIGHUP reloads the certificate: new connections get the new one, an open keep-alive connection
    keeps working; a SIGHUP with a broken key keeps the previous certificate and logs why; both
    reloads are in the audit trail;
  - a wrong certificate path stops the start with the file named (exit 1), and --check-config
    names it too.

Run by ctest with Debian's /usr/bin/python3 (python3-websockets). Exit code 0 when every check passed.
"""

import argparse
import asyncio
import hashlib
import http.client
import json
import os
import signal
import socket
import ssl
import subprocess
import sys
import time
import warnings

import websockets

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gateway_fixture import (TOKENS, WAIT, Fixture, auth_tokens, check, free_port, http_request,  # noqa: E402
                             run_main, self_signed_certificate, wait_until)

HEADER_TIMEOUT_MS = 1500


def client_context(cafile):
    """What a careful client does: verify the chain against `cafile` and the host name."""
    ctx = ssl.create_default_context(cafile=cafile)
    ctx.check_hostname = True
    return ctx


def peer_fingerprint(port, ctx):
    """SHA-256 of the certificate the gateway presents to a new connection."""
    with socket.create_connection(("127.0.0.1", port), timeout=WAIT) as raw:
        with ctx.wrap_socket(raw, server_hostname="localhost") as tls:
            return hashlib.sha256(tls.getpeercert(binary_form=True)).hexdigest()


def file_fingerprint(cert):
    der = ssl.PEM_cert_to_DER_cert(open(cert).read())
    return hashlib.sha256(der).hexdigest()


def metric(port, ctx, name):
    status, text = http_request(port, "GET", "/api/v1/metrics", tls=ctx)
    check(status == 200, f"metrics: {status}")
    for line in text.splitlines():
        if line.startswith(name + " ") or line.startswith(name + "{"):
            return float(line.rsplit(" ", 1)[1])
    return 0.0


def test_verified_client(port, ctx):
    conn = http.client.HTTPSConnection("localhost", port, timeout=WAIT, context=ctx)
    conn.request("GET", "/api/v1/health")
    r = conn.getresponse()
    body = r.read()
    check(r.status == 200, f"health over HTTPS: {r.status} {body[:200]!r}")
    version = conn.sock.version()
    check(version in ("TLSv1.2", "TLSv1.3"), f"negotiated {version}")
    conn.close()
    status, text = http_request(port, "POST", "/api/v1/controllers/sim1/move", {"axes": {"X": 250}, "wait": True},
                                tls=ctx)
    check(status == 200, f"move over HTTPS: {status} {text[:300]}")
    status, text = http_request(port, "GET", "/api/v1/controllers/sim1", tls=ctx)
    x = next(a["position_um"] for a in json.loads(text)["axes"] if a["axis"] == "X")
    check(abs(x - 250) < 1, f"sim1 X at {x} after the move")


def test_untrusting_client_refuses(port):
    ctx = ssl.create_default_context()  # the system's CAs: the self-signed certificate is not among them
    try:
        http_request(port, "GET", "/api/v1/health", tls=ctx)
    except ssl.SSLCertVerificationError:
        return
    raise AssertionError("a client that does not trust the certificate connected")


def test_old_tls_refused(port, cafile):
    """This client does connect with TLS 1.1 to a server that allows it (openssl s_server -tls1_1)."""
    ctx = client_context(cafile)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        ctx.minimum_version = ssl.TLSVersion.MINIMUM_SUPPORTED
        ctx.maximum_version = ssl.TLSVersion.TLSv1_1
    try:
        ctx.set_ciphers("DEFAULT:@SECLEVEL=0")  # let this client offer TLS 1.1 at all
    except ssl.SSLError:
        pass
    try:
        peer_fingerprint(port, ctx)
    except (ssl.SSLError, OSError):
        return
    raise AssertionError("a TLS 1.1 client connected")


def test_wss(port, ctx):
    async def go():
        url = f"wss://localhost:{port}/api/v1/ws?access_token={TOKENS['operator']}"
        async with websockets.connect(url, ssl=ctx, open_timeout=WAIT) as ws:
            await ws.send(json.dumps({"op": "subscribe", "id": 1, "topics": ["controllers/sim1/state"]}))
            await ws.send(json.dumps({"op": "command", "id": 2, "controller": "sim1", "operation": "move",
                                      "args": {"axes": {"Y": 120}}}))
            seen_state, result = False, None
            deadline = time.monotonic() + WAIT
            while (not seen_state or result is None) and time.monotonic() < deadline:
                m = json.loads(await asyncio.wait_for(ws.recv(), WAIT))
                if m.get("type") == "event" and m.get("topic") == "controllers/sim1/state":
                    seen_state = True
                if m.get("id") == 2 and m.get("type") in ("result", "error"):
                    result = m
            check(seen_state, "no state event over WSS")
            check(result and result["type"] == "result", f"the move over WSS: {result}")

    asyncio.run(go())


def test_plain_http_gets_nothing(port, ctx):
    with socket.create_connection(("127.0.0.1", port), timeout=WAIT) as s:
        s.sendall(b"GET /api/v1/health HTTP/1.1\r\nHost: localhost\r\n\r\n")
        got = b""
        try:
            while True:
                chunk = s.recv(4096)
                if not chunk:
                    break
                got += chunk
        except OSError:
            pass
    check(b"HTTP/1.1 200" not in got, f"plain HTTP was answered: {got[:100]!r}")
    status, _ = http_request(port, "GET", "/api/v1/health", tls=ctx)
    check(status == 200, f"HTTPS after a plain request: {status}")


def test_silent_handshake_closed(port, ctx):
    before = metric(port, ctx, "gw_http_tls_handshake_failures_total")
    with socket.create_connection(("127.0.0.1", port), timeout=WAIT) as s:
        started = time.monotonic()
        s.settimeout(WAIT)
        try:
            closed = s.recv(1) == b""
        except ConnectionResetError:
            closed = True
        waited = time.monotonic() - started
    check(closed, "a silent client was not closed")
    check(waited >= HEADER_TIMEOUT_MS / 1000 * 0.9, f"closed after {waited:.2f} s, before the header timeout")
    wait_until("the failed handshake counted",
               lambda: metric(port, ctx, "gw_http_tls_handshake_failures_total") >= before + 1)


def test_sighup_reloads(fx, port, ctx_for, cert, key):
    old = file_fingerprint(cert)
    check(peer_fingerprint(port, ctx_for(cert)) == old, "the first certificate is not the one served")
    # A keep-alive connection opened before the reload.
    kept = http.client.HTTPSConnection("localhost", port, timeout=WAIT, context=ctx_for(cert))
    kept.request("GET", "/api/v1/health")
    check(kept.getresponse().read() is not None, "keep-alive request")
    # New files in place (a renewal writes them over the old ones), then SIGHUP.
    new_dir = os.path.join(fx.tmp, "renewed")
    os.makedirs(new_dir, exist_ok=True)
    new_cert, new_key = self_signed_certificate(new_dir)
    os.replace(new_cert, cert)
    os.replace(new_key, key)
    new = file_fingerprint(cert)
    check(new != old, "the renewed certificate is the same")
    fx.gateway.send_signal(signal.SIGHUP)
    wait_until("the new certificate served", lambda: peer_fingerprint(port, ctx_for(cert)) == new)
    kept.request("GET", "/api/v1/health")
    r = kept.getresponse()
    r.read()
    check(r.status == 200, f"the kept-alive connection after the reload: {r.status}")
    kept.close()
    check(fx.gateway.poll() is None, "the gateway stopped on SIGHUP")
    # A broken key: the reload fails, the certificate served stays, the log says why.
    with open(key, "w") as f:
        f.write("-----BEGIN PRIVATE KEY-----\nnot a key\n-----END PRIVATE KEY-----\n")
    fx.gateway.send_signal(signal.SIGHUP)
    wait_until("the failed reload logged", lambda: "TLS certificate not reloaded" in open(fx.log_path).read())
    check(peer_fingerprint(port, ctx_for(cert)) == new, "a failed reload changed the certificate")
    line = next(l for l in open(fx.log_path) if "TLS certificate not reloaded" in l)
    check(key in line, f"the log line does not name the key file: {line}")
    # Both reloads are in the audit trail.
    status, text = http_request(port, "GET", "/api/v1/audit?limit=50", tls=ctx_for(cert))
    reloads = [e for e in json.loads(text)["entries"] if e["action"] == "tls.reload"]
    check(status == 200 and [e["outcome"] for e in reloads] == ["failed", "ok"]
          and reloads[0]["transport"] == "signal" and key in reloads[0]["detail"]["error"],
          f"the reloads in the audit trail: {status} {reloads}")


def test_wrong_path_fails_at_start(fx, gateway):
    missing = os.path.join(fx.tmp, "nowhere", "server.crt")
    cfg = os.path.join(fx.tmp, "wrong.json")
    with open(cfg, "w") as f:
        json.dump({"http": {"port": free_port(), "tls": {"cert_file": missing, "key_file": missing + ".key"}},
                   "simulate": {"count": 1, "directory": os.path.join(fx.tmp, "sims-wrong")},
                   "storage": {"path": os.path.join(fx.tmp, "store-wrong")}}, f)
    r = subprocess.run([gateway, "--config", cfg], stdin=subprocess.DEVNULL, capture_output=True, text=True,
                       timeout=WAIT)
    check(r.returncode == 1, f"exit code {r.returncode}")
    out = r.stdout + r.stderr
    check("http.tls.cert_file" in out and missing in out and "No such file" in out,
          f"the start-up error does not name the file: {out[-600:]}")
    r = subprocess.run([gateway, "--check-config", cfg], stdin=subprocess.DEVNULL, capture_output=True,
                       text=True, timeout=WAIT)
    check(r.returncode != 0 and missing in r.stdout + r.stderr, f"--check-config: {r.returncode} {r.stdout}{r.stderr}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    args = ap.parse_args()
    fx = Fixture("gw-tls-test-")
    try:
        cert, key = self_signed_certificate(fx.tmp)
        port = free_port()

        def ctx_for(cafile):
            return client_context(cafile)

        ctx = ctx_for(cert)
        fx.start_gateway(args.gateway, {
            "http": {"listen_address": "127.0.0.1", "port": port, "tls": {"cert_file": cert, "key_file": key},
                     "limits": {"header_timeout_ms": HEADER_TIMEOUT_MS}},
            "auth": auth_tokens(),
            "simulate": {"count": 1, "time_scale": 10, "directory": os.path.join(fx.tmp, "sims")},
            "logging": {"level": "info"}}, tls=ctx)
        fx.run("a verifying client: health and a move over HTTPS", test_verified_client, port, ctx)
        fx.run("a client that does not trust the certificate refuses it", test_untrusting_client_refuses, port)
        fx.run("TLS 1.1 gets no connection", test_old_tls_refused, port, cert)
        fx.run("WSS: events and a command", test_wss, port, ctx)
        fx.run("plain HTTP to the TLS port gets no answer", test_plain_http_gets_nothing, port, ctx)
        fx.run("a silent client is closed after the header timeout", test_silent_handshake_closed, port, ctx)
        fx.run("SIGHUP reloads the certificate, a broken one is not taken", test_sighup_reloads, fx, port, ctx_for,
               cert, key)
        fx.run("a wrong certificate path fails at start with the file named", test_wrong_path_fails_at_start, fx,
               args.gateway)
        return fx.stop_and_report()
    finally:
        fx.cleanup()


if __name__ == "__main__":
    run_main(main)
