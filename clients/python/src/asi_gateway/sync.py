"""The synchronous interface: `with Gateway(url) as gw: gw.stage("sim1").move({"X": 1000}, wait=True)`.

It is a thin facade over the asyncio implementation, which runs on an event loop in a daemon
thread of its own. So both interfaces behave the same in everything (reconnection, resumption,
problem mapping), and what must go on while your code blocks does: a lease keeps renewing during
a `time.sleep()` in its `with` block. Progress callbacks of `jobs.wait()` run on that thread.
"""

from __future__ import annotations

import asyncio
import builtins
import threading
from collections.abc import Callable, Coroutine, Iterable, Iterator, Mapping
from concurrent.futures import Future
from pathlib import Path
from types import TracebackType
from typing import Any, TypeVar

from .client import AsyncGateway
from .gcode import AsyncGcode, Program
from .jobs import AsyncJobs
from .leases import AsyncLease
from .models import (
    ControllerState,
    GcodeFile,
    Job,
    JobPlan,
    JobUpdate,
    JsonObject,
    LeaseGrant,
    LeaseInfo,
    MoveResult,
    OperationResult,
    Recording,
)
from .problems import LeaseLost
from .recordings import AsyncRecordings, Moment
from .stage import DEFAULT_MOVE_TIMEOUT_S, AsyncStage
from .subscription import Message, Subscription

T = TypeVar("T")


class _EventLoopThread:
    """An asyncio loop running in a daemon thread; `run()` executes a coroutine on it and blocks
    for the result (Ctrl-C cancels the coroutine)."""

    def __init__(self) -> None:
        self.loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self.loop.run_forever, name="asi-gateway-loop", daemon=True)
        self._thread.start()

    def run(self, coroutine: Coroutine[Any, Any, T]) -> T:
        future: Future[T] = asyncio.run_coroutine_threadsafe(coroutine, self.loop)
        try:
            return future.result()
        except KeyboardInterrupt:
            future.cancel()
            raise

    def stop(self) -> None:
        if self.loop.is_running():
            self.loop.call_soon_threadsafe(self.loop.stop)
            self._thread.join(timeout=10)
        if not self.loop.is_running():
            self.loop.close()


class Gateway:
    """The synchronous client; the arguments are AsyncGateway's."""

    def __init__(
        self,
        url: str = "http://127.0.0.1:8080",
        *,
        token: str | None = None,
        verify: bool = True,
        ca_file: str | None = None,
        timeout_s: float = 30.0,
    ) -> None:
        self._runner = _EventLoopThread()

        async def make() -> AsyncGateway:
            return AsyncGateway(url, token=token, verify=verify, ca_file=ca_file, timeout_s=timeout_s)

        try:
            self.aio = self._runner.run(make())  # the asyncio client underneath, for mixed use
        except BaseException:
            self._runner.stop()
            raise
        self.jobs = Jobs(self._runner, self.aio.jobs)
        self.gcode = Gcode(self._runner, self.aio.gcode)
        self.recordings = Recordings(self._runner, self.aio.recordings)

    @property
    def url(self) -> str:
        return self.aio.url

    def __enter__(self) -> Gateway:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        try:
            self._runner.run(self.aio.aclose())
        finally:
            self._runner.stop()

    def run_async(self, coroutine: Coroutine[Any, Any, T]) -> T:
        """Runs a coroutine (of `gw.aio`, or one using it) on the client's event loop and waits
        for its result: for mixing the two interfaces."""
        return self._runner.run(coroutine)

    def start_async(self, coroutine: Coroutine[Any, Any, T]) -> Future[T]:
        """Starts a coroutine on the client's event loop and returns at once; the future has its
        result (a waited move in the background, say)."""
        return asyncio.run_coroutine_threadsafe(coroutine, self._runner.loop)

    def health(self) -> dict[str, Any]:
        return self._runner.run(self.aio.health())

    def ready(self) -> dict[str, Any]:
        return self._runner.run(self.aio.ready())

    def whoami(self) -> dict[str, Any]:
        return self._runner.run(self.aio.whoami())

    def list_controllers(self) -> list[ControllerState]:
        return self._runner.run(self.aio.list_controllers())

    def get_controller(self, controller_id: str) -> ControllerState:
        return self._runner.run(self.aio.get_controller(controller_id))

    def wait_connected(
        self, controller_ids: str | Iterable[str] | None = None, *, timeout_s: float = 60.0
    ) -> list[ControllerState]:
        return self._runner.run(self.aio.wait_connected(controller_ids, timeout_s=timeout_s))

    def stage(self, controller_id: str) -> Stage:
        return Stage(self._runner, self.aio.stage(controller_id))

    def leases(self) -> list[LeaseInfo]:
        return self._runner.run(self.aio.leases())

    def halt_all(self) -> dict[str, OperationResult]:
        """HALT on every controller; see AsyncGateway.halt_all."""
        return self._runner.run(self.aio.halt_all())

    def subscribe(
        self,
        topics: str | Iterable[str],
        *,
        resume: Mapping[str, int] | None = None,
        max_rate_hz: float | None = None,
        batch_ms: int | None = None,
        reconnect: bool = True,
        give_up_after_s: float | None = None,
    ) -> SyncSubscription:
        """`with gw.subscribe("jobs/j-...") as sub: for message in sub:` ... (see AsyncGateway)."""
        return SyncSubscription(
            self._runner,
            self.aio.subscribe(
                topics,
                resume=resume,
                max_rate_hz=max_rate_hz,
                batch_ms=batch_ms,
                reconnect=reconnect,
                give_up_after_s=give_up_after_s,
            ),
        )


