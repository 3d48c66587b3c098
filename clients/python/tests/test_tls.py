"""TLS: verification is on by default (a self-signed gateway is refused), a CA file makes it
trusted, verify=False turns the check off; REST and the WebSocket alike. The gateway serves
plain HTTP, so a TLS-terminating proxy with a certificate made here stands in front of it."""

from __future__ import annotations

import shutil
import ssl
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest
from gateway_process import TOKENS, RunningGateway
from tcp_proxy import CuttableProxy

from asi_gateway import Event, Gateway, GatewayUnreachable


@pytest.fixture(scope="module")
def certificate(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    openssl = shutil.which("openssl")
    if openssl is None:
        pytest.fail("openssl is needed (Debian package openssl)")
    directory = tmp_path_factory.mktemp("tls")
    cert, key = directory / "cert.pem", directory / "key.pem"
    subprocess.run(
        [openssl, "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "1", "-subj", "/CN=127.0.0.1",
         "-addext", "subjectAltName=IP:127.0.0.1", "-keyout", str(key), "-out", str(cert)],
        check=True,
        capture_output=True,
    )  # fmt: skip
    return cert, key


@pytest.fixture
def tls_proxy(gateway: RunningGateway, certificate: tuple[Path, Path]) -> Iterator[CuttableProxy]:
    context = ssl.SSLContext(ssl.PROTOCOL_TLS_SERVER)
    context.load_cert_chain(*certificate)
    proxy = CuttableProxy(gateway.port, tls=context)
    yield proxy
    proxy.close()


def test_self_signed_gateway_is_refused_by_default(tls_proxy: CuttableProxy) -> None:
    assert tls_proxy.url.startswith("https://")
    with Gateway(tls_proxy.url, token=TOKENS["viewer"]) as gw:
        with pytest.raises(GatewayUnreachable, match="CERTIFICATE_VERIFY_FAILED"):
            gw.list_controllers()
        with pytest.raises(GatewayUnreachable, match="CERTIFICATE_VERIFY_FAILED"):
            gw.subscribe("controllers/+/state").__enter__()


def test_ca_file_trusts_it_for_rest_and_websocket(tls_proxy: CuttableProxy, certificate: tuple[Path, Path]) -> None:
    with Gateway(tls_proxy.url, token=TOKENS["viewer"], ca_file=str(certificate[0])) as gw:
        assert [c.id for c in gw.list_controllers()] == ["ext1", "cam1", "sim1", "sim2"]
        with gw.subscribe("controllers/sim1/state") as sub:
            message = sub.next(timeout_s=30)
            assert isinstance(message, Event)
            assert message.data["id"] == "sim1"


def test_verify_false_skips_the_check(tls_proxy: CuttableProxy) -> None:
    with Gateway(tls_proxy.url, token=TOKENS["viewer"], verify=False) as gw:
        assert gw.whoami()["role"] == "viewer"
        with gw.subscribe("controllers/sim2/state") as sub:
            assert isinstance(sub.next(timeout_s=30), Event)
