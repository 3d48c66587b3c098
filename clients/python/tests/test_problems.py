"""problem+json answers of the real gateway arrive as their exception classes, every field kept."""

from __future__ import annotations

import asyncio

import pytest
from gateway_process import TOKENS, RunningGateway

from asi_gateway import (
    AsyncGateway,
    Conflict,
    Forbidden,
    Gateway,
    InvalidValue,
    Leased,
    NotFound,
    Problem,
    Unauthorized,
    UnknownController,
    UnknownJob,
)


def assert_fields(error: Problem, status: int, kind: str) -> None:
    assert error.status == status
    assert error.type == "https://asi-gateway.dev/problems/" + kind and error.kind == kind
    assert error.title and error.detail
    assert error.instance and error.instance.startswith("/api/v1/")
    assert error.request_id
    assert error.body["status"] == status


def test_404_unknown_controller_and_job(operator: Gateway) -> None:
    with pytest.raises(UnknownController) as unknown:
        operator.stage("stage9").move({"X": 1})
    assert isinstance(unknown.value, NotFound)
    assert_fields(unknown.value, 404, "unknown-controller")
    assert unknown.value.instance == "/api/v1/controllers/stage9/move"
    with pytest.raises(UnknownJob) as job:
        operator.jobs.get("j-01JD3Q5W8Z0000000000000000")
    assert_fields(job.value, 404, "unknown-job")


def test_409_leased(gateway: RunningGateway, admin: Gateway, operator: Gateway) -> None:
    with admin.stage("sim1").lease(ttl_s=30, holder="other-client"):
        with pytest.raises(Leased) as leased:
            operator.stage("sim1").move({"X": 5})
        assert isinstance(leased.value, Conflict)
        assert_fields(leased.value, 409, "leased")
        assert "admin1/other-client" in leased.value.detail
        # HALT always works, whoever holds the lease.
        assert operator.stage("sim1").halt().operation == "halt"


def test_422_invalid_value_names_the_field(operator: Gateway) -> None:
    with pytest.raises(InvalidValue) as invalid:
        operator.stage("sim2").move({"Q": 1000})
    assert_fields(invalid.value, 422, "invalid-value")
    assert invalid.value.field == "axes.Q"
    with pytest.raises(InvalidValue) as spec:
        operator.jobs.submit("sim1", "array", {"plate": "96", "colour": "red"})
    assert spec.value.field == "spec.colour"


def test_401_and_403(gateway: RunningGateway) -> None:
    with Gateway(gateway.url, token="not-a-token") as stranger, pytest.raises(Unauthorized) as unauthorized:
        stranger.list_controllers()
    assert_fields(unauthorized.value, 401, "unauthorized")
    with Gateway(gateway.url, token=TOKENS["viewer"]) as viewer:
        with pytest.raises(Forbidden) as forbidden:
            viewer.stage("sim1").move({"X": 1})
        assert_fields(forbidden.value, 403, "forbidden")


def test_async_problems(gateway: RunningGateway) -> None:
    async def scenario() -> None:
        async with AsyncGateway(gateway.url, token=TOKENS["operator"]) as gw:
            with pytest.raises(UnknownController):
                await gw.stage("nope").halt()
            with pytest.raises(InvalidValue) as invalid:
                await gw.stage("sim2").speed({"X": 500})
            assert invalid.value.field is not None and invalid.value.field.startswith("axes")
        # The WebSocket upgrade's refusal is mapped too.
        async with AsyncGateway(gateway.url, token="not-a-token") as stranger:
            with pytest.raises(Unauthorized) as refused:
                await stranger.subscribe("controllers/+/state").__aenter__()
            assert refused.value.status == 401

    asyncio.run(scenario())
