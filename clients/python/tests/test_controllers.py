"""Controllers: list, get, wait until connected (sync and asyncio), against the real gateway."""

from __future__ import annotations

import asyncio

import pytest
from gateway_process import TOKENS, RunningGateway

from asi_gateway import AsyncGateway, Gateway, UnknownController


def test_list_and_get(operator: Gateway) -> None:
    controllers = operator.list_controllers()
    assert [c.id for c in controllers] == ["ext1", "cam1", "sim1", "sim2"]
    assert all(c.connected for c in controllers)
    sim1 = operator.get_controller("sim1")
    assert sim1.identity is not None and sim1.identity.build == "STD_XYZ_SCAN"
    assert "array" in sim1.identity.modules
    assert [a.axis for a in sim1.axes] == ["X", "Y", "Z"]
    assert set(sim1.positions) == {"X", "Y", "Z"}
    assert sim1.raw["id"] == "sim1"


def test_whoami_names_the_token(gateway: RunningGateway) -> None:
    with Gateway(gateway.url, token=TOKENS["viewer"]) as gw:
        assert gw.whoami() == {"client": "viewer1", "role": "viewer", "auth": "token"}


def test_wait_connected_follows_an_unplugged_controller(gateway: RunningGateway, operator: Gateway) -> None:
    assert [c.id for c in operator.wait_connected(timeout_s=30)] == ["ext1", "cam1", "sim1", "sim2"]
    assert gateway.ext.control("unplug") == "ok"
    try:
        with pytest.raises(TimeoutError, match="ext1"):
            operator.wait_connected("ext1", timeout_s=1.5)
    finally:
        assert gateway.ext.control("replug") == "ok"
    (state,) = operator.wait_connected("ext1", timeout_s=60)
    assert state.id == "ext1" and state.connected


def test_async_list_get_wait(gateway: RunningGateway) -> None:
    async def scenario() -> None:
        async with AsyncGateway(gateway.url, token=TOKENS["viewer"]) as gw:
            states = await gw.wait_connected(["sim1", "sim2"], timeout_s=30)
            assert [s.id for s in states] == ["sim1", "sim2"]
            listed = await gw.list_controllers()
            assert {c.id for c in listed} == {"cam1", "ext1", "sim1", "sim2"}
            sim2 = await gw.get_controller("sim2")
            assert sim2.identity is not None and sim2.identity.modules == ()
            with pytest.raises(UnknownController):
                await gw.get_controller("stage9")

    asyncio.run(scenario())
