"""Subscriptions: resumption after a connection cut (no event lost, none twice) and the gateway's
gap messages, sync and asyncio. The cut is a real one: the client talks to the gateway through a
TCP proxy (tests/tcp_proxy.py) that closes every live connection."""

from __future__ import annotations

import asyncio
from collections.abc import Iterator

import pytest
from gateway_process import TOKENS, RunningGateway
from tcp_proxy import CuttableProxy

from asi_gateway import AsyncGateway, Event, Gap, Gateway, Message

# Six wells with a dwell: a job that runs a few seconds and publishes an event per step.
SLOW_GRID = {
    "grid": {"columns": 3, "rows": 2, "column_step_mm": 0.1, "row_step_mm": -0.1},
    "a1": "current",
    "dwell_ms": 400,
    "mode": "host",
}
TERMINAL = ("succeeded", "failed", "cancelled")


@pytest.fixture
def proxy(gateway: RunningGateway) -> Iterator[CuttableProxy]:
    p = CuttableProxy(gateway.port)
    yield p
    p.close()


def is_final(message: Message) -> bool:
    return isinstance(message, Event) and message.data.get("type") == "state" and message.data["state"] in TERMINAL


def test_async_subscription_resumes_after_a_cut_without_losing_events(
    gateway: RunningGateway, proxy: CuttableProxy
) -> None:
    async def scenario() -> None:
        async with AsyncGateway(proxy.url, token=TOKENS["operator"]) as gw:
            job = await gw.jobs.submit("sim2", "array", SLOW_GRID)
            topic = "jobs/" + job.id
            seqs: list[int] = []
            async with gw.subscribe(topic, resume={topic: 0}) as sub:
                async for message in sub:
                    assert isinstance(message, Event), f"no gap expected: {message}"
                    seqs.append(message.seq)
                    if len(seqs) == 2:
                        assert proxy.cut() >= 2  # the WebSocket (and any idle HTTP connection)
                    if is_final(message):
                        break
                assert sub.reconnects == 1
            stored = await gw.jobs.events(job.id)
            assert seqs == list(range(1, len(stored) + 1)), f"got {seqs} for {len(stored)} stored events"

    asyncio.run(scenario())


def test_sync_subscription_resumes_after_a_cut(gateway: RunningGateway, proxy: CuttableProxy) -> None:
    with Gateway(proxy.url, token=TOKENS["operator"]) as gw:
        job = gw.jobs.submit("sim1", "array", SLOW_GRID)
        topic = "jobs/" + job.id
        seqs: list[int] = []
        with gw.subscribe(topic, resume={topic: 0}) as sub:
            for message in sub:
                assert isinstance(message, Event), f"no gap expected: {message}"
                seqs.append(message.seq)
                if len(seqs) in (2, 5):  # twice
                    proxy.cut()
                if is_final(message):
                    break
            assert sub.reconnects == 2
            assert sub.last_seq[topic] == seqs[-1]
        assert seqs == list(range(1, len(gw.jobs.events(job.id)) + 1))


def test_gap_from_the_gateway_is_reported(operator: Gateway) -> None:
    topic = "controllers/sim1/position"
    stage = operator.stage("sim1")
    # Enough position events that the oldest have left the topic's small replay buffer.
    with operator.subscribe(topic) as sub:
        stage.move_relative({"X": 6000}, wait=True)
        stage.move_relative({"X": -6000}, wait=True)
        last = 0
        while True:
            try:
                message = sub.next(timeout_s=1.5)
            except TimeoutError:
                break  # idle: no more position events
            assert isinstance(message, Event)
            last = message.seq
    assert last > 20
    with operator.subscribe(topic, resume={topic: 1}) as resumed:
        first = resumed.next(timeout_s=30)
        assert isinstance(first, Gap), f"expected a gap, got {first}"
        assert first.topic == topic and first.from_seq == 2
        assert first.missed == first.to_seq - first.from_seq + 1 > 0
        after = resumed.next(timeout_s=30)
        assert isinstance(after, Event) and after.seq == first.to_seq + 1
        assert resumed.last_seq[topic] == after.seq


def test_async_wildcard_subscription_gets_every_controller(gateway: RunningGateway) -> None:
    async def scenario() -> None:
        async with (
            AsyncGateway(gateway.url, token=TOKENS["viewer"]) as gw,
            gw.subscribe("controllers/+/state") as sub,
        ):
            seen: set[str] = set()
            while seen != {"cam1", "ext1", "sim1", "sim2"}:
                message = await asyncio.wait_for(sub.__anext__(), 30)
                assert isinstance(message, Event) and message.data["state"] == "connected"
                seen.add(message.data["id"])
            assert sub.hello["role"] == "viewer"

    asyncio.run(scenario())
