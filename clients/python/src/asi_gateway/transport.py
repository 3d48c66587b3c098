"""The HTTP side: one httpx.AsyncClient per gateway, bearer token, TLS, and problem+json answers
turned into exceptions. Everything else in the package talks to the gateway through `Transport`."""

from __future__ import annotations

import asyncio
import ssl
from collections.abc import Mapping
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit, urlunsplit

import httpx

from .problems import GatewayUnreachable, UnexpectedResponse, problem_from_body

API_PREFIX = "/api/v1"
USER_AGENT = "asi-gateway-python/0.1.0"


def make_ssl_context(verify: bool, ca_file: str | None) -> ssl.SSLContext:
    """Verification is on unless `verify` is False; `ca_file` adds a CA (a self-signed gateway)."""
    context = ssl.create_default_context(cafile=ca_file)
    if not verify:
        context.check_hostname = False
        context.verify_mode = ssl.CERT_NONE
    return context


def _retry_after(response: httpx.Response) -> float | None:
    value = response.headers.get("Retry-After")
    try:
        return float(value) if value is not None else None
    except ValueError:
        return None


def raise_for_problem(response: httpx.Response) -> None:
    """Raises the mapped Problem for an error answer; returns for a success."""
    if response.status_code < 400:
        return
    media = response.headers.get("Content-Type", "").split(";")[0].strip()
    if media in ("application/problem+json", "application/json"):
        try:
            body = response.json()
        except ValueError:
            body = None
        if isinstance(body, dict) and "type" in body:
            raise problem_from_body(body, _retry_after(response))
    raise UnexpectedResponse(response.status_code, response.text)


class Transport:
    """Requests to one gateway. `url` is the server root ("http://127.0.0.1:8080")."""

    def __init__(
        self,
        url: str,
        *,
        token: str | None = None,
        verify: bool = True,
        ca_file: str | None = None,
        timeout: float = 30.0,
    ) -> None:
        parts = urlsplit(url)
        if parts.scheme not in ("http", "https") or not parts.netloc:
            raise ValueError(f"expected an http:// or https:// URL, got {url!r}")
        self.url = urlunsplit((parts.scheme, parts.netloc, parts.path.rstrip("/"), "", ""))
        self.token = token
        self.timeout = timeout
        self.ssl_context: ssl.SSLContext | None = make_ssl_context(verify, ca_file) if parts.scheme == "https" else None
        headers = {"User-Agent": USER_AGENT, **self.auth_headers()}
        self._client = httpx.AsyncClient(
            base_url=self.url + API_PREFIX,
            headers=headers,
            verify=self.ssl_context if self.ssl_context is not None else True,
            timeout=timeout,
        )

    def auth_headers(self) -> dict[str, str]:
        return {"Authorization": f"Bearer {self.token}"} if self.token else {}

    def websocket_url(self, query: str = "") -> str:
        scheme = "wss" if self.url.startswith("https:") else "ws"
        return scheme + self.url.removeprefix("https").removeprefix("http") + API_PREFIX + "/ws" + query

    async def request(
        self,
        method: str,
        path: str,
        *,
        json: Any = None,
        content: bytes | str | None = None,
        params: Mapping[str, Any] | None = None,
        headers: Mapping[str, str] | None = None,
        request_timeout_s: float | None = None,
        check: bool = True,
    ) -> httpx.Response:
        """One request under /api/v1; raises the mapped Problem for an error answer (unless
        `check` is False)."""
        extra = dict(headers or {})
        if content is not None:
            extra.setdefault("Content-Type", "text/plain")
        try:
            response = await self._client.request(
                method,
                path,
                json=json,
                content=content,
                params=_query(params),
                headers=extra,
                timeout=request_timeout_s if request_timeout_s is not None else self.timeout,
            )
        except httpx.TransportError as e:
            raise GatewayUnreachable(f"{method} {self.url}{API_PREFIX}{path}: {e!r}") from e
        if check:
            raise_for_problem(response)
        return response

    async def json(self, method: str, path: str, **kwargs: Any) -> Any:
        response = await self.request(method, path, **kwargs)
        if response.status_code == 204 or not response.content:
            return None
        try:
            return response.json()
        except ValueError as e:
            raise UnexpectedResponse(response.status_code, response.text) from e

    async def download(
        self,
        path: str,
        target: Path,
        *,
        params: Mapping[str, Any] | None = None,
        request_timeout_s: float | None = None,
    ) -> int:
        """Streams a GET's body into the file `target` (created or replaced) and returns its size;
        raises the mapped Problem for an error answer. A body that ends early (the gateway closes a
        chunked body without its last chunk when it fails midway) raises GatewayUnreachable and
        leaves no file."""
        try:
            async with self._client.stream(
                "GET",
                path,
                params=_query(params),
                timeout=request_timeout_s if request_timeout_s is not None else self.timeout,
            ) as response:
                if response.status_code >= 400:
                    await response.aread()
                    raise_for_problem(response)
                return await _write_body(response, target)
        except httpx.TransportError as e:
            await asyncio.to_thread(target.unlink, missing_ok=True)
            raise GatewayUnreachable(f"GET {self.url}{API_PREFIX}{path}: {e!r}") from e

    async def aclose(self) -> None:
        await self._client.aclose()


async def _write_body(response: httpx.Response, target: Path) -> int:
    """The body into the file, piece by piece as it arrives (file writes off the event loop)."""
    size = 0
    file = await asyncio.to_thread(target.open, "wb")
    try:
        async for piece in response.aiter_bytes():
            await asyncio.to_thread(file.write, piece)
            size += len(piece)
    finally:
        await asyncio.to_thread(file.close)
    return size


def _query(params: Mapping[str, Any] | None) -> dict[str, str] | None:
    """Query values as the gateway reads them: booleans as true/false, None left out."""
    if not params:
        return None
    out: dict[str, str] = {}
    for key, value in params.items():
        if value is None:
            continue
        out[key] = ("true" if value else "false") if isinstance(value, bool) else str(value)
    return out
