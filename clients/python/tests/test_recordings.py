"""Recordings through the client against the real gateway: cam1 is an ms2000-sim with a report port
whose control socket makes trigger edges (`pulse N RATE_HZ`), each a recorded frame."""

from __future__ import annotations

import asyncio
import time
from pathlib import Path

import h5py
import pytest
from gateway_process import TOKENS, RunningGateway

from asi_gateway import AsyncGateway, Gateway, InvalidState, InvalidValue, UnknownRecording

GRID = {"grid": {"columns": 3, "rows": 1, "column_step_mm": 1, "row_step_mm": -1}, "a1": {"X": 0, "Y": 0}}


def test_record_stop_and_read_back(operator: Gateway, gateway: RunningGateway, tmp_path: Path) -> None:
    operator.stage("cam1").move({"X": 1500, "Y": -500}, wait=True)
    started = operator.recordings.start("cam1", "plate 1", metadata={"camera": "cam0"})
    assert started.state == "recording" and started.frames == 0 and started.job is None
    gateway.cam.pulse(50, 200)
    assert operator.recordings.wait(started.id, frames=50, timeout_s=30).frames == 50
    stopped = operator.recordings.stop(started.id)
    assert stopped.ended and stopped.state == "stopped" and (stopped.frames, stopped.losses) == (50, 0)
    assert stopped.metadata == {"camera": "cam0"} and stopped.axes == "XYZ"
    assert started.id in [r.id for r in operator.recordings.list(controller="cam1", state="stopped")]

    frames = operator.recordings.dataframe(started.id)
    assert list(frames.index) == list(range(50))
    assert ((frames["X_um"] - 1500).abs() < 0.5).all() and ((frames["Y_um"] + 500).abs() < 0.5).all()
    rows = operator.recordings.rows(started.id)
    assert [r["index"] for r in rows] == list(range(50)) and all(r["loss"] is None for r in rows)
    assert [r["X_counts"] for r in rows] == list(frames["X_counts"])

    size = operator.recordings.download(started.id, tmp_path / "frames.h5", format="hdf5")
    assert size == (tmp_path / "frames.h5").stat().st_size > 0
    with h5py.File(tmp_path / "frames.h5", "r") as f:
        assert f.attrs["id"] == started.id and list(f["index"][:]) == list(range(50))
    operator.recordings.download(started.id, tmp_path / "frames.csv")
    assert (tmp_path / "frames.csv").read_text().splitlines()[0].startswith("index,time_us,loss,X_um")

    operator.recordings.delete(started.id)
    with pytest.raises(UnknownRecording):
        operator.recordings.get(started.id)


def test_refusals_are_problems(operator: Gateway) -> None:
    with pytest.raises(InvalidState, match="report port"):
        operator.recordings.start("sim2", "no report port")
    with pytest.raises(InvalidValue) as bad:
        operator.recordings.start("cam1", "mode 0", ttl_in_mode=0)
    assert bad.value.field == "arm.ttl_in_mode"
    with pytest.raises(ValueError, match="format"):
        operator.recordings.download("r-x", "x.xlsx", format="xlsx")


def test_a_job_that_records_its_run(operator: Gateway, gateway: RunningGateway) -> None:
    # Advanced by triggers: each one is a frame at the well the stage stands at.
    job = operator.jobs.submit("cam1", "array", {**GRID, "mode": "host", "advance": "ttl", "record": True})
    for done in (1, 2):
        deadline = time.monotonic() + 60
        while True:
            current = operator.jobs.get(job.id)
            if current.progress.steps_done == done and current.progress.waiting_for == "ttl":
                break
            assert not current.ended, current.reason
            assert time.monotonic() < deadline, f"the job does not wait for a trigger: {current.progress}"
            time.sleep(0.1)
        gateway.cam.pulse(1, 10)
    assert operator.jobs.wait(job.id, timeout_s=60).state == "succeeded"
    (recording,) = operator.recordings.list(job=job.id)
    assert recording.job == job.id and (recording.frames, recording.losses) == (2, 0)
    steps = [e for e in operator.jobs.events(job.id) if e["type"] == "step"]
    frames = operator.recordings.dataframe(recording.id)
    for k in (0, 1):
        assert abs(frames["X_um"][k] - steps[k]["position"]["X"]) < 0.5


def test_async_interface(gateway: RunningGateway) -> None:
    async def scenario() -> None:
        async with AsyncGateway(gateway.url, token=TOKENS["operator"]) as gw:
            started = await gw.recordings.start("cam1", "async", max_frames=5)
            await asyncio.to_thread(gateway.cam.pulse, 8, 100)
            ended = await gw.recordings.wait(started.id, timeout_s=30)
            assert ended.state == "stopped" and ended.frames == 5 and "max_frames" in ended.reason
            assert len(await gw.recordings.rows(started.id)) == 5

    asyncio.run(scenario())
