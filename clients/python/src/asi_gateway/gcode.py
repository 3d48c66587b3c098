"""G-code programs (/api/v1/gcode): upload, plan, preview, and run as a `gcode` job."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any
from urllib.parse import quote

from .jobs import AsyncJobs, LeaseArg
from .models import GcodeFile, Job, JsonObject
from .transport import Transport

Program = str | bytes | Path

# Planning a large program may take a while on the gateway's worker thread.
PLAN_TIMEOUT_S = 120.0


def _program_bytes(program: Program) -> bytes:
    if isinstance(program, Path):
        return program.read_bytes()
    return program.encode() if isinstance(program, str) else program


class AsyncGcode:
    def __init__(self, transport: Transport, jobs: AsyncJobs) -> None:
        self._transport = transport
        self._jobs = jobs

    async def upload(self, program: Program, *, name: str | None = None) -> GcodeFile:
        """Stores a program (text, bytes or a file path) on the gateway, as sent; plan it to see
        its errors. A Path's file name is the default name."""
        if name is None and isinstance(program, Path):
            name = program.name
        answer = await self._transport.json(
            "POST", "/gcode/files", content=_program_bytes(program), params={"name": name}
        )
        return GcodeFile.from_json(answer)

    async def files(self) -> list[GcodeFile]:
        answer = await self._transport.json("GET", "/gcode/files")
        return [GcodeFile.from_json(f) for f in answer["files"]]

    async def get(self, file_id: str) -> GcodeFile:
        return GcodeFile.from_json(await self._transport.json("GET", _file_path(file_id)))

    async def delete(self, file_id: str) -> None:
        await self._transport.request("DELETE", _file_path(file_id))

    async def plan(
        self,
        program: Program | None = None,
        *,
        file_id: str | None = None,
        moves: bool = True,
        options: Mapping[str, Any] | None = None,
    ) -> JsonObject:
        """The plan of a program (given, or uploaded: `file_id`) without any controller: moves,
        segments, estimated_s, bounds and warnings (`moves=False`: the summary only). A program
        error raises InvalidGcode with its line and column."""
        params = {**(options or {}), "moves": moves}
        if (program is None) == (file_id is None):
            raise ValueError("give either a program or a file_id")
        if file_id is not None:
            path = _file_path(file_id) + "/plan"
            answer = await self._transport.json("POST", path, params=params, request_timeout_s=PLAN_TIMEOUT_S)
        else:
            assert program is not None
            answer = await self._transport.json(
                "POST", "/gcode/plan", content=_program_bytes(program), params=params, request_timeout_s=PLAN_TIMEOUT_S
            )
        return dict(answer)

    async def preview_svg(self, program: Program | None = None, *, file_id: str | None = None, **params: Any) -> str:
        """The program's path drawn as SVG (`view`, `width_px`, `max_points` and the options)."""
        if (program is None) == (file_id is None):
            raise ValueError("give either a program or a file_id")
        if file_id is not None:
            response = await self._transport.request(
                "GET", _file_path(file_id) + "/preview.svg", params=params, request_timeout_s=PLAN_TIMEOUT_S
            )
        else:
            assert program is not None
            response = await self._transport.request(
                "POST",
                "/gcode/preview.svg",
                content=_program_bytes(program),
                params=params,
                request_timeout_s=PLAN_TIMEOUT_S,
            )
        return response.text

    async def run(
        self,
        controller: str,
        program: str | None = None,
        *,
        file_id: str | None = None,
        options: Mapping[str, Any] | None = None,
        lease: LeaseArg = None,
        idempotency_key: str | None = None,
    ) -> Job:
        """Submits a `gcode` job that traces the program (text, or an uploaded `file_id`) on the
        controller; follow it with jobs.wait()."""
        if (program is None) == (file_id is None):
            raise ValueError("give either a program or a file_id")
        spec: dict[str, Any] = {"program": program} if program is not None else {"file": file_id}
        if options:
            spec["options"] = dict(options)
        return await self._jobs.submit(controller, "gcode", spec, lease=lease, idempotency_key=idempotency_key)


def _file_path(file_id: str) -> str:
    return "/gcode/files/" + quote(file_id, safe="")
