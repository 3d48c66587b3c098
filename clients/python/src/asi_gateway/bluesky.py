"""ophyd-async devices for stages behind asi-gateway (install the extra: `asi-gateway[bluesky]`).

    from bluesky import RunEngine
    from ophyd_async.core import init_devices
    from asi_gateway import AsyncGateway
    from asi_gateway.bluesky import GatewayAxis, GatewayXYStage

    RE = RunEngine()
    gateway = AsyncGateway("http://127.0.0.1:8080")
    with init_devices():
        stage = GatewayXYStage(gateway, "sim1")     # stage.x, stage.y
        focus = GatewayAxis(gateway, "sim1", "Z")

- Each axis is Movable (`set` returns a status that completes when the gateway's waited move
  ends, and fails with the gateway's reason: its problem, or `MoveStoppedShort` when a HALT or a
  limit stopped it), Locatable, Readable and Stoppable (HALT on the controller).
- The XY stage is Movable and Locatable too: `set((x, y))` is one MOVE of both axes.
- Readbacks are pushed from the gateway's `controllers/<id>/position` WebSocket topic (one
  subscription per controller, resumed after a dropped connection), never polled.
- `GatewayJobFlyer` runs a gateway job (plate, scan, ring buffer, G-code) as a Bluesky flyer:
  `kickoff` submits it, `complete` ends with it, `collect` yields one event per completed step
  with the target and measured position the gateway recorded, and with `record=True` one event
  per camera trigger with the positions the controller latched at it (the job's recording).

The devices use the AsyncGateway from the RunEngine's event loop (init_devices connects them
there): give them an AsyncGateway that nothing else uses from another loop.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import AsyncIterator, Callable, Mapping, Sequence
from dataclasses import dataclass
from datetime import datetime
from functools import cached_property
from typing import Any

from bluesky.protocols import Collectable, Flyable, Locatable, Location, Stoppable
from event_model import DataKey
from event_model.documents.event import PartialEvent
from ophyd_async.core import (
    AsyncStatus,
    Device,
    DeviceConnector,
    MovableLogic,
    StandardMovable,
    StandardReadable,
    TimeoutCalculator,
    soft_signal_r_and_setter,
    soft_signal_rw,
    wait_for_value,
)
from ophyd_async.core import StandardReadableFormat as Format

from .client import AsyncGateway
from .models import Job, JsonObject
from .positions import PositionFeed
from .problems import GatewayError
from .stage import AsyncStage

# A move whose length the device cannot know in advance gets this long before the gateway gives up.
DEFAULT_MOVE_TIMEOUT_S = 300.0
# How long the readback may trail a move's answer (the gateway polls a moving stage every 100 ms).
READBACK_CATCH_UP_S = 2.0


class MoveStoppedShort(GatewayError):
    """A waited move ended away from its target: a HALT (from anyone) or a limit stopped it."""


class _FeedConnector(DeviceConnector):
    """Connects the device's soft signals, then starts the position feed it reads from."""

    def __init__(self, feed: PositionFeed) -> None:
        self.feed = feed

    async def connect_real(self, device: Device, timeout: float, force_reconnect: bool) -> None:  # noqa: ASYNC109 - ophyd-async's signature
        await super().connect_real(device, timeout, force_reconnect)
        await asyncio.wait_for(self.feed.start(), timeout)


@dataclass
class _GatewayMoveLogic(MovableLogic[float]):
    stage: AsyncStage
    axis: str
    tolerance_um: float
    set_readback: Callable[[float], None]

    async def move(self, new_position: float, timeout: TimeoutCalculator) -> None:  # noqa: ASYNC109 - ophyd-async's
        await self.setpoint.set(new_position)
        timeout_s = timeout()
        result = await self.stage.move(
            {self.axis: new_position},
            wait=True,
            timeout_s=timeout_s if timeout_s is not None else DEFAULT_MOVE_TIMEOUT_S,
        )
        reached = result.positions.get(self.axis)
        if reached is not None:
            await self.readback_shows(reached)
        if not result.arrived(self.tolerance_um):
            raise MoveStoppedShort(
                f"{self.stage.id} {self.axis}: stopped at {reached} um, short of {new_position} um "
                "(a HALT or a limit stopped it)"
            )

    async def readback_shows(self, reached: float) -> None:
        """A read right after set() must show where the stage stopped: wait for the position
        event that says so (it may come just after the move's answer); should none come (the
        feed is reconnecting), take the move's own read-back."""
        try:
            await wait_for_value(
                self.readback, lambda um: abs(um - reached) <= self.tolerance_um, timeout=READBACK_CATCH_UP_S
            )
        except TimeoutError:
            self.set_readback(reached)

    async def stop(self) -> None:
        await self.stage.halt()


