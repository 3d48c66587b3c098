"""pymmcore-plus stage devices for a gateway controller (install the extra:
`asi-gateway[micromanager]`): pure-Python devices for pymmcore-plus's UniMMCore, so that
`core.setXYPosition`, `getXYPosition`, `waitForDevice`, `stop` and the MDA engine drive a stage
behind the gateway.

    from pymmcore_plus.experimental.unicore import UniMMCore
    from asi_gateway import Gateway
    from asi_gateway.micromanager import GatewayXYStage, GatewayZStage

    gw = Gateway("http://127.0.0.1:8080")
    core = UniMMCore()
    core.loadPyDevice("XY", GatewayXYStage(gw, "sim1"))
    core.loadPyDevice("Z", GatewayZStage(gw, "sim1"))
    core.initializeAllDevices()
    core.setXYStageDevice("XY")
    core.setFocusDevice("Z")
    core.setTimeoutMs(120_000)  # waitForDevice's limit; the default 5 s is short for long moves

A move is the gateway's waited move, run in the background on the client's event loop: the
device is busy until it ended and the pushed positions show where the stage stopped, so
`waitForDevice` returns with `getXYPosition` current. A move the gateway refused (leased,
out of range) raises its problem from `waitForDevice`. `stop` HALTs the controller, which stops
all of its axes. Positions come from the gateway's position topic, never from polling it.
"""

from __future__ import annotations

from concurrent.futures import Future

from pymmcore_plus.experimental.unicore import StageDevice, XYStageDevice

from .models import MoveResult
from .positions import PositionFeed
from .sync import Gateway

# Waited moves may take long; Micro-Manager's own timeout (core.setTimeoutMs) bounds the wait.
MOVE_TIMEOUT_S = 600.0
# How long the pushed positions may trail a move's answer (the gateway polls a moving stage every 100 ms).
CATCH_UP_S = 2.0


class _Motion:
    """One controller's moves for Micro-Manager: a waited move in the background, `busy()` until
    it ended and the feed shows it."""

    def __init__(self, gateway: Gateway, controller: str, tolerance_um: float) -> None:
        self.gateway = gateway
        self.stage = gateway.aio.stage(controller)
        self.feed = PositionFeed(gateway.aio, controller)
        self.tolerance_um = tolerance_um
        self._move: Future[MoveResult] | None = None

    def start_feed(self) -> None:
        self.gateway.run_async(self.feed.start())

    def stop_feed(self) -> None:
        self.gateway.run_async(self.feed.stop())

    def position(self, axis: str) -> float:
        if axis not in self.feed.latest:
            raise RuntimeError(f"{self.stage.id}: no position of {axis} yet (is the device initialized?)")
        return self.feed.latest[axis]

    def move(self, target: dict[str, float]) -> None:
        self._move = self.gateway.start_async(self._move_and_settle(target))

    async def _move_and_settle(self, target: dict[str, float]) -> MoveResult:
        result = await self.stage.move(target, wait=True, timeout_s=MOVE_TIMEOUT_S)
        reached = {axis: result.positions[axis] for axis in target if axis in result.positions}
        await self.feed.wait_for(reached, self.tolerance_um, CATCH_UP_S)
        return result

    def busy(self) -> bool:
        """True while a move runs; a move that failed raises its error here, once."""
        move = self._move
        if move is None:
            return False
        if not move.done():
            return True
        self._move = None
        move.result()  # raises the gateway's problem
        return False

    def halt(self) -> None:
        self.gateway.run_async(self.stage.halt())

    def here(self, axes: dict[str, float]) -> None:
        self.gateway.run_async(self.stage.here(axes))

    def home(self, axes: list[str]) -> None:
        self.gateway.run_async(self.stage.home(axes))


class GatewayXYStage(XYStageDevice):
    """The X and Y axes of a gateway controller as a Micro-Manager XY stage (micrometres)."""

    def __init__(self, gateway: Gateway, controller: str, *, tolerance_um: float = 1.0) -> None:
        super().__init__()
        self.controller = controller
        self.motion = _Motion(gateway, controller, tolerance_um)

    def initialize(self) -> None:
        self.motion.start_feed()

    def shutdown(self) -> None:
        self.motion.stop_feed()

    def set_position_um(self, x: float, y: float) -> None:
        self.motion.move({"X": x, "Y": y})

    def get_position_um(self) -> tuple[float, float]:
        return self.motion.position("X"), self.motion.position("Y")

    def set_origin_x(self) -> None:
        self.motion.here({"X": 0})

    def set_origin_y(self) -> None:
        self.motion.here({"Y": 0})

    def set_origin(self) -> None:
        self.motion.here({"X": 0, "Y": 0})

    def home(self) -> None:
        self.motion.home(["X", "Y"])

    def stop(self) -> None:
        self.motion.halt()

    def busy(self) -> bool:
        return self.motion.busy()


class GatewayZStage(StageDevice):
    """One axis of a gateway controller (Z by default) as a Micro-Manager focus stage."""

    def __init__(self, gateway: Gateway, controller: str, *, axis: str = "Z", tolerance_um: float = 1.0) -> None:
        super().__init__()
        self.controller = controller
        self.axis = axis.upper()
        self.motion = _Motion(gateway, controller, tolerance_um)

    def initialize(self) -> None:
        self.motion.start_feed()

    def shutdown(self) -> None:
        self.motion.stop_feed()

    def set_position_um(self, val: float) -> None:
        self.motion.move({self.axis: val})

    def get_position_um(self) -> float:
        return self.motion.position(self.axis)

    def set_origin(self) -> None:
        self.motion.here({self.axis: 0})

    def home(self) -> None:
        self.motion.home([self.axis])

    def stop(self) -> None:
        self.motion.halt()

    def busy(self) -> bool:
        return self.motion.busy()
