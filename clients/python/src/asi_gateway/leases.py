"""Leases as async context managers that renew themselves and release on exit."""

from __future__ import annotations

import asyncio
import contextlib
import logging
from typing import TYPE_CHECKING

from .models import LeaseGrant
from .problems import GatewayError, GatewayUnreachable, InvalidState, LeaseLost, Problem
from .transport import Transport

if TYPE_CHECKING:
    from .stage import AsyncStage

log = logging.getLogger(__name__)


class AsyncLease:
    """Exclusive control of one controller for the length of an `async with` block.

    On entry it takes the lease (409 Leased when someone else holds it, Busy while earlier jobs
    hold the controller); while the block runs, a task renews it every `renew_every_s`; on exit
    it stops renewing and releases it. If a renewal is refused (the lease expired, or an admin
    ended it), the lease is lost: the stage's next operation raises LeaseLost, and so does the
    end of the block, unless another exception is already on its way out.
    """

    def __init__(
        self,
        stage: AsyncStage,
        transport: Transport,
        *,
        ttl_s: int = 60,
        holder: str | None = None,
        renew_every_s: float | None = None,
    ) -> None:
        if ttl_s < 1:
            raise ValueError("ttl_s must be at least 1")
        self.stage = stage
        self.ttl_s = ttl_s
        self.holder = holder
        self.renew_every_s = renew_every_s if renew_every_s is not None else max(ttl_s / 3, 0.5)
        self.grant: LeaseGrant | None = None
        self.renewals = 0
        self.lost: LeaseLost | None = None
        self._transport = transport
        self._renewer: asyncio.Task[None] | None = None

    @property
    def lease_id(self) -> str | None:
        return self.grant.lease_id if self.grant is not None else None

    async def __aenter__(self) -> AsyncLease:
        if self.stage.lease_in_use is not None:
            raise RuntimeError(f"{self.stage.id}: a lease block of this stage object is already open")
        body: dict[str, object] = {"ttl_s": self.ttl_s}
        if self.holder is not None:
            body["holder"] = self.holder
        answer = await self._transport.json("POST", self.stage.path + "/lease", json=body)
        self.grant = LeaseGrant.from_json(answer)
        self.stage.lease_in_use = self
        self._renewer = asyncio.create_task(self._renew_forever(), name=f"lease-renewal-{self.stage.id}")
        return self

    async def __aexit__(self, exc_type: type[BaseException] | None, *exc: object) -> None:
        if self._renewer is not None:
            self._renewer.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._renewer
        self.stage.lease_in_use = None
        if self.lost is not None:
            if exc_type is None:
                raise self.lost
            return
        try:
            await self._transport.request(
                "DELETE", self.stage.path + "/lease", headers={"Lease-Id": self.lease_id or ""}
            )
        except InvalidState:
            pass  # it expired just now: nothing left to release
        except GatewayError as e:
            if exc_type is None:
                raise
            # The block's own exception matters more; the lease expires by itself.
            log.warning("%s: could not release the lease: %s", self.stage.id, e)

    def raise_if_lost(self) -> None:
        if self.lost is not None:
            raise self.lost

    async def renew(self) -> LeaseGrant:
        """Renews now (the block does this by itself); raises LeaseLost when refused."""
        try:
            answer = await self._transport.json(
                "POST",
                self.stage.path + "/lease/renew",
                json={"ttl_s": self.ttl_s},
                headers={"Lease-Id": self.lease_id or ""},
            )
        except InvalidState as e:
            self.lost = LeaseLost(e.body)
            raise self.lost from e
        self.grant = LeaseGrant.from_json(answer)
        self.renewals += 1
        return self.grant

    async def _renew_forever(self) -> None:
        while True:
            await asyncio.sleep(self.renew_every_s)
            try:
                await self.renew()
            except LeaseLost:
                log.warning("%s: lease lost: %s", self.stage.id, self.lost)
                return
            except (GatewayUnreachable, Problem) as e:
                # Transient (the gateway is restarting, a 503): try again at the next tick; the
                # lease only ends when a renewal is refused.
                log.warning("%s: lease renewal failed, will retry: %s", self.stage.id, e)