class GatewayAxis(StandardReadable, StandardMovable[float]):
    """One motor axis of a gateway controller, in micrometres.

    `readback` (hinted, named as the device) follows the gateway's position events; `setpoint`
    is the last target. `stop()` HALTs the controller, which stops all of its axes."""

    def __init__(
        self,
        gateway: AsyncGateway,
        controller: str,
        axis: str,
        *,
        feed: PositionFeed | None = None,
        tolerance_um: float = 1.0,
        name: str = "",
    ) -> None:
        self.controller = controller
        self.axis = axis.upper()
        self._stage = gateway.stage(controller)
        self._tolerance_um = tolerance_um
        with self.add_children_as_readables(Format.HINTED_SIGNAL):
            self.readback, self._set_readback = soft_signal_r_and_setter(float, 0.0, units="um", precision=2)
        self.setpoint = soft_signal_rw(float, 0.0, units="um", precision=2)
        self.feed = feed if feed is not None else PositionFeed(gateway, controller)
        self.feed.add_listener(self._on_position)
        super().__init__(name=name, connector=_FeedConnector(self.feed))

    def _on_position(self, axis: str, um: float) -> None:
        if axis == self.axis:
            self._set_readback(um)

    @cached_property
    def movable_logic(self) -> _GatewayMoveLogic:
        return _GatewayMoveLogic(
            setpoint=self.setpoint, readback=self.readback, stage=self._stage, axis=self.axis,
            tolerance_um=self._tolerance_um, set_readback=self._set_readback,
        )  # fmt: skip


class GatewayXYStage(StandardReadable, Locatable[tuple[float, float]], Stoppable):
    """A controller's X and Y axes as children `x` and `y`, sharing one position feed. (Its Z,
    or any other axis, is a GatewayAxis of its own: `GatewayAxis(gateway, "sim1", "Z")`.)

    The stage is Movable itself: `set((x, y))` (`bps.mv(stage, (x, y))`) is one MOVE of both
    axes, so the stage goes straight to the point; its status fails like an axis's (the gateway's
    problem, or MoveStoppedShort). `locate()` gives both setpoints and readbacks as (x, y);
    `stop()` HALTs the controller."""

    def __init__(self, gateway: AsyncGateway, controller: str, *, tolerance_um: float = 1.0, name: str = "") -> None:
        self.feed = PositionFeed(gateway, controller)
        self._stage = gateway.stage(controller)
        self._tolerance_um = tolerance_um
        with self.add_children_as_readables():
            self.x = GatewayAxis(gateway, controller, "X", feed=self.feed, tolerance_um=tolerance_um)
            self.y = GatewayAxis(gateway, controller, "Y", feed=self.feed, tolerance_um=tolerance_um)
        super().__init__(name=name)

    @AsyncStatus.wrap
    async def set(self, value: tuple[float, float], timeout: float | None = None) -> None:  # noqa: ASYNC109 - Movable's
        x, y = (float(v) for v in value)
        await self.x.setpoint.set(x)
        await self.y.setpoint.set(y)
        result = await self._stage.move(
            {"X": x, "Y": y}, wait=True, timeout_s=timeout if timeout is not None else DEFAULT_MOVE_TIMEOUT_S
        )
        for axis, reached in ((self.x, result.positions.get("X")), (self.y, result.positions.get("Y"))):
            if reached is not None:
                await axis.movable_logic.readback_shows(reached)
        if not result.arrived(self._tolerance_um):
            raise MoveStoppedShort(
                f"{self._stage.id}: stopped at X={result.positions.get('X')} Y={result.positions.get('Y')} um, "
                f"short of X={x} Y={y} um (a HALT or a limit stopped it)"
            )

    async def locate(self) -> Location[tuple[float, float]]:
        x, y = await self.x.locate(), await self.y.locate()
        return Location(setpoint=(x["setpoint"], y["setpoint"]), readback=(x["readback"], y["readback"]))

    async def stop(self, success: bool = True) -> None:
        await self._stage.halt()


