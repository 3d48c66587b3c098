"""The ophyd-async devices (asi_gateway.bluesky) against the real gateway: a grid scan with one of
ophyd-async's simulated detectors in a RunEngine, a plate as a fly scan (and one that records each
camera trigger's position), readbacks pushed from
the position topic, set() failing with the gateway's reason (a HALT from another client, a
lease), locate and stop."""

from __future__ import annotations

import asyncio
import threading
import time
from collections.abc import Iterator
from typing import Any

import bluesky.plan_stubs as bps
import bluesky.plans as bp
import bluesky.preprocessors as bpp
import pytest
from bluesky import RunEngine
from bluesky.run_engine import call_in_bluesky_event_loop
from event_model import unpack_event_page
from gateway_process import TOKENS, RunningGateway
from ophyd_async.core import init_devices
from ophyd_async.sim import PatternGenerator, SimPointDetector

from asi_gateway import AsyncGateway, Gateway, Leased
from asi_gateway.bluesky import GatewayAxis, GatewayJobFlyer, GatewayXYStage, MoveStoppedShort
from asi_gateway.positions import PositionFeed

TOLERANCE_UM = 1.0


@pytest.fixture
def run_engine() -> Iterator[RunEngine]:
    engine = RunEngine({}, call_returns_result=True)
    yield engine
    engine.loop.call_soon_threadsafe(engine.loop.stop)


def documents_of(run_engine: RunEngine, plan: Any) -> list[tuple[str, dict[str, Any]]]:
    """The run's documents, event pages unpacked into events."""
    docs: list[tuple[str, dict[str, Any]]] = []

    def keep(name: str, doc: Any) -> None:
        if name == "event_page":
            docs.extend(("event", dict(event)) for event in unpack_event_page(doc))
        else:
            docs.append((name, dict(doc)))

    run_engine(plan, keep)
    return docs


def close_in_loop(gateway: AsyncGateway, *feeds: PositionFeed) -> None:
    """Ends the position feeds and the client in the RunEngine's loop, where they run."""

    async def close() -> None:
        for feed in feeds:
            await feed.stop()
        await gateway.aclose()

    call_in_bluesky_event_loop(close())


def test_grid_scan_documents_carry_the_stage_positions(gateway: RunningGateway, run_engine: RunEngine) -> None:
    gw = AsyncGateway(gateway.url, token=TOKENS["operator"])
    with init_devices():
        stage = GatewayXYStage(gw, "sim1")
        det = SimPointDetector(PatternGenerator())  # type: ignore[no-untyped-call]
    assert stage.x.name == "stage-x"
    docs = documents_of(run_engine, bp.grid_scan([det], stage.x, 0, 400, 3, stage.y, 0, -200, 2))
    events = [doc for name, doc in docs if name == "event"]
    assert len(events) == 6
    grid = {(x, y) for x in (0.0, 200.0, 400.0) for y in (0.0, -200.0)}
    seen = set()
    for event in events:
        x, y = event["data"]["stage-x"], event["data"]["stage-y"]
        target = min(grid, key=lambda p: abs(p[0] - x) + abs(p[1] - y))
        assert abs(target[0] - x) <= TOLERANCE_UM and abs(target[1] - y) <= TOLERANCE_UM, (x, y)
        seen.add(target)
        assert "det-channel-1-value" in event["data"]
    assert seen == grid
    (stop,) = [doc for name, doc in docs if name == "stop"]
    assert stop["exit_status"] == "success"
    close_in_loop(gw, stage.feed)
    with Gateway(gateway.url, token=TOKENS["viewer"]) as check:
        positions = check.get_controller("sim1").positions
    assert abs((positions["Y"] or 0) + 200) <= TOLERANCE_UM


def test_fly_scan_of_a_plate_collects_every_well(gateway: RunningGateway, run_engine: RunEngine) -> None:
    gw = AsyncGateway(gateway.url, token=TOKENS["operator"])
    grid = {"columns": 3, "rows": 2, "column_step_mm": 0.3, "row_step_mm": -0.3}
    flyer = GatewayJobFlyer(gw, "sim2", "array", {"grid": grid, "a1": {"X": 0, "Y": 0}, "mode": "host"}, name="plate")
    docs = documents_of(run_engine, bp.fly([flyer]))
    events = [doc for name, doc in docs if name == "event"]
    assert [e["data"]["plate-step_name"] for e in events] == ["A1", "A2", "A3", "B3", "B2", "B1"]
    for event in events:
        data = event["data"]
        assert abs(data["plate-x_position"] - data["plate-x_target"]) <= TOLERANCE_UM
        assert abs(data["plate-y_position"] - data["plate-y_target"]) <= TOLERANCE_UM
    assert {round(e["data"]["plate-x_target"]) for e in events} == {0, 300, 600}
    assert flyer.job is not None and flyer.job.state == "succeeded"
    close_in_loop(gw)


