"""The pymmcore-plus devices (asi_gateway.micromanager) in a UniMMCore against the real gateway:
setXYPosition / waitForDevice / getXYPosition, the focus stage, stop, a refused move raised by
waitForDevice, and a multi-position MDA with a pure-Python demo camera that records where the
stage was at each snap."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from datetime import timedelta
from typing import Any

import numpy as np
import pytest
import useq
from gateway_process import TOKENS, RunningGateway
from pymmcore_plus.experimental.unicore import SimpleCameraDevice, UniMMCore

from asi_gateway import Gateway, Leased
from asi_gateway.micromanager import GatewayXYStage, GatewayZStage

TOLERANCE_UM = 1.0


class DemoCamera(SimpleCameraDevice):
    """A 64 x 64 noise camera that notes where the XY stage was at each snap (`snapped_at`)."""

    def __init__(self, where: Callable[[], tuple[float, float]]) -> None:
        super().__init__()
        self._where = where
        self.snapped_at: list[tuple[float, float]] = []
        self._exposure = 10.0
        self._rng = np.random.default_rng(0)

    def get_exposure(self) -> float:
        return self._exposure

    def set_exposure(self, exposure: float) -> None:
        self._exposure = exposure

    def dtype(self) -> Any:
        return np.uint16

    def sensor_shape(self) -> tuple[int, int]:
        return (64, 64)

    def snap(self, buffer: np.ndarray[Any, Any]) -> Mapping[str, Any]:
        buffer[:] = self._rng.integers(0, 4096, size=buffer.shape, dtype=np.uint16)
        self.snapped_at.append(self._where())
        return {}


@dataclass
class Rig:
    mmc: UniMMCore
    gateway: Gateway
    camera: DemoCamera


@pytest.fixture
def rig(gateway: RunningGateway) -> Iterator[Rig]:
    gw = Gateway(gateway.url, token=TOKENS["operator"])
    mmc = UniMMCore()
    xy = GatewayXYStage(gw, "sim1")
    mmc.loadPyDevice("XY", xy)
    mmc.loadPyDevice("Z", GatewayZStage(gw, "sim1"))
    camera = DemoCamera(xy.get_position_um)
    mmc.loadPyDevice("Camera", camera)
    mmc.initializeAllDevices()
    mmc.setXYStageDevice("XY")
    mmc.setFocusDevice("Z")
    mmc.setCameraDevice("Camera")
    mmc.setTimeoutMs(120_000)
    mmc.setAutoShutter(False)  # no shutter in this setup
    yield Rig(mmc, gw, camera)
    mmc.unloadAllDevices()
    gw.close()


def test_set_wait_get_xy_and_z(rig: Rig) -> None:
    mmc, gw = rig.mmc, rig.gateway
    mmc.setXYPosition(300.0, -200.0)
    assert mmc.deviceBusy("XY")  # the move runs in the background
    mmc.waitForDevice("XY")
    x, y = mmc.getXYPosition()
    assert abs(x - 300) <= TOLERANCE_UM and abs(y + 200) <= TOLERANCE_UM
    mmc.setPosition(25.0)
    mmc.waitForDevice("Z")
    assert abs(mmc.getPosition() - 25) <= TOLERANCE_UM
    mmc.setRelativeXYPosition(100.0, 0.0)
    mmc.waitForSystem()
    assert abs(mmc.getXYPosition()[0] - 400) <= TOLERANCE_UM
    # The gateway agrees.
    state = gw.get_controller("sim1")
    deadline = time.monotonic() + 30
    while abs((state.positions["X"] or 0) - 400) > TOLERANCE_UM:
        assert time.monotonic() < deadline
        time.sleep(0.1)
        state = gw.get_controller("sim1")


def test_stop_halts_a_long_move(rig: Rig) -> None:
    mmc = rig.mmc
    mmc.setXYPosition(0.0, 0.0)
    mmc.waitForDevice("XY")
    mmc.setXYPosition(50000.0, 0.0)
    deadline = time.monotonic() + 30
    while mmc.getXYPosition()[0] < 300:
        assert time.monotonic() < deadline, "the stage never moved"
        time.sleep(0.05)
    mmc.stop("XY")
    mmc.waitForDevice("XY")
    x, _ = mmc.getXYPosition()
    assert 300 <= x < 50000 - 1000


def test_a_refused_move_raises_from_wait_for_device(gateway: RunningGateway, rig: Rig) -> None:
    mmc = rig.mmc
    with Gateway(gateway.url, token=TOKENS["admin"]) as other, other.stage("sim1").lease(ttl_s=30):
        mmc.setXYPosition(10.0, 10.0)
        with pytest.raises(Leased):
            mmc.waitForDevice("XY")
        assert not mmc.deviceBusy("XY")


def test_mda_over_the_gateway(rig: Rig) -> None:
    mmc = rig.mmc
    positions = [useq.AbsolutePosition(x=x, y=y, z=z) for x, y, z in [(0, 0, 0), (500, 250, 10), (-400, 300, 5)]]
    sequence = useq.MDASequence(
        stage_positions=tuple(positions), time_plan=useq.TIntervalLoops(interval=timedelta(0), loops=2)
    )
    frames: list[tuple[useq.MDAEvent, dict[str, Any], tuple[int, ...]]] = []
    lock = threading.Lock()

    def on_frame(image: np.ndarray[Any, Any], event: useq.MDAEvent, meta: dict[str, Any]) -> None:
        with lock:
            frames.append((event, dict(meta), image.shape))

    mmc.mda.events.frameReady.connect(on_frame)
    mmc.mda.run(sequence)
    camera = rig.camera
    assert len(frames) == len(camera.snapped_at) == 6
    for (event, meta, shape), (snap_x, snap_y) in zip(frames, camera.snapped_at, strict=True):
        assert shape == (64, 64)
        assert event.x_pos is not None and event.y_pos is not None and event.z_pos is not None
        # The stage was at the event's position when the camera snapped, and the frame says so.
        assert abs(snap_x - event.x_pos) <= TOLERANCE_UM and abs(snap_y - event.y_pos) <= TOLERANCE_UM
        recorded = meta["position"]
        assert abs(recorded["x"] - event.x_pos) <= TOLERANCE_UM and abs(recorded["y"] - event.y_pos) <= TOLERANCE_UM
        assert abs(recorded["z"] - event.z_pos) <= TOLERANCE_UM
    assert {(e.x_pos, e.y_pos) for e, _, _ in frames} == {(p.x, p.y) for p in positions}
