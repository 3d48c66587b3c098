"""Moves, HALT and HALT ALL against the real gateway on simulated controllers."""

from __future__ import annotations

import asyncio
import threading
import time
from collections.abc import Callable

from gateway_process import TOKENS, RunningGateway

from asi_gateway import AsyncGateway, ControllerState, Gateway, MoveResult, Stage

TOLERANCE_UM = 1.0


def test_move_with_wait_ends_at_its_target(operator: Gateway) -> None:
    stage = operator.stage("sim2")
    result = stage.move({"X": 1500, "Y": -250.5}, wait=True)
    assert result.waited and result.arrived(TOLERANCE_UM)
    assert abs(result.positions["X"] - 1500) <= TOLERANCE_UM
    assert abs(result.positions["Y"] + 250.5) <= TOLERANCE_UM
    # The gateway's snapshot catches up at its next poll.
    snapshot_shows(stage, "X = 1500", lambda s: abs((s.positions["X"] or 0) - 1500) <= TOLERANCE_UM)


def test_relative_moves_add_up(operator: Gateway) -> None:
    stage = operator.stage("sim2")
    stage.move({"X": 0, "Z": 0}, wait=True)
    stage.move_relative({"X": 300}, wait=True)
    result = stage.move_relative({"X": 200, "Z": -50}, wait=True)
    assert abs(result.positions["X"] - 500) <= TOLERANCE_UM
    assert abs(result.positions["Z"] + 50) <= TOLERANCE_UM
    # A relative move has no absolute target to check arrival against.
    assert result.target is None


def snapshot_shows(stage: Stage, what: str, check: Callable[[ControllerState], bool]) -> None:
    """The gateway's snapshot follows a command at its next poll: wait for it."""
    deadline = time.monotonic() + 30
    while not check(stage.state()):
        assert time.monotonic() < deadline, f"{stage.id}: the state never showed {what}"
        time.sleep(0.1)


def test_zero_here_speed_home_ttl(operator: Gateway) -> None:
    stage = operator.stage("sim2")
    stage.move({"X": 1000}, wait=True)
    assert stage.zero().operation == "zero"
    snapshot_shows(stage, "X = 0", lambda s: abs(s.positions["X"] or 0) <= TOLERANCE_UM)
    assert stage.here({"X": 250}).operation == "here"
    snapshot_shows(stage, "X = 250", lambda s: abs((s.positions["X"] or 0) - 250) <= TOLERANCE_UM)
    assert stage.speed({"X": 2.5}).operation == "speed"
    assert stage.ttl(out0_mode=1).operation == "ttl"
    snapshot_shows(stage, "out0_mode 1", lambda s: s.ttl["out0_mode"] == 1)
    stage.ttl(out0_mode=0)
    assert stage.home(["Z"]).operation == "home"
    stage.halt()


def wait_busy(gw: Gateway, controller: str) -> None:
    deadline = time.monotonic() + 30
    while not gw.get_controller(controller).busy:
        assert time.monotonic() < deadline, f"{controller} never started moving"
        time.sleep(0.05)


def test_halt_from_another_client_stops_a_waited_move(gateway: RunningGateway, operator: Gateway) -> None:
    stage = operator.stage("sim1")
    stage.move({"X": 0}, wait=True)
    outcome: dict[str, MoveResult] = {}
    mover = threading.Thread(target=lambda: outcome.update(r=stage.move({"X": 60000}, wait=True, timeout_s=120)))
    mover.start()
    with Gateway(gateway.url, token=TOKENS["operator"]) as other:
        wait_busy(other, "sim1")
        assert other.stage("sim1").halt().operation == "halt"
    mover.join(60)
    assert not mover.is_alive()
    result = outcome["r"]
    assert result.waited and not result.arrived(TOLERANCE_UM)
    assert 0 < result.positions["X"] < 60000 - 1000
    assert not stage.state().busy


def test_async_move_and_halt_all(gateway: RunningGateway) -> None:
    async def scenario() -> None:
        async with AsyncGateway(gateway.url, token=TOKENS["operator"]) as gw:
            result = await gw.stage("ext1").move({"Y": 800}, wait=True)
            assert result.arrived(TOLERANCE_UM)
            for cid in ("ext1", "sim1", "sim2"):
                await gw.stage(cid).move_relative({"X": 50000})
            halted = await gw.halt_all()
            assert set(halted) == {"cam1", "ext1", "sim1", "sim2"}
            assert all(r.operation == "halt" for r in halted.values())
            # Every stage stops short of its 50 mm.
            deadline = time.monotonic() + 30
            while any(c.busy for c in await gw.list_controllers()):
                assert time.monotonic() < deadline, "still moving after HALT ALL"
                await asyncio.sleep(0.1)
            for state in await gw.list_controllers():
                assert (state.positions["X"] or 0) < 40000, state.id

    asyncio.run(scenario())
