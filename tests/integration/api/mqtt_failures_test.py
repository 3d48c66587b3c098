"""MQTT connection failures are logged with a reason a person can act on (issue 13): the real
asi-gateway (one simulated controller) against a real mosquitto that it cannot use: a port where
nothing listens (connection refused), a TLS broker whose certificate comes from a CA the gateway does
not trust (unknown CA), one whose certificate names another host (wrong host name), one that requires a
client certificate the gateway does not send, and a broker that refuses anonymous clients (not
authorised). A gateway that never reached its broker does not claim "offline published" on SIGTERM.

Run by ctest (mqtt_failures); by hand:
  /usr/bin/python3 tests/integration/api/mqtt_failures_test.py --gateway build/gateway/asi-gateway
"""

import argparse
import os
import signal
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gateway_fixture import WAIT, Fixture, check, free_port, wait_until  # noqa: E402
from mqtt_api_test import Broker, Gateway, make_pki  # noqa: E402


def log_text(gw):
    with open(gw.log_path) as f:
        return f.read()


def expect_logged(gw, *parts):
    def found():
        for line in log_text(gw).splitlines():
            if "cannot connect to" in line and all(p in line for p in parts):
                return line
        return None
    return wait_until(f"{gw.name}: a connect failure naming {parts}", found, timeout=30)


def stop(gw):
    gw.proc.send_signal(signal.SIGTERM)
    code = gw.proc.wait(timeout=WAIT)
    check(code == 0, f"{gw.name} exited {code}")


def test_refused(fx, binary):
    gw = Gateway(fx, binary, "gw-refused", [f"mqtt://127.0.0.1:{free_port()}"], sims=1)
    gw.start()
    expect_logged(gw, "connection refused", "nothing listens")
    stop(gw)
    text = log_text(gw)
    check("offline published" not in text, "'offline published' logged for a broker never reached")
    check("the broker was never reached" in text, "no word on the unreached broker at shutdown")


def wrong_host_cert(pki_dir, ca, ca_key):
    def run(*args):
        subprocess.run(["openssl", *args], cwd=pki_dir, check=True, stdout=subprocess.DEVNULL,
                       stderr=subprocess.DEVNULL)
    with open(os.path.join(pki_dir, "elsewhere.ext"), "w") as f:
        f.write("subjectAltName=DNS:elsewhere.example\n")
    run("req", "-newkey", "rsa:2048", "-nodes", "-keyout", "elsewhere.key", "-out", "elsewhere.csr",
        "-subj", "/CN=elsewhere.example")
    run("x509", "-req", "-in", "elsewhere.csr", "-CA", ca, "-CAkey", ca_key, "-CAcreateserial",
        "-out", "elsewhere.pem", "-days", "2", "-extfile", "elsewhere.ext")
    return os.path.join(pki_dir, "elsewhere.pem"), os.path.join(pki_dir, "elsewhere.key")


def test_tls(fx, binary):
    pki = make_pki(fx.tmp)
    broker = Broker(fx, "tls-broker", tls={"ca": pki["ca"], "cert": pki["server_cert"], "key": pki["server_key"]})
    broker.start()
    url = f"mqtts://localhost:{broker.tls_port}"
    client = {"cert_file": pki["client_cert"], "key_file": pki["client_key"], "verify": True}
    unknown_ca = Gateway(fx, binary, "gw-unknown-ca", [url], sims=1,
                         mqtt_extra={"tls": {"ca_file": pki["other_ca"], **client}})
    no_cert = Gateway(fx, binary, "gw-no-cert", [url], sims=1,
                      mqtt_extra={"tls": {"ca_file": pki["ca"], "verify": True}})
    cert, key = wrong_host_cert(os.path.dirname(pki["ca"]), pki["ca"], os.path.join(os.path.dirname(pki["ca"]),
                                                                                    "ca.key"))
    elsewhere = Broker(fx, "elsewhere-broker", tls={"ca": pki["ca"], "cert": cert, "key": key})
    elsewhere.start()
    wrong_host = Gateway(fx, binary, "gw-wrong-host", [f"mqtts://localhost:{elsewhere.tls_port}"], sims=1,
                         mqtt_extra={"tls": {"ca_file": pki["ca"], **client}})
    for g in (unknown_ca, no_cert, wrong_host):
        g.start()
    try:
        line = expect_logged(unknown_ca, "TLS handshake failed")
        check("unknown CA" in line and "certificate verify failed" in line and "wrong host name" not in line, line)
        line = expect_logged(no_cert, "TLS handshake failed")
        check("client certificate" in line, line)
        line = expect_logged(wrong_host, "TLS handshake failed")
        check("wrong host name" in line and "unknown CA" not in line, line)
    finally:
        for g in (unknown_ca, no_cert, wrong_host):
            stop(g)


def test_not_authorised(fx, binary):
    broker = Broker(fx, "closed-broker", extra=["allow_anonymous false"])
    broker.start()
    for protocol in ("5", "3.1.1"):
        gw = Gateway(fx, binary, f"gw-anon-{protocol.replace('.', '')}", [f"mqtt://127.0.0.1:{broker.port}"], sims=1,
                     mqtt_extra={"protocol": protocol})
        gw.start()
        try:
            expect_logged(gw, "not authorised")
        finally:
            stop(gw)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    args = ap.parse_args()
    fx = Fixture("asi-mqtt-failures-")
    try:
        fx.run("connection refused; no 'offline published' for a broker never reached", test_refused, fx,
               args.gateway)
        fx.run("TLS: unknown CA, missing client certificate, wrong host name", test_tls, fx, args.gateway)
        fx.run("not authorised (MQTT 5 and 3.1.1)", test_not_authorised, fx, args.gateway)
    except Exception as e:  # noqa: BLE001
        fx.failures.append(("setup", e))
        print(f"[FAIL] setup: {e}")
    finally:
        if fx.failures:
            for name in sorted(os.listdir(fx.tmp)):
                if name.startswith("gw-") and name.endswith(".log"):
                    with open(os.path.join(fx.tmp, name)) as f:
                        tail = [line for line in f if "mqtt" in line][-6:]
                    print(f"---- {name} (mqtt lines) ----\n{''.join(tail)}")
        code = fx.report()
        fx.cleanup()
    return code


if __name__ == "__main__":
    sys.exit(main())