class Stage:
    """One controller's operations; see AsyncStage."""

    def __init__(self, runner: _EventLoopThread, stage: AsyncStage) -> None:
        self._runner = runner
        self.aio = stage

    @property
    def id(self) -> str:
        return self.aio.id

    def __repr__(self) -> str:
        return f"Stage({self.id!r})"

    def state(self) -> ControllerState:
        return self._runner.run(self.aio.state())

    def positions(self) -> dict[str, float | None]:
        return self._runner.run(self.aio.positions())

    def move(
        self, axes: Mapping[str, float], *, wait: bool = False, timeout_s: float = DEFAULT_MOVE_TIMEOUT_S
    ) -> MoveResult:
        return self._runner.run(self.aio.move(axes, wait=wait, timeout_s=timeout_s))

    def move_relative(
        self, axes: Mapping[str, float], *, wait: bool = False, timeout_s: float = DEFAULT_MOVE_TIMEOUT_S
    ) -> MoveResult:
        return self._runner.run(self.aio.move_relative(axes, wait=wait, timeout_s=timeout_s))

    def home(self, axes: Iterable[str] | None = None) -> OperationResult:
        return self._runner.run(self.aio.home(axes))

    def zero(self) -> OperationResult:
        return self._runner.run(self.aio.zero())

    def here(self, axes: Mapping[str, float]) -> OperationResult:
        return self._runner.run(self.aio.here(axes))

    def speed(self, axes: Mapping[str, float]) -> OperationResult:
        return self._runner.run(self.aio.speed(axes))

    def ttl(
        self, *, in0_mode: int | None = None, out0_mode: int | None = None, output_high: bool | None = None
    ) -> OperationResult:
        return self._runner.run(self.aio.ttl(in0_mode=in0_mode, out0_mode=out0_mode, output_high=output_high))

    def halt(self) -> OperationResult:
        return self._runner.run(self.aio.halt())

    def lease_info(self) -> LeaseInfo | None:
        return self._runner.run(self.aio.lease_info())

    def force_release_lease(self) -> None:
        self._runner.run(self.aio.force_release_lease())

    def lease(self, *, ttl_s: int = 60, holder: str | None = None, renew_every_s: float | None = None) -> Lease:
        """`with stage.lease(ttl_s=30):` ... (see AsyncLease); renews in the background."""
        return Lease(self._runner, self.aio.lease(ttl_s=ttl_s, holder=holder, renew_every_s=renew_every_s))


