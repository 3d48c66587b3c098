"""Jobs (/api/v1/jobs): submit, dry run, actions, events, and waiting with progress."""

from __future__ import annotations

import asyncio
import builtins
import inspect
from collections.abc import Awaitable, Callable, Mapping
from typing import Any
from urllib.parse import quote

from .leases import AsyncLease
from .models import Job, JobPlan, JobProgress, JobUpdate, JsonObject
from .problems import JobCancelled, JobEnded, JobFailed
from .subscription import Event, Retired, Subscription
from .transport import Transport

ProgressCallback = Callable[[JobUpdate], Awaitable[None] | None]
LeaseArg = AsyncLease | str | None


def lease_header(lease: LeaseArg) -> dict[str, str]:
    """The Lease-Id header for a lease block or a plain lease id."""
    if isinstance(lease, AsyncLease):
        lease.raise_if_lost()
        lease_id = lease.lease_id
    else:
        lease_id = lease
    return {"Lease-Id": lease_id} if lease_id else {}


class AsyncJobs:
    def __init__(
        self, transport: Transport, lease_held_on: Callable[[str], AsyncLease | None] = lambda _: None
    ) -> None:
        self._transport = transport
        # The lease block this client has open on a controller, if any: a submission carries it
        # without being told.
        self._lease_held_on = lease_held_on

    async def submit(
        self,
        controller: str,
        type: str,
        spec: Mapping[str, Any],
        *,
        lease: LeaseArg = None,
        idempotency_key: str | None = None,
    ) -> Job:
        """Validates, plans, stores and queues a job. The same `idempotency_key` again returns the
        first job instead of a second one. `lease` defaults to this client's open lease block
        on the controller."""
        headers = lease_header(lease if lease is not None else self._lease_held_on(controller))
        if idempotency_key is not None:
            headers["Idempotency-Key"] = idempotency_key
        body = {"controller": controller, "type": type, "spec": dict(spec)}
        return Job.from_json(await self._transport.json("POST", "/jobs", json=body, headers=headers))

    async def dry_run(self, controller: str, type: str, spec: Mapping[str, Any], *, lease: LeaseArg = None) -> JobPlan:
        """Plans only: the serial commands, the estimate and the bounds; nothing moves or is stored."""
        body = {"controller": controller, "type": type, "spec": dict(spec)}
        held = lease if lease is not None else self._lease_held_on(controller)
        answer = await self._transport.json(
            "POST", "/jobs", json=body, params={"dry_run": True}, headers=lease_header(held)
        )
        return JobPlan.from_json(answer)

    async def get(self, job_id: str) -> Job:
        return Job.from_json(await self._transport.json("GET", _path(job_id)))

    async def list(
        self,
        *,
        controller: str | None = None,
        type: str | None = None,
        state: str | None = None,
        limit: int | None = None,
        before: str | None = None,
    ) -> tuple[builtins.list[Job], str | None]:
        """One page, newest first, and the cursor of the next page (pass it as `before`)."""
        params = {"controller": controller, "type": type, "state": state, "limit": limit, "before": before}
        page = await self._transport.json("GET", "/jobs", params=params)
        return [Job.from_json(j) for j in page["jobs"]], page["next"]

    async def events(self, job_id: str, *, limit: int | None = None) -> builtins.list[JsonObject]:
        """The job's stored events, oldest first (state changes, steps, job-specific events)."""
        answer = await self._transport.json("GET", _path(job_id) + "/events", params={"limit": limit})
        return list(answer["events"])

    async def cancel(self, job_id: str, *, lease: LeaseArg = None) -> Job:
        return await self._action(job_id, "cancel", lease)

    async def pause(self, job_id: str, *, lease: LeaseArg = None) -> Job:
        return await self._action(job_id, "pause", lease)

    async def resume(self, job_id: str, *, lease: LeaseArg = None) -> Job:
        return await self._action(job_id, "resume", lease)

    async def next(self, job_id: str, *, lease: LeaseArg = None) -> Job:
        """Advances a job that waits for a `next` call."""
        return await self._action(job_id, "next", lease)

    async def _action(self, job_id: str, action: str, lease: LeaseArg) -> Job:
        answer = await self._transport.json("POST", f"{_path(job_id)}/{action}", json={}, headers=lease_header(lease))
        return Job.from_json(answer)

    async def wait(
        self,
        job_id: str,
        *,
        on_progress: ProgressCallback | None = None,
        timeout_s: float | None = None,
        raise_on_failure: bool = True,
    ) -> Job:
        """Follows the job's topic from its first event until it ends; returns its final record.

        `on_progress` (a function or a coroutine function) gets a JobUpdate for every state
        change and every completed step, in order, replayed ones included. Raises JobFailed or
        JobCancelled when it ended otherwise than succeeded (unless `raise_on_failure` is
        False), TimeoutError after `timeout_s`.
        """
        return await asyncio.wait_for(self._follow(job_id, on_progress, raise_on_failure), timeout_s)

    async def _follow(self, job_id: str, on_progress: ProgressCallback | None, raise_on_failure: bool) -> Job:
        topic = "jobs/" + job_id
        # resume from 0: the whole history the gateway still holds, so a job that ended before
        # we subscribed still delivers its final state.
        async with Subscription(self._transport, [topic], resume={topic: 0}) as sub:
            async for message in sub:
                if isinstance(message, Retired):
                    break  # ended long ago; its record says how
                if not isinstance(message, Event):
                    continue  # a gap: the final state event still comes
                update = _update(job_id, message.data)
                if update is not None and on_progress is not None:
                    result = on_progress(update)
                    if inspect.isawaitable(result):
                        await result
                if message.data.get("type") == "state" and message.data.get("state") in (
                    "succeeded",
                    "failed",
                    "cancelled",
                ):
                    break
        job = await self.get(job_id)
        if raise_on_failure:
            _raise_unless_succeeded(job)
        return job


def _update(job_id: str, data: JsonObject) -> JobUpdate | None:
    kind = data.get("type")
    if kind == "state" and isinstance(data.get("job"), dict):
        job = data["job"]
        return JobUpdate(job_id, data["state"], JobProgress.from_json(job["progress"]), None, data)
    if kind == "step":
        # A step happens while the job runs; its event does not repeat the state.
        return JobUpdate(job_id, "running", JobProgress.from_step_event(data), data["name"], data)
    return None


def _raise_unless_succeeded(job: Job) -> None:
    if job.state == "failed":
        raise JobFailed(job)
    if job.state == "cancelled":
        raise JobCancelled(job)
    if job.state != "succeeded":
        raise JobEnded(job)


def _path(job_id: str) -> str:
    return "/jobs/" + quote(job_id, safe="")
