"""Subscriptions to the gateway's event topics over /api/v1/ws, as async iterators that survive a
dropped connection.

The gateway numbers every topic's events (`seq` 1, 2, 3 ...) and, when a client subscribes with
`"resume": {topic: last_seq}`, sends what the client missed from its replay buffer or, when that
is gone, an explicit `gap` message with the count. A Subscription remembers the last `seq` it
delivered per topic; when the connection drops it reconnects (0.5 s doubling to 10 s, as the
dashboard does) and subscribes again with those numbers, so nothing is lost silently: either the
events come, or a `Gap` says how many did not. Events it already delivered are never delivered
twice.

A `seq` that jumps by more than one on a position or state topic is not a loss: those topics keep
the latest value only (the gateway coalesces positions), so only the gateway's `gap` messages
are gaps.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import json
import ssl
from collections.abc import AsyncIterator, Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import websockets
from websockets.asyncio.client import ClientConnection, connect

from .problems import GatewayError, GatewayUnreachable, Unavailable, problem_from_body
from .transport import Transport

JsonObject = dict[str, Any]

FIRST_RETRY_S = 0.5
MAX_RETRY_S = 10.0


@dataclass(frozen=True)
class Event:
    """One event of a topic: `data` is the payload (a controller state, a position, a job event)."""

    topic: str
    seq: int
    time: str
    time_ms: int
    data: JsonObject


@dataclass(frozen=True)
class Gap:
    """Events `from_seq`..`to_seq` of `topic` (`missed` of them) will never come: the gateway's
    replay buffer no longer had them, or this client fell behind."""

    topic: str
    missed: int
    from_seq: int
    to_seq: int
    time: str


@dataclass(frozen=True)
class Retired:
    """The topic left the gateway (an ended job's topic, some minutes after its end): nothing more
    comes on it. Its history is in GET /api/v1/jobs/{id}/events."""

    topic: str
    last_seq: int
    time: str


Message = Event | Gap | Retired


def parse_message(m: JsonObject) -> Message | None:
    """An event-hub message, or None for anything else (answers, pongs)."""
    kind = m.get("type")
    if kind == "event":
        return Event(m["topic"], m["seq"], m["time"], m.get("time_ms", 0), m["data"])
    if kind == "gap":
        return Gap(m["topic"], m["missed"], m["from"], m["to"], m["time"])
    if kind == "retired":
        return Retired(m["topic"], m["last_seq"], m["time"])
    return None


class Subscription:
    """`async with gateway.subscribe([...]) as sub: async for message in sub: ...`

    Yields Event, Gap and Retired messages in the order the gateway sent them. `last_seq` maps
    each topic seen to the last sequence number delivered; `reconnects` counts the connections
    made again after a drop; `hello` is the gateway's first message on the current connection.
    """

    def __init__(
        self,
        transport: Transport,
        topics: Iterable[str],
        *,
        resume: Mapping[str, int] | None = None,
        max_rate_hz: float | None = None,
        batch_ms: int | None = None,
        reconnect: bool = True,
        give_up_after_s: float | None = None,
    ) -> None:
        self.topics = list(topics)
        if not self.topics:
            raise ValueError("subscribe to at least one topic")
        self.last_seq: dict[str, int] = dict(resume or {})
        self.reconnects = 0
        self.hello: JsonObject = {}
        self._transport = transport
        self._max_rate_hz = max_rate_hz
        self._batch_ms = batch_ms
        self._reconnect = reconnect
        self._give_up_after_s = give_up_after_s
        self._retired: set[str] = set()
        self._ids = itertools.count(1)
        self._ws: ClientConnection | None = None
        self._pending: list[JsonObject] = []  # messages of a batch not yet handed out
        self._closed = False

    async def __aenter__(self) -> Subscription:
        await self._connect()
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()

    def __aiter__(self) -> AsyncIterator[Message]:
        return self

    async def __anext__(self) -> Message:
        while True:
            if self._closed:
                raise StopAsyncIteration
            if not self._pending:
                if self._ws is None:
                    await self._connect_again()
                assert self._ws is not None
                try:
                    text = await self._ws.recv()
                except (websockets.ConnectionClosed, OSError) as e:
                    if self._closed:
                        raise StopAsyncIteration from None
                    if not self._reconnect:
                        raise GatewayUnreachable(f"the WebSocket closed: {e!r}") from e
                    await self._drop()
                    continue
                self._pending = _unbatch(json.loads(text))
            message = self._take(self._pending.pop(0))
            if message is not None:
                return message

    async def close(self) -> None:
        self._closed = True
        await self._drop()

    # ---- internals ---------------------------------------------------------------------------

    def _take(self, raw: JsonObject) -> Message | None:
        """The message to hand out, or None for one that is not new (a replayed duplicate after a
        reconnect, a second `retired`) or not an event."""
        if raw.get("type") == "error":
            raise problem_from_body(raw["problem"])
        message = parse_message(raw)
        if message is None:
            return None
        topic = message.topic
        if topic in self._retired:
            return None
        last = self.last_seq.get(topic, 0)
        if isinstance(message, Event):
            if message.seq <= last:
                return None
            self.last_seq[topic] = message.seq
        elif isinstance(message, Gap):
            if message.to_seq <= last:
                return None
            self.last_seq[topic] = message.to_seq
        else:
            self._retired.add(topic)
        return message

    async def _connect(self) -> None:
        """Opens a connection and subscribes on it, resuming every topic seen so far."""
        ws = await self._open()
        try:
            self._pending = await self._subscribe(ws)
        except (websockets.ConnectionClosed, OSError) as e:
            await ws.close()
            raise GatewayUnreachable(f"the WebSocket closed while subscribing: {e!r}") from e
        except BaseException:
            await ws.close()
            raise
        self._ws = ws

    async def _open(self) -> ClientConnection:
        query = f"?batch_ms={self._batch_ms}" if self._batch_ms is not None else ""
        ssl_context: ssl.SSLContext | None = self._transport.ssl_context
        try:
            return await connect(
                self._transport.websocket_url(query),
                additional_headers=self._transport.auth_headers(),
                ssl=ssl_context,
                open_timeout=self._transport.timeout,
                max_size=None,
                # Room for bursts (report streams) before reading stops and the gateway counts gaps.
                max_queue=1024,
            )
        except websockets.InvalidStatus as e:
            # The upgrade was answered with an error: its problem+json body says which.
            raise _refusal(e) from e
        except (TimeoutError, OSError, websockets.InvalidHandshake) as e:
            raise GatewayUnreachable(f"WebSocket {self._transport.websocket_url()}: {e!r}") from e

    async def _subscribe(self, ws: ClientConnection) -> list[JsonObject]:
        """Reads the hello, subscribes, and returns the events that came before the answer (a
        latest-value topic's current value may)."""
        self.hello = json.loads(await ws.recv())
        request_id = f"sub-{next(self._ids)}"
        request: JsonObject = {"op": "subscribe", "id": request_id, "topics": self.topics}
        resume = {t: s for t, s in self.last_seq.items() if t not in self._retired}
        if resume:
            request["resume"] = resume
        if self._max_rate_hz is not None:
            request["max_rate_hz"] = self._max_rate_hz
        await ws.send(json.dumps(request))
        early: list[JsonObject] = []
        while True:
            answer = json.loads(await ws.recv())
            if answer.get("id") == request_id and answer.get("type") in ("subscribed", "error"):
                break
            early.extend(_unbatch(answer))
        if answer["type"] == "error":
            raise problem_from_body(answer["problem"])
        return early

    async def _connect_again(self) -> None:
        """Reconnects with backoff until it works (or `give_up_after_s` passed)."""
        loop = asyncio.get_running_loop()
        started = loop.time()
        wait = FIRST_RETRY_S
        while True:
            try:
                await self._connect()
                self.reconnects += 1
                return
            except (GatewayUnreachable, Unavailable):  # down, restarting, or full for the moment
                if self._give_up_after_s is not None and loop.time() - started > self._give_up_after_s:
                    raise
            await asyncio.sleep(wait)
            wait = min(wait * 2, MAX_RETRY_S)

    async def _drop(self) -> None:
        ws, self._ws = self._ws, None
        self._pending = []
        if ws is not None:
            with contextlib.suppress(Exception):
                await ws.close()


def _refusal(error: websockets.InvalidStatus) -> GatewayError:
    try:
        body = json.loads(error.response.body or b"")
    except ValueError:
        body = None
    if isinstance(body, dict) and "type" in body:
        return problem_from_body(body)
    return GatewayError(f"the WebSocket upgrade was refused: {error}")


def _unbatch(message: JsonObject) -> list[JsonObject]:
    if message.get("type") == "batch":
        return list(message["events"])
    return [message]
