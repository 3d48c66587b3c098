"""Typed operations on one controller (POST /api/v1/controllers/{id}/<operation>)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING, Any
from urllib.parse import quote

from .models import ControllerState, LeaseInfo, MoveResult, OperationResult
from .problems import NotFound, UnknownController
from .transport import Transport

if TYPE_CHECKING:
    from .leases import AsyncLease

# A waited move answers when the stage stopped; the HTTP request must outlast the gateway's own
# timeout_ms by a margin, or the client would give up on a move that is still fine.
WAIT_MARGIN_S = 15.0
DEFAULT_MOVE_TIMEOUT_S = 60.0


class AsyncStage:
    """One controller. Creating it does no I/O. While a `lease()` block of this object is open,
    every operation carries its Lease-Id, and raises LeaseLost once the lease has been lost."""

    def __init__(self, transport: Transport, controller_id: str) -> None:
        self.id = controller_id
        self._transport = transport
        self.path = "/controllers/" + quote(controller_id, safe="")
        self.lease_in_use: AsyncLease | None = None

    def __repr__(self) -> str:
        return f"AsyncStage({self.id!r})"

    # ---- reading ------------------------------------------------------------------------------

    async def state(self) -> ControllerState:
        return ControllerState.from_json(await self._transport.json("GET", self.path))

    async def positions(self) -> dict[str, float | None]:
        """Axis letter -> micrometres, from the gateway's latest snapshot (no serial traffic)."""
        return (await self.state()).positions

    # ---- motion -------------------------------------------------------------------------------

    async def move(
        self, axes: Mapping[str, float], *, wait: bool = False, timeout_s: float = DEFAULT_MOVE_TIMEOUT_S
    ) -> MoveResult:
        """Moves to absolute positions (axis -> um). With `wait`, returns when the stage stopped,
        with the positions read back; `result.arrived()` tells whether it reached the target (a
        HALT from anyone stops it short, and the call still returns)."""
        target = {a: float(v) for a, v in axes.items()}
        return await self._move(target, "absolute", wait, timeout_s, target)

    async def move_relative(
        self, axes: Mapping[str, float], *, wait: bool = False, timeout_s: float = DEFAULT_MOVE_TIMEOUT_S
    ) -> MoveResult:
        """Moves by distances (axis -> um); as move()."""
        return await self._move({a: float(v) for a, v in axes.items()}, "relative", wait, timeout_s, None)

    async def _move(
        self,
        axes: dict[str, float],
        mode: str,
        wait: bool,
        timeout_s: float,
        target: dict[str, float] | None,
    ) -> MoveResult:
        body: dict[str, Any] = {"axes": axes, "mode": mode, "wait": wait}
        if wait:
            body["timeout_ms"] = max(1, round(timeout_s * 1000))
        answer = await self._post("move", body, request_timeout_s=timeout_s + WAIT_MARGIN_S if wait else None)
        return MoveResult.from_json(answer, target)

    async def home(self, axes: Iterable[str] | None = None) -> OperationResult:
        """Drives axes (default: every motor axis) towards home; answers once the controller took
        the command. By default home lies beyond travel: the stage runs to its limit switch."""
        body = {"axes": list(axes)} if axes is not None else {}
        return OperationResult.from_json(await self._post("home", body))

    async def zero(self) -> OperationResult:
        """The current position of every axis becomes 0."""
        return OperationResult.from_json(await self._post("zero", {}))

    async def here(self, axes: Mapping[str, float]) -> OperationResult:
        """Calls the current position of the given axes these values (um)."""
        return OperationResult.from_json(await self._post("here", {"axes": dict(axes)}))

    async def speed(self, axes: Mapping[str, float]) -> OperationResult:
        """Sets the maximum speed of axes in mm/s."""
        return OperationResult.from_json(await self._post("speed", {"axes": dict(axes)}))

    async def ttl(
        self,
        *,
        in0_mode: int | None = None,
        out0_mode: int | None = None,
        output_high: bool | None = None,
    ) -> OperationResult:
        """TTL IN0 / OUT0 modes, or the output level (not together with out0_mode)."""
        body = {
            k: v
            for k, v in (("in0_mode", in0_mode), ("out0_mode", out0_mode), ("output_high", output_high))
            if v is not None
        }
        return OperationResult.from_json(await self._post("ttl", body))

    async def halt(self) -> OperationResult:
        """Stops every axis now. Always allowed, also on a controller someone else leased."""
        return OperationResult.from_json(await self._post("halt", {}, check_lease=False))

    def lease(self, *, ttl_s: int = 60, holder: str | None = None, renew_every_s: float | None = None) -> AsyncLease:
        """`async with stage.lease(ttl_s=30):` holds the controller exclusively for the block,
        renewing the lease every `renew_every_s` (default a third of `ttl_s`), and releases it at
        the end."""
        from .leases import AsyncLease

        return AsyncLease(self, self._transport, ttl_s=ttl_s, holder=holder, renew_every_s=renew_every_s)

    async def lease_info(self) -> LeaseInfo | None:
        """Who holds this controller's lease and until when (never its id); None when free."""
        try:
            return LeaseInfo.from_json(await self._transport.json("GET", self.path + "/lease"))
        except UnknownController:
            raise
        except NotFound:  # the controller exists and nobody holds it
            return None

    async def force_release_lease(self) -> None:
        """Admin only: ends whoever's lease this controller has (its holder's next renewal is
        refused, and its block raises LeaseLost)."""
        await self._transport.request("DELETE", self.path + "/lease", params={"force": True})

    # ---- the request --------------------------------------------------------------------------

    def lease_headers(self) -> dict[str, str]:
        lease = self.lease_in_use
        return {"Lease-Id": lease.lease_id} if lease is not None and lease.lease_id else {}

    async def _post(
        self, operation: str, body: dict[str, Any], *, request_timeout_s: float | None = None, check_lease: bool = True
    ) -> Any:
        if check_lease and self.lease_in_use is not None:
            self.lease_in_use.raise_if_lost()
        return await self._transport.json(
            "POST",
            f"{self.path}/{operation}",
            json=body,
            headers=self.lease_headers(),
            request_timeout_s=request_timeout_s,
        )