class GatewayJobFlyer(Flyable, Collectable):
    """A gateway job as a Bluesky flyer: `kickoff` submits it (it is running or queued when the
    status completes), `complete` ends when the job does (and fails with JobFailed or
    JobCancelled), `collect` yields one event per completed step: its index, name, and the
    target and measured position of each axis the gateway recorded (array jobs record both).

    With `record=True` (a controller with a report port) the job records its run, and `collect`
    also yields, in a second stream named `<name>_triggers`, one event per trigger the controller
    reported: the frame index and each axis's position latched at that trigger, timed by the
    gateway's receive time. Frames lost (loss markers) are left out: the frame indices say where."""

    def __init__(
        self,
        gateway: AsyncGateway,
        controller: str,
        job_type: str,
        spec: Mapping[str, Any],
        *,
        axes: Sequence[str] = ("X", "Y"),
        record: bool = False,
        name: str = "job",
    ) -> None:
        self._gateway = gateway
        self.controller = controller
        self.job_type = job_type
        self.spec = dict(spec)
        if record:
            self.spec["record"] = True
        self.record = record
        self.axes = [a.upper() for a in axes]
        self._name = name
        self.job: Job | None = None

    @property
    def name(self) -> str:
        return self._name

    @property
    def parent(self) -> None:
        return None

    @AsyncStatus.wrap
    async def kickoff(self) -> None:
        self.job = await self._gateway.jobs.submit(self.controller, self.job_type, self.spec)

    @AsyncStatus.wrap
    async def complete(self) -> None:
        if self.job is None:
            raise RuntimeError(f"{self.name}: complete() before kickoff()")
        self.job = await self._gateway.jobs.wait(self.job.id)

    def describe_collect(self) -> dict[str, dict[str, DataKey]]:
        """One stream, named as the flyer, with a key per step field."""
        source = f"asi-gateway:{self.controller}:{self.job_type}"
        keys: dict[str, DataKey] = {
            f"{self.name}-step": DataKey(source=source, dtype="integer", shape=[]),
            f"{self.name}-step_name": DataKey(source=source, dtype="string", shape=[]),
        }
        for axis in self.axes:
            for kind in ("target", "position"):
                key = f"{self.name}-{axis.lower()}_{kind}"
                keys[key] = DataKey(source=source, dtype="number", shape=[], units="um")
        streams = {self.name: keys}
        if self.record:
            triggers: dict[str, DataKey] = {
                f"{self.name}-frame": DataKey(source=f"{source}:recording", dtype="integer", shape=[])
            }
            for axis in self.axes:
                key = f"{self.name}-{axis.lower()}_trigger"
                triggers[key] = DataKey(source=f"{source}:recording", dtype="number", shape=[], units="um")
            streams[f"{self.name}_triggers"] = triggers
        return streams

    async def collect(self) -> AsyncIterator[PartialEvent]:
        if self.job is None:
            return
        for event in await self._gateway.jobs.events(self.job.id):
            if event.get("type") == "step":
                yield self._partial_event(event)
        if not self.record:
            return
        # Every run's recording (a resumed job has one per run), oldest first.
        recordings = await self._gateway.recordings.list(job=self.job.id)
        for recording in sorted(recordings, key=lambda r: r.started):
            for row in await self._gateway.recordings.rows(recording.id):
                if row.get("loss") is None:
                    yield self._trigger_event(row)

    def _trigger_event(self, row: JsonObject) -> PartialEvent:
        data: dict[str, Any] = {f"{self.name}-frame": row["index"]}
        for axis in self.axes:
            value = row.get(f"{axis}_um")
            data[f"{self.name}-{axis.lower()}_trigger"] = float("nan") if value is None else float(value)
        when = row["time_us"] / 1e6
        return PartialEvent(data=data, timestamps=dict.fromkeys(data, when), time=when)

    def _partial_event(self, step: JsonObject) -> PartialEvent:
        data: dict[str, Any] = {f"{self.name}-step": step["index"], f"{self.name}-step_name": step["name"]}
        for axis in self.axes:
            for kind in ("target", "position"):
                value = (step.get(kind) or {}).get(axis)
                data[f"{self.name}-{axis.lower()}_{kind}"] = float("nan") if value is None else float(value)
        # When the step ended, as the gateway recorded it (steps stored by an older one lack it).
        at = step.get("at")
        when = datetime.fromisoformat(at).timestamp() if isinstance(at, str) else time.time()
        return PartialEvent(data=data, timestamps=dict.fromkeys(data, when), time=when)