def test_a_recording_fly_scan_collects_each_triggers_positions(gateway: RunningGateway, run_engine: RunEngine) -> None:
    # A plate advanced by camera triggers on cam1 (a report port): each trigger is an event of the
    # "plate_triggers" stream with the position the controller latched, the well the stage stood at.
    gw = AsyncGateway(gateway.url, token=TOKENS["operator"])
    grid = {"columns": 3, "rows": 1, "column_step_mm": 0.5, "row_step_mm": -0.5}
    spec = {"grid": grid, "a1": {"X": 0, "Y": 0}, "mode": "host", "advance": "ttl"}
    flyer = GatewayJobFlyer(gw, "cam1", "array", spec, record=True, name="plate")

    def camera() -> None:  # triggers the two advances while the plan runs
        with Gateway(gateway.url, token=TOKENS["viewer"]) as watcher:
            for done in (1, 2):
                deadline = time.monotonic() + 60
                while time.monotonic() < deadline:
                    jobs, _ = watcher.jobs.list(controller="cam1", state="running")
                    if jobs and jobs[0].progress.steps_done == done and jobs[0].progress.waiting_for == "ttl":
                        break
                    time.sleep(0.1)
                gateway.cam.pulse(1, 10)

    trigger_thread = threading.Thread(target=camera)
    trigger_thread.start()
    try:
        docs = documents_of(run_engine, bp.fly([flyer]))
    finally:
        trigger_thread.join()
    streams = {doc["uid"]: doc["name"] for name, doc in docs if name == "descriptor"}
    events = [doc for name, doc in docs if name == "event"]
    steps = [e["data"] for e in events if streams[e["descriptor"]] == "plate"]
    triggers = [e["data"] for e in events if streams[e["descriptor"]] == "plate_triggers"]
    assert [s["plate-step_name"] for s in steps] == ["A1", "A2", "A3"]
    assert [t["plate-frame"] for t in triggers] == [0, 1]
    for k in (0, 1):
        assert abs(triggers[k]["plate-x_trigger"] - steps[k]["plate-x_position"]) <= TOLERANCE_UM
    assert flyer.job is not None and flyer.job.state == "succeeded"
    close_in_loop(gw)


def test_set_fails_with_the_gateways_reason_and_readback_is_pushed(gateway: RunningGateway) -> None:
    async def scenario() -> None:
        async with (
            AsyncGateway(gateway.url, token=TOKENS["operator"]) as gw,
            AsyncGateway(gateway.url, token=TOKENS["operator"]) as other,
        ):
            x = GatewayAxis(gw, "sim2", "X", name="x")
            await x.connect()
            start = await x.readback.get_value()
            status = x.set(start + 40000)
            # The readback follows the move while set() runs: pushed by the position feed.
            deadline = time.monotonic() + 30
            while await x.readback.get_value() < start + 500:
                assert time.monotonic() < deadline, "the readback never moved"
                await asyncio.sleep(0.05)
            assert not status.done
            await other.stage("sim2").halt()  # another client
            with pytest.raises(MoveStoppedShort, match="short of"):
                await status
            assert not status.success
            location = await x.locate()
            assert location["setpoint"] == start + 40000
            assert start + 500 <= location["readback"] < start + 40000 - 1000
            # Back, and locate agrees with the gateway.
            await x.set(start)
            location = await x.locate()
            assert abs(location["readback"] - start) <= TOLERANCE_UM
            await x.feed.stop()

    asyncio.run(scenario())


def test_the_xy_stage_moves_both_axes_at_once_and_fails_like_an_axis(
    gateway: RunningGateway, run_engine: RunEngine
) -> None:
    gw = AsyncGateway(gateway.url, token=TOKENS["operator"])
    with init_devices():
        stage = GatewayXYStage(gw, "sim2")
    targets = [(300.0, -300.0), (900.0, 600.0)]

    def visit() -> Any:
        for target in targets:
            yield from bps.mv(stage, target)
            yield from bps.trigger_and_read([stage])

    docs = documents_of(run_engine, bpp.run_wrapper(visit()))  # type: ignore[no-untyped-call]
    points = [(e["data"]["stage-x"], e["data"]["stage-y"]) for name, e in docs if name == "event"]
    for (x, y), (tx, ty) in zip(points, targets, strict=True):
        assert abs(x - tx) <= TOLERANCE_UM and abs(y - ty) <= TOLERANCE_UM, (x, y)

    async def halted_midway() -> None:
        async with AsyncGateway(gateway.url, token=TOKENS["operator"]) as other:
            status = stage.set((40000.0, 30000.0))
            deadline = time.monotonic() + 30
            while await stage.x.readback.get_value() < 2000:
                assert time.monotonic() < deadline, "the stage never moved"
                await asyncio.sleep(0.05)
            await other.stage("sim2").halt()
            with pytest.raises(MoveStoppedShort, match="short of X=40000"):
                await status
            # One MOVE: both axes were under way when the HALT came.
            assert await stage.y.readback.get_value() > 1000
            where = await stage.locate()
            assert where["setpoint"] == (40000.0, 30000.0)
            assert 2000 <= where["readback"][0] < 39000 and where["readback"][1] > 1000

    call_in_bluesky_event_loop(halted_midway())
    close_in_loop(gw, stage.feed)


def test_stop_halts_and_a_lease_refuses(gateway: RunningGateway) -> None:
    async def scenario() -> None:
        async with (
            AsyncGateway(gateway.url, token=TOKENS["operator"]) as gw,
            AsyncGateway(gateway.url, token=TOKENS["admin"]) as other,
        ):
            z = GatewayAxis(gw, "ext1", "Z", name="z")
            await z.connect()
            start = await z.readback.get_value()
            status = z.set(start + 30000)
            deadline = time.monotonic() + 30
            while await z.readback.get_value() < start + 200:
                assert time.monotonic() < deadline, "the readback never moved"
                await asyncio.sleep(0.05)
            await z.stop()  # type: ignore[no-untyped-call]  # Stoppable: HALT
            with pytest.raises(RuntimeError, match="stopped"):
                await status
            state = await other.get_controller("ext1")
            deadline = time.monotonic() + 30
            while state.busy:
                assert time.monotonic() < deadline
                await asyncio.sleep(0.1)
                state = await other.get_controller("ext1")
            assert (state.positions["Z"] or 0) < start + 30000 - 1000
            async with other.stage("ext1").lease(ttl_s=30):
                with pytest.raises(Leased):
                    await z.set(start)
            await z.feed.stop()

    asyncio.run(scenario())