class Lease:
    def __init__(self, runner: _EventLoopThread, lease: AsyncLease) -> None:
        self._runner = runner
        self.aio = lease

    @property
    def lease_id(self) -> str | None:
        return self.aio.lease_id

    @property
    def grant(self) -> LeaseGrant | None:
        return self.aio.grant

    @property
    def renewals(self) -> int:
        return self.aio.renewals

    @property
    def lost(self) -> LeaseLost | None:
        return self.aio.lost

    def __enter__(self) -> Lease:
        self._runner.run(self.aio.__aenter__())
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self._runner.run(self.aio.__aexit__(exc_type, exc, tb))

    def renew(self) -> LeaseGrant:
        return self._runner.run(self.aio.renew())


SyncLeaseArg = Lease | AsyncLease | str | None


def _async_lease(lease: SyncLeaseArg) -> AsyncLease | str | None:
    return lease.aio if isinstance(lease, Lease) else lease


class Recordings:
    """See AsyncRecordings; `lease` takes a Lease block, or a lease id."""

    def __init__(self, runner: _EventLoopThread, recordings: AsyncRecordings) -> None:
        self._runner = runner
        self.aio = recordings

    def start(
        self,
        controller: str,
        name: str,
        *,
        ttl_in_mode: int | None = None,
        max_frames: int | None = None,
        max_s: float | None = None,
        metadata: Mapping[str, Any] | None = None,
        lease: SyncLeaseArg = None,
    ) -> Recording:
        return self._runner.run(
            self.aio.start(
                controller,
                name,
                ttl_in_mode=ttl_in_mode,
                max_frames=max_frames,
                max_s=max_s,
                metadata=metadata,
                lease=_async_lease(lease),
            )
        )

    def stop(self, recording_id: str) -> Recording:
        return self._runner.run(self.aio.stop(recording_id))

    def get(self, recording_id: str) -> Recording:
        return self._runner.run(self.aio.get(recording_id))

    def list(
        self,
        *,
        controller: str | None = None,
        state: str | None = None,
        job: str | None = None,
        since: Moment = None,
        until: Moment = None,
        limit: int | None = None,
    ) -> builtins.list[Recording]:
        return self._runner.run(
            self.aio.list(controller=controller, state=state, job=job, since=since, until=until, limit=limit)
        )

    def delete(self, recording_id: str) -> None:
        self._runner.run(self.aio.delete(recording_id))

    def wait(self, recording_id: str, *, frames: int | None = None, timeout_s: float | None = None) -> Recording:
        return self._runner.run(self.aio.wait(recording_id, frames=frames, timeout_s=timeout_s))

    def download(self, recording_id: str, target: str | Path, *, format: str = "csv") -> int:
        return self._runner.run(self.aio.download(recording_id, target, format=format))

    def rows(self, recording_id: str) -> builtins.list[JsonObject]:
        return self._runner.run(self.aio.rows(recording_id))

    def dataframe(self, recording_id: str, *, losses: bool = False) -> Any:
        return self._runner.run(self.aio.dataframe(recording_id, losses=losses))


