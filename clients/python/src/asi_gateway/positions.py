"""A controller's positions kept current from the gateway's position topic (pushed over the
WebSocket, resumed after a dropped connection), for the device integrations (Bluesky,
pymmcore-plus) that must answer "where is it" at once and without polling the gateway."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable, Mapping

from .client import AsyncGateway
from .subscription import Event, Subscription

PositionListener = Callable[[str, float], None]


class PositionFeed:
    """Started once, however many devices share it; the first values come from the controller's
    state, so `latest` is right as soon as `start()` returned. Listeners get (axis, um) for every
    axis of every position event, on the event loop's thread."""

    def __init__(self, gateway: AsyncGateway, controller: str) -> None:
        self.gateway = gateway
        self.controller = controller
        self.latest: dict[str, float] = {}
        self._listeners: list[PositionListener] = []
        self._subscription: Subscription | None = None
        self._task: asyncio.Task[None] | None = None
        self._lock = asyncio.Lock()

    def add_listener(self, listener: PositionListener) -> None:
        self._listeners.append(listener)

    @property
    def running(self) -> bool:
        return self._task is not None and not self._task.done()

    async def start(self) -> None:
        async with self._lock:
            if self.running:
                return
            state = await self.gateway.get_controller(self.controller)
            self._apply(state.positions)
            subscription = self.gateway.subscribe(f"controllers/{self.controller}/position")
            await subscription.__aenter__()
            self._subscription = subscription
            self._task = asyncio.create_task(self._follow(subscription), name=f"positions-{self.controller}")

    async def _follow(self, subscription: Subscription) -> None:
        async for message in subscription:
            if isinstance(message, Event):
                self._apply({a["axis"]: a["position_um"] for a in message.data["axes"]})

    def _apply(self, positions: Mapping[str, float | None]) -> None:
        for axis, um in positions.items():
            if um is None:
                continue
            self.latest[axis] = float(um)
            for listener in self._listeners:
                listener(axis, float(um))

    async def wait_for(self, target: Mapping[str, float], tolerance_um: float, timeout_s: float) -> bool:
        """Whether `latest` came within `tolerance_um` of `target` on every axis in time."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout_s
        while not all(abs(self.latest.get(a, float("inf")) - um) <= tolerance_um for a, um in target.items()):
            if loop.time() >= deadline:
                return False
            await asyncio.sleep(0.02)
        return True

    async def stop(self) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
            self._task = None
        if self._subscription is not None:
            await self._subscription.close()
            self._subscription = None
