"""A TCP proxy on loopback whose live connections can be cut, to drop a client's WebSocket the
way a network does (the gateway and the client each see their socket close) while new
connections still get through. With a server SSL context it also terminates TLS in front of the
plain-HTTP gateway, for the TLS tests. Runs its own event loop in a thread, so sync and async
tests use it alike."""

from __future__ import annotations

import asyncio
import contextlib
import ssl
import threading


class CuttableProxy:
    def __init__(self, target_port: int, tls: ssl.SSLContext | None = None) -> None:
        self.target_port = target_port
        self.tls = tls
        self.port = 0
        self.cuts = 0
        self._loop = asyncio.new_event_loop()
        self._writers: set[asyncio.StreamWriter] = set()
        self._ready = threading.Event()
        self._thread = threading.Thread(target=self._run, name="cuttable-proxy", daemon=True)
        self._thread.start()
        if not self._ready.wait(30):
            raise RuntimeError("the proxy did not start")

    @property
    def url(self) -> str:
        return f"{'https' if self.tls else 'http'}://127.0.0.1:{self.port}"

    def _run(self) -> None:
        asyncio.set_event_loop(self._loop)
        server = self._loop.run_until_complete(asyncio.start_server(self._serve, "127.0.0.1", 0, ssl=self.tls))
        self.port = server.sockets[0].getsockname()[1]
        self._ready.set()
        self._loop.run_forever()
        server.close()

    async def _serve(self, client_r: asyncio.StreamReader, client_w: asyncio.StreamWriter) -> None:
        try:
            upstream_r, upstream_w = await asyncio.open_connection("127.0.0.1", self.target_port)
        except OSError:
            client_w.close()
            return
        self._writers.update((client_w, upstream_w))
        await asyncio.gather(self._pipe(client_r, upstream_w), self._pipe(upstream_r, client_w))
        self._writers.difference_update((client_w, upstream_w))

    @staticmethod
    async def _pipe(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        with contextlib.suppress(OSError, asyncio.CancelledError):
            while data := await reader.read(65536):
                writer.write(data)
                await writer.drain()
        writer.close()

    def cut(self) -> int:
        """Closes every live connection at once (both sides, no WebSocket close handshake);
        returns how many sockets were closed."""

        async def cut_all() -> int:
            writers = list(self._writers)
            for w in writers:
                _abort(w)
            self._writers.clear()
            return len(writers)

        closed = asyncio.run_coroutine_threadsafe(cut_all(), self._loop).result(30)
        self.cuts += 1
        return closed

    def close(self) -> None:
        async def shutdown() -> None:
            for w in list(self._writers):
                _abort(w)
            tasks = [t for t in asyncio.all_tasks() if t is not asyncio.current_task()]
            for t in tasks:
                t.cancel()
            await asyncio.gather(*tasks, return_exceptions=True)

        asyncio.run_coroutine_threadsafe(shutdown(), self._loop).result(30)
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(10)


def _abort(writer: asyncio.StreamWriter) -> None:
    """Closes a connection at once. An SSL transport already closing has lost its socket, and
    Python 3.11's abort() then fails inside asyncio: leave those alone."""
    if not writer.transport.is_closing():
        with contextlib.suppress(AttributeError):
            writer.transport.abort()