class Jobs:
    """See AsyncJobs; `lease` takes a Lease block, or a lease id."""

    def __init__(self, runner: _EventLoopThread, jobs: AsyncJobs) -> None:
        self._runner = runner
        self.aio = jobs

    def submit(
        self,
        controller: str,
        type: str,
        spec: Mapping[str, Any],
        *,
        lease: SyncLeaseArg = None,
        idempotency_key: str | None = None,
    ) -> Job:
        return self._runner.run(
            self.aio.submit(controller, type, spec, lease=_async_lease(lease), idempotency_key=idempotency_key)
        )

    def dry_run(self, controller: str, type: str, spec: Mapping[str, Any], *, lease: SyncLeaseArg = None) -> JobPlan:
        return self._runner.run(self.aio.dry_run(controller, type, spec, lease=_async_lease(lease)))

    def get(self, job_id: str) -> Job:
        return self._runner.run(self.aio.get(job_id))

    def list(
        self,
        *,
        controller: str | None = None,
        type: str | None = None,
        state: str | None = None,
        limit: int | None = None,
        before: str | None = None,
    ) -> tuple[builtins.list[Job], str | None]:
        return self._runner.run(
            self.aio.list(controller=controller, type=type, state=state, limit=limit, before=before)
        )

    def events(self, job_id: str, *, limit: int | None = None) -> builtins.list[JsonObject]:
        return self._runner.run(self.aio.events(job_id, limit=limit))

    def cancel(self, job_id: str, *, lease: SyncLeaseArg = None) -> Job:
        return self._runner.run(self.aio.cancel(job_id, lease=_async_lease(lease)))

    def pause(self, job_id: str, *, lease: SyncLeaseArg = None) -> Job:
        return self._runner.run(self.aio.pause(job_id, lease=_async_lease(lease)))

    def resume(self, job_id: str, *, lease: SyncLeaseArg = None) -> Job:
        return self._runner.run(self.aio.resume(job_id, lease=_async_lease(lease)))

    def next(self, job_id: str, *, lease: SyncLeaseArg = None) -> Job:
        return self._runner.run(self.aio.next(job_id, lease=_async_lease(lease)))

    def wait(
        self,
        job_id: str,
        *,
        on_progress: Callable[[JobUpdate], None] | None = None,
        timeout_s: float | None = None,
        raise_on_failure: bool = True,
    ) -> Job:
        """See AsyncJobs.wait; `on_progress` is called on the client's event-loop thread."""
        return self._runner.run(
            self.aio.wait(job_id, on_progress=on_progress, timeout_s=timeout_s, raise_on_failure=raise_on_failure)
        )


class Gcode:
    """See AsyncGcode."""

    def __init__(self, runner: _EventLoopThread, gcode: AsyncGcode) -> None:
        self._runner = runner
        self.aio = gcode

    def upload(self, program: Program, *, name: str | None = None) -> GcodeFile:
        return self._runner.run(self.aio.upload(program, name=name))

    def files(self) -> list[GcodeFile]:
        return self._runner.run(self.aio.files())

    def get(self, file_id: str) -> GcodeFile:
        return self._runner.run(self.aio.get(file_id))

    def delete(self, file_id: str) -> None:
        self._runner.run(self.aio.delete(file_id))

    def plan(
        self,
        program: Program | None = None,
        *,
        file_id: str | None = None,
        moves: bool = True,
        options: Mapping[str, Any] | None = None,
    ) -> JsonObject:
        return self._runner.run(self.aio.plan(program, file_id=file_id, moves=moves, options=options))

    def preview_svg(self, program: Program | None = None, *, file_id: str | None = None, **params: Any) -> str:
        return self._runner.run(self.aio.preview_svg(program, file_id=file_id, **params))

    def run(
        self,
        controller: str,
        program: str | None = None,
        *,
        file_id: str | None = None,
        options: Mapping[str, Any] | None = None,
        lease: SyncLeaseArg = None,
        idempotency_key: str | None = None,
    ) -> Job:
        return self._runner.run(
            self.aio.run(
                controller,
                program,
                file_id=file_id,
                options=options,
                lease=_async_lease(lease),
                idempotency_key=idempotency_key,
            )
        )


class SyncSubscription:
    """An iterator of Event, Gap and Retired messages; see Subscription."""

    def __init__(self, runner: _EventLoopThread, subscription: Subscription) -> None:
        self._runner = runner
        self.aio = subscription

    @property
    def last_seq(self) -> dict[str, int]:
        return self.aio.last_seq

    @property
    def reconnects(self) -> int:
        return self.aio.reconnects

    def __enter__(self) -> SyncSubscription:
        self._runner.run(self.aio.__aenter__())
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __iter__(self) -> Iterator[Message]:
        return self

    def __next__(self) -> Message:
        try:
            return self._runner.run(self.aio.__anext__())
        except StopAsyncIteration:
            raise StopIteration from None

    def next(self, timeout_s: float) -> Message:
        """The next message, or TimeoutError after `timeout_s`; the subscription stays usable
        (a WebSocket read is cancelled cleanly, nothing is lost)."""

        async def next_within() -> Message:
            return await asyncio.wait_for(self.aio.__anext__(), timeout_s)

        return self._runner.run(next_within())

    def close(self) -> None:
        self._runner.run(self.aio.close())
