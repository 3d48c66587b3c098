"""AsyncGateway: the asyncio interface, and the one implementation the synchronous one runs."""

from __future__ import annotations

import asyncio
from collections.abc import Iterable, Mapping
from typing import Any

from .gcode import AsyncGcode
from .jobs import AsyncJobs
from .leases import AsyncLease
from .models import ControllerState, LeaseInfo, OperationResult
from .problems import HaltIncomplete, Problem, problem_from_body
from .recordings import AsyncRecordings
from .stage import AsyncStage
from .subscription import Subscription
from .transport import Transport

WAIT_POLL_S = 0.2


class AsyncGateway:
    """`async with AsyncGateway("http://127.0.0.1:8080") as gw:` ...

    `token` is sent as `Authorization: Bearer` (REST and the WebSocket upgrade). For https URLs
    the certificate is verified; `ca_file` trusts a CA of your own (a self-signed gateway),
    `verify=False` turns verification off. `timeout_s` bounds each request (waited moves get
    their own, longer one).
    """

    def __init__(
        self,
        url: str = "http://127.0.0.1:8080",
        *,
        token: str | None = None,
        verify: bool = True,
        ca_file: str | None = None,
        timeout_s: float = 30.0,
    ) -> None:
        self.transport = Transport(url, token=token, verify=verify, ca_file=ca_file, timeout=timeout_s)
        self._stages: dict[str, AsyncStage] = {}
        self.jobs = AsyncJobs(self.transport, self._lease_held_on)
        self.gcode = AsyncGcode(self.transport, self.jobs)
        self.recordings = AsyncRecordings(self.transport, self._lease_held_on)

    @property
    def url(self) -> str:
        return self.transport.url

    async def __aenter__(self) -> AsyncGateway:
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.aclose()

    async def aclose(self) -> None:
        await self.transport.aclose()

    # ---- service ------------------------------------------------------------------------------

    async def health(self) -> dict[str, Any]:
        return dict(await self.transport.json("GET", "/health"))

    async def ready(self) -> dict[str, Any]:
        """{"ready": bool, "controllers": [{"id", "state"}]}; 200 or 503, both answered here."""
        response = await self.transport.request("GET", "/ready", check=False)
        return dict(response.json())

    async def whoami(self) -> dict[str, Any]:
        """{"client", "role", "auth"}: the token's name and role."""
        return dict(await self.transport.json("GET", "/whoami"))

    # ---- controllers --------------------------------------------------------------------------

    async def list_controllers(self) -> list[ControllerState]:
        answer = await self.transport.json("GET", "/controllers")
        return [ControllerState.from_json(c) for c in answer["controllers"]]

    async def get_controller(self, controller_id: str) -> ControllerState:
        return await self.stage(controller_id).state()

    def stage(self, controller_id: str) -> AsyncStage:
        """The handle for one controller's operations (no I/O until used). The same object for the
        same id, so a lease taken through one handle covers every call of this client on that
        controller."""
        if controller_id not in self._stages:
            self._stages[controller_id] = AsyncStage(self.transport, controller_id)
        return self._stages[controller_id]

    def _lease_held_on(self, controller_id: str) -> AsyncLease | None:
        stage = self._stages.get(controller_id)
        return stage.lease_in_use if stage is not None else None

    async def wait_connected(
        self, controller_ids: str | Iterable[str] | None = None, *, timeout_s: float = 60.0
    ) -> list[ControllerState]:
        """Waits until the controllers (default: every configured one) are connected; returns
        their states. TimeoutError names the ones that are not."""
        wanted = [controller_ids] if isinstance(controller_ids, str) else controller_ids
        wanted_list = list(wanted) if wanted is not None else None
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout_s
        while True:
            if wanted_list is None:
                states = await self.list_controllers()
            else:
                states = [await self.get_controller(cid) for cid in wanted_list]
            waiting = [s.id for s in states if not s.connected]
            if not waiting:
                return states
            if loop.time() >= deadline:
                raise TimeoutError(f"not connected after {timeout_s} s: {', '.join(waiting)}")
            await asyncio.sleep(WAIT_POLL_S)

    async def leases(self) -> list[LeaseInfo]:
        """Every current lease (without its id)."""
        answer = await self.transport.json("GET", "/leases")
        return [LeaseInfo.from_json(x) for x in answer["leases"]]

    async def halt_all(self) -> dict[str, OperationResult]:
        """HALT on every controller the gateway has, in one request (`POST /api/v1/halt`): the
        gateway halts them all at once and latches each as halted by this client's token. When a
        controller could not be reached, HaltIncomplete is raised with each one's outcome (its
        OperationResult, or the Problem that says why not)."""
        answer = await self.transport.json("POST", "/halt")
        results: dict[str, OperationResult | Problem] = {}
        for c in answer["controllers"]:
            if c["halted"]:
                results[c["id"]] = OperationResult(c["id"], "halt", answer["request_id"], c["latency_us"], raw=c)
            else:
                results[c["id"]] = problem_from_body(c["problem"])
        if any(isinstance(r, Problem) for r in results.values()):
            raise HaltIncomplete(results)
        return {cid: r for cid, r in results.items() if isinstance(r, OperationResult)}

    # ---- events -------------------------------------------------------------------------------

    def subscribe(
        self,
        topics: str | Iterable[str],
        *,
        resume: Mapping[str, int] | None = None,
        max_rate_hz: float | None = None,
        batch_ms: int | None = None,
        reconnect: bool = True,
        give_up_after_s: float | None = None,
    ) -> Subscription:
        """`async with gw.subscribe("controllers/+/position") as sub: async for m in sub:` ...

        Topics take MQTT-style wildcards (`+` one level, `#` the rest): controllers/<id>/state,
        position, reports, ttl, errors, and jobs/<id>. `resume` maps topics to the last sequence
        number you have, to get what came after. See Subscription for reconnection and gaps.
        """
        return Subscription(
            self.transport,
            [topics] if isinstance(topics, str) else topics,
            resume=resume,
            max_rate_hz=max_rate_hz,
            batch_ms=batch_ms,
            reconnect=reconnect,
            give_up_after_s=give_up_after_s,
        )
