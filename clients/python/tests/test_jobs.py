"""Jobs: submit, dry run, wait with progress, failure, actions, events; G-code upload, plan, run."""

from __future__ import annotations

import asyncio

import pytest
from gateway_process import TOKENS, RunningGateway

from asi_gateway import AsyncGateway, Event, Gateway, InvalidGcode, InvalidState, JobCancelled, JobFailed, JobUpdate

GRID = {"grid": {"columns": 3, "rows": 2, "column_step_mm": 0.2, "row_step_mm": -0.2}, "a1": "current"}


def test_job_succeeds_with_a_progress_callback(operator: Gateway) -> None:
    updates: list[JobUpdate] = []
    job = operator.jobs.submit("sim2", "array", {**GRID, "mode": "host"})
    assert job.state in ("queued", "running") and job.progress.steps_total == 6
    final = operator.jobs.wait(job.id, on_progress=updates.append, timeout_s=120)
    assert final.state == "succeeded" and final.ended
    assert final.progress.steps_done == 6 and final.progress.percent == 100
    steps = [u for u in updates if u.step is not None]
    assert [u.progress.steps_done for u in steps] == [1, 2, 3, 4, 5, 6]
    assert [u.step for u in steps] == ["A1", "A2", "A3", "B3", "B2", "B1"]  # serpentine
    states = [u.state for u in updates if u.step is None]
    assert states[0] == "queued" and "running" in states and states[-1] == "succeeded"
    events = operator.jobs.events(job.id)
    assert [e["type"] for e in events].count("step") == 6


def test_job_that_fails_raises_job_failed_with_the_reason(gateway: RunningGateway, operator: Gateway) -> None:
    job = operator.jobs.submit("ext1", "array", {**GRID, "mode": "host"})
    # The simulated controller refuses the job's next move: the job fails with its reason.
    assert gateway.ext.control("refuse-next M -4") == "ok"
    with pytest.raises(JobFailed) as failed:
        operator.jobs.wait(job.id, timeout_s=120)
    assert failed.value.job.state == "failed"
    assert ":N-4" in failed.value.job.reason
    final = operator.jobs.wait(job.id, raise_on_failure=False, timeout_s=60)
    assert final.state == "failed"


def test_dry_run_moves_nothing(operator: Gateway) -> None:
    before = operator.get_controller("sim1").positions
    plan = operator.jobs.dry_run("sim1", "array", {"plate": "96", "a1": {"X": -49500, "Y": 31500}})
    assert plan.dry_run and plan.plan["path"] == "firmware" and plan.estimated_s > 0
    assert any(c.startswith("ARRAY") for c in plan.commands)
    assert operator.get_controller("sim1").positions == before
    assert operator.jobs.list(controller="sim1", state="queued")[0] == []


def test_pause_resume_next_cancel(operator: Gateway) -> None:
    spec = {"plate": "6", "a1": "current", "advance": "next", "mode": "host"}
    job = operator.jobs.submit("sim2", "array", spec)
    # Wait for the first "next" request of the job.
    with operator.subscribe("jobs/" + job.id, resume={"jobs/" + job.id: 0}) as sub:
        for message in sub:
            if isinstance(message, Event) and message.data.get("waiting_for") == "next":
                break
    advanced = operator.jobs.next(job.id)
    assert advanced.id == job.id
    paused = operator.jobs.pause(job.id)
    assert paused.id == job.id
    assert operator.jobs.cancel(job.id).id == job.id
    with pytest.raises(JobCancelled):
        operator.jobs.wait(job.id, timeout_s=60)
    with pytest.raises(InvalidState) as refused:
        operator.jobs.resume(job.id)
    assert refused.value.status == 409 and refused.value.field == "state"


def test_idempotent_submission_returns_the_first_job(operator: Gateway) -> None:
    first = operator.jobs.submit("sim1", "array", GRID, idempotency_key="pytest-key-1")
    again = operator.jobs.submit("sim1", "array", GRID, idempotency_key="pytest-key-1")
    assert again.id == first.id
    operator.jobs.wait(first.id, timeout_s=120)


PROGRAM = "G21 G90\nG00 X0.1 Y0.1\nM03\nG01 X0.3 F120\nY0.3\nM05\nG00 X0 Y0\n"


def test_gcode_upload_plan_run(operator: Gateway) -> None:
    uploaded = operator.gcode.upload(PROGRAM, name="square.ngc")
    assert uploaded.id.startswith("g-") and uploaded.name == "square.ngc" and uploaded.lines == 7
    assert uploaded.id in [f.id for f in operator.gcode.files()]
    plan = operator.gcode.plan(file_id=uploaded.id)
    assert plan["units"] == "mm" and [m["kind"] for m in plan["moves"]].count("ttl") == 2
    summary = operator.gcode.plan(PROGRAM, moves=False)
    assert summary["move_count"] == len(plan["moves"])
    assert "<svg" in operator.gcode.preview_svg(PROGRAM, width_px=200)
    with pytest.raises(InvalidGcode) as bad:
        operator.gcode.plan("G21\nG00 X1\nG28 X0\n")
    assert (bad.value.line, bad.value.column) == (3, 1) and bad.value.status == 422
    job = operator.gcode.run("sim2", file_id=uploaded.id)
    final = operator.jobs.wait(job.id, timeout_s=120)
    assert final.type == "gcode" and final.state == "succeeded"
    operator.gcode.delete(uploaded.id)
    assert uploaded.id not in [f.id for f in operator.gcode.files()]


def test_async_jobs_with_an_async_callback(gateway: RunningGateway) -> None:
    async def scenario() -> None:
        seen: list[int] = []

        async def on_progress(update: JobUpdate) -> None:
            seen.append(update.progress.steps_done)

        async with AsyncGateway(gateway.url, token=TOKENS["operator"]) as gw:
            job = await gw.jobs.submit("sim1", "array", GRID)
            final = await gw.jobs.wait(job.id, on_progress=on_progress, timeout_s=120)
            assert final.state == "succeeded"
            assert seen == sorted(seen) and seen[-1] == 6
            page, _ = await gw.jobs.list(controller="sim1", limit=1)
            assert page[0].id == job.id

    asyncio.run(scenario())
