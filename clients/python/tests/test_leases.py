"""Leases as context managers: renewal past the TTL, release on exit, a lease lost mid-script."""

from __future__ import annotations

import asyncio
import time

import pytest
from gateway_process import TOKENS, RunningGateway

from asi_gateway import AsyncGateway, Gateway, InvalidState, Leased, LeaseLost


def test_lease_renews_past_its_ttl_and_is_released(gateway: RunningGateway, operator: Gateway) -> None:
    stage = operator.stage("sim2")
    with Gateway(gateway.url, token=TOKENS["admin"]) as other:
        with stage.lease(ttl_s=2, holder="pytest", renew_every_s=0.5) as lease:
            assert lease.lease_id and lease.lease_id.startswith("l-")
            time.sleep(5)  # 2.5 TTLs: only the renewals keep it
            info = other.stage("sim2").lease_info()
            assert info is not None and info.holder == "operator1/pytest"
            assert lease.renewals >= 3
            # Another client is refused, the holder is not.
            with pytest.raises(Leased) as refused:
                other.stage("sim2").move({"X": 10})
            assert refused.value.status == 409
            result = stage.move({"X": 100}, wait=True)
            assert result.arrived()
            # Every handle and every job submission of this client on sim2 carries the lease.
            assert operator.stage("sim2").move({"X": 150}, wait=True).arrived()
            spec = {"grid": {"columns": 2, "rows": 1, "column_step_mm": 0.1, "row_step_mm": 0.1}, "a1": "current"}
            job = operator.jobs.submit("sim2", "array", {**spec, "mode": "host"})
            assert operator.jobs.wait(job.id, timeout_s=120).state == "succeeded"
        assert other.stage("sim2").lease_info() is None
        assert other.stage("sim2").move({"X": 0}, wait=True).arrived()


def test_lease_lost_mid_script_raises_the_mapped_exception(admin: Gateway, operator: Gateway) -> None:
    stage = operator.stage("sim2")
    with pytest.raises(LeaseLost) as lost, stage.lease(ttl_s=2, renew_every_s=0.3) as lease:
        stage.move({"X": 20}, wait=True)
        admin.stage("sim2").force_release_lease()  # an admin ends it under us
        deadline = time.monotonic() + 30
        while lease.lost is None:
            assert time.monotonic() < deadline, "the renewal never noticed"
            time.sleep(0.1)
        stage.move({"X": 40}, wait=True)  # must not run: the lease is gone
    error = lost.value
    assert isinstance(error, InvalidState)
    assert error.status == 409 and error.kind == "invalid-state"
    assert error.title and error.detail and error.request_id
    # The refused move never reached the stage.
    x = stage.state().positions["X"] or 0
    assert abs(x - 20) <= 1.0


def test_lease_lost_without_an_operation_raises_at_the_end_of_the_block(admin: Gateway, operator: Gateway) -> None:
    stage = operator.stage("ext1")
    with pytest.raises(LeaseLost), stage.lease(ttl_s=1, renew_every_s=0.25) as lease:
        admin.stage("ext1").force_release_lease()
        deadline = time.monotonic() + 30
        while lease.lost is None and time.monotonic() < deadline:
            time.sleep(0.1)


def test_async_lease_and_jobs_under_it(gateway: RunningGateway) -> None:
    async def scenario() -> None:
        async with (
            AsyncGateway(gateway.url, token=TOKENS["operator"]) as gw,
            AsyncGateway(gateway.url, token=TOKENS["admin"]) as other,
        ):
            stage = gw.stage("sim1")
            async with stage.lease(ttl_s=2, renew_every_s=0.5) as lease:
                await asyncio.sleep(3)
                assert lease.renewals >= 2
                spec = {"grid": {"columns": 2, "rows": 1, "column_step_mm": 0.1, "row_step_mm": 0.1}, "a1": "current"}
                with pytest.raises(Leased):
                    await other.jobs.submit("sim1", "array", spec)
                job = await gw.jobs.submit("sim1", "array", spec, lease=lease)
                final = await gw.jobs.wait(job.id, timeout_s=120)
                assert final.state == "succeeded"
            assert await other.stage("sim1").lease_info() is None

    asyncio.run(scenario())
