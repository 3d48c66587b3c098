"""Position recordings (/api/v1/recordings): start, stop, list, wait, and the frames as a file,
as rows, or as a pandas DataFrame indexed by frame.

A recording keeps the encoder positions a controller with a report port sends at each trigger
(a camera's exposure) on its IN0 input: frame N is the N-th trigger since the start, and a loss
marker row stands where frames were lost before it. Jobs record their runs with `"record": true`
in their spec; `list(job=...)` finds those recordings.
"""

from __future__ import annotations

import asyncio
import builtins
import io
import json
import time
from collections.abc import Callable, Mapping
from datetime import datetime
from pathlib import Path
from typing import Any
from urllib.parse import quote

from .jobs import LeaseArg, lease_header
from .leases import AsyncLease
from .models import JsonObject, Recording
from .transport import Transport

FORMATS = ("csv", "jsonl", "hdf5")
WAIT_POLL_S = 0.2
# A download of a long recording: the gateway streams it, but an HDF5 file is written first.
DOWNLOAD_TIMEOUT_S = 600.0

Moment = datetime | int | None  # a datetime, or milliseconds since the Unix epoch


def _ms(moment: Moment) -> int | None:
    if isinstance(moment, datetime):
        return int(moment.timestamp() * 1000)
    return moment


class AsyncRecordings:
    def __init__(
        self, transport: Transport, lease_held_on: Callable[[str], AsyncLease | None] = lambda _: None
    ) -> None:
        self._transport = transport
        self._lease_held_on = lease_held_on

    async def start(
        self,
        controller: str,
        name: str,
        *,
        ttl_in_mode: int | None = None,
        max_frames: int | None = None,
        max_s: float | None = None,
        metadata: Mapping[str, Any] | None = None,
        lease: LeaseArg = None,
    ) -> Recording:
        """Arms the controller's trigger input (TTL X=1, or `ttl_in_mode`) and records every frame
        from now on, until stop(), `max_frames` or `max_s`. `lease` defaults to this client's open
        lease block on the controller (a leased controller records for its holder only)."""
        body: dict[str, Any] = {"name": name}
        if ttl_in_mode is not None:
            body["arm"] = {"ttl_in_mode": ttl_in_mode}
        if max_frames is not None:
            body["max_frames"] = max_frames
        if max_s is not None:
            body["max_s"] = max_s
        if metadata is not None:
            body["metadata"] = dict(metadata)
        headers = lease_header(lease if lease is not None else self._lease_held_on(controller))
        answer = await self._transport.json(
            "POST", f"/controllers/{quote(controller, safe='')}/recordings", json=body, headers=headers
        )
        return Recording.from_json(answer)

    async def stop(self, recording_id: str) -> Recording:
        """Stops it (the input mode put back) and returns the stored record; an ended recording's
        stop returns its record as it is."""
        return Recording.from_json(await self._transport.json("POST", _path(recording_id) + "/stop"))

    async def get(self, recording_id: str) -> Recording:
        return Recording.from_json(await self._transport.json("GET", _path(recording_id)))

    async def list(
        self,
        *,
        controller: str | None = None,
        state: str | None = None,
        job: str | None = None,
        since: Moment = None,
        until: Moment = None,
        limit: int | None = None,
    ) -> builtins.list[Recording]:
        """Newest first: by controller, state ("recording", "stopped", "failed"), the job that made
        them, and start time (`since` inclusive, `until` exclusive)."""
        params = {
            "controller": controller,
            "state": state,
            "job": job,
            "since": _ms(since),
            "until": _ms(until),
            "limit": limit,
        }
        answer = await self._transport.json("GET", "/recordings", params=params)
        return [Recording.from_json(r) for r in answer["recordings"]]

    async def delete(self, recording_id: str) -> None:
        """Deletes an ended recording and its frames (a recording that records: InvalidState)."""
        await self._transport.request("DELETE", _path(recording_id))

    async def wait(self, recording_id: str, *, frames: int | None = None, timeout_s: float | None = None) -> Recording:
        """Returns once the recording has ended, or has stored at least `frames` frames; TimeoutError
        after `timeout_s`. Frames are stored every 250 ms, so this sees them within about that."""
        deadline = None if timeout_s is None else time.monotonic() + timeout_s
        while True:
            record = await self.get(recording_id)
            if record.ended or (frames is not None and record.frames >= frames):
                return record
            if deadline is not None and time.monotonic() >= deadline:
                raise TimeoutError(f"recording {recording_id}: {record.frames} frames, still recording")
            await asyncio.sleep(WAIT_POLL_S)

    async def download(self, recording_id: str, target: str | Path, *, format: str = "csv") -> int:
        """The frames as a file, streamed: CSV (a header, then one row per frame or loss marker,
        `index` first), JSON Lines (the same columns as keys) or HDF5 (one dataset per column, the
        record in the root's attributes). Returns the file's size."""
        if format not in FORMATS:
            raise ValueError(f"format must be one of {', '.join(FORMATS)}")
        return await self._transport.download(
            _path(recording_id) + "/frames",
            Path(target),
            params={"format": format},
            request_timeout_s=DOWNLOAD_TIMEOUT_S,
        )

    async def rows(self, recording_id: str) -> builtins.list[JsonObject]:
        """Every row in order, as dicts: `index`, `time_us` (the gateway's receive time, us since
        the epoch), `loss` (None for a frame; the kind of loss for a marker), then `<axis>_um` and
        `<axis>_counts` per axis."""
        response = await self._transport.request(
            "GET", _path(recording_id) + "/frames", params={"format": "jsonl"}, request_timeout_s=DOWNLOAD_TIMEOUT_S
        )
        return [json.loads(line) for line in response.text.splitlines() if line]

    async def dataframe(self, recording_id: str, *, losses: bool = False) -> Any:
        """The frames as a pandas DataFrame indexed by frame index (`pip install asi-gateway[pandas]`):
        columns time_us and, per axis, `<axis>_um` and `<axis>_counts`. Loss markers are left out
        unless `losses` (then `loss` says where frames were lost, and the index is a column)."""
        try:
            import pandas
        except ImportError as e:
            raise ImportError("dataframe() needs pandas: pip install 'asi-gateway[pandas]'") from e
        response = await self._transport.request(
            "GET", _path(recording_id) + "/frames", params={"format": "csv"}, request_timeout_s=DOWNLOAD_TIMEOUT_S
        )
        table = await asyncio.to_thread(pandas.read_csv, io.BytesIO(response.content))
        if losses:
            return table
        return table[table["loss"].isna()].drop(columns="loss").set_index("index")


def _path(recording_id: str) -> str:
    return "/recordings/" + quote(recording_id, safe="")
