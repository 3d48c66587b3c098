"""The gateway's JSON bodies as frozen dataclasses, hand-written from openapi/openapi.yaml.

Each class names the schema it mirrors (`SCHEMA`); tests/test_schema.py checks that its fields
are exactly that schema's properties and that the fields without a default are exactly its
required ones, so a change to the contract fails the tests until this file follows. `raw` keeps
the whole body as received: a newer gateway's extra fields are not lost, and nested objects
this package does not type (the TTL modes, a plan's commands) are plain JSON.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

JsonObject = dict[str, Any]

TERMINAL_JOB_STATES = frozenset({"succeeded", "failed", "cancelled"})


@dataclass(frozen=True)
class Identity:
    SCHEMA: ClassVar[str] = "ControllerState.identity"

    version: str
    version_raw: str
    build: str
    motor_axes: str
    modules: tuple[str, ...]
    module_lines: tuple[str, ...]
    ring_buffer_size: int

    @classmethod
    def from_json(cls, d: JsonObject) -> Identity:
        return cls(
            version=d["version"],
            version_raw=d["version_raw"],
            build=d["build"],
            motor_axes=d["motor_axes"],
            modules=tuple(d["modules"]),
            module_lines=tuple(d["module_lines"]),
            ring_buffer_size=d["ring_buffer_size"],
        )


@dataclass(frozen=True)
class AxisState:
    SCHEMA: ClassVar[str] = "ControllerState.axes[]"

    axis: str
    position_um: float | None
    busy: bool
    counts_per_mm: float | None
    soft_limits_um: JsonObject

    @classmethod
    def from_json(cls, d: JsonObject) -> AxisState:
        return cls(d["axis"], d["position_um"], d["busy"], d["counts_per_mm"], d["soft_limits_um"])


@dataclass(frozen=True)
class ControllerState:
    """One controller's latest snapshot (GET /api/v1/controllers/{id})."""

    SCHEMA: ClassVar[str] = "ControllerState"

    id: str
    state: str
    port: str
    busy: bool
    identity: Identity | None
    axes: tuple[AxisState, ...]
    ttl: JsonObject
    crisp: JsonObject | None
    last_error: JsonObject | None
    error_log: JsonObject
    report_port: str
    last_attempt: str | None
    next_retry: str | None
    halted: JsonObject | None  # {"by", "at"}: a HALT latched it (jobs there wait); None when not
    updated: str
    # The shared port (pty, TCP) and the programs connected to it; REST only (not in state events).
    share: JsonObject | None = None
    raw: JsonObject = field(default_factory=dict, repr=False, compare=False)

    @classmethod
    def from_json(cls, d: JsonObject) -> ControllerState:
        return cls(
            id=d["id"],
            state=d["state"],
            port=d["port"],
            busy=d["busy"],
            identity=Identity.from_json(d["identity"]) if d["identity"] is not None else None,
            axes=tuple(AxisState.from_json(a) for a in d["axes"]),
            ttl=d["ttl"],
            crisp=d["crisp"],
            last_error=d["last_error"],
            error_log=d["error_log"],
            report_port=d["report_port"],
            last_attempt=d["last_attempt"],
            next_retry=d["next_retry"],
            halted=d["halted"],
            updated=d["updated"],
            share=d.get("share"),
            raw=d,
        )

    @property
    def connected(self) -> bool:
        return self.state == "connected"

    @property
    def positions(self) -> dict[str, float | None]:
        """Axis letter -> micrometres (None while unknown)."""
        return {a.axis: a.position_um for a in self.axes}


@dataclass(frozen=True)
class OperationResult:
    """The answer of halt, home, zero, here, speed, ttl, dac and led."""

    SCHEMA: ClassVar[str] = "OperationDone"

    id: str
    operation: str
    request_id: str
    latency_us: int
    raw: JsonObject = field(default_factory=dict, repr=False, compare=False)

    @classmethod
    def from_json(cls, d: JsonObject) -> OperationResult:
        return cls(d["id"], d["operation"], d["request_id"], d["latency_us"], raw=d)


@dataclass(frozen=True)
class MoveResult:
    """The answer of a move. With `wait`, `positions` were read back after the stage stopped
    (axis -> um; empty without `wait`). `target` is what an absolute move asked for."""

    SCHEMA: ClassVar[str] = "MoveResult"
    CLIENT_FIELDS: ClassVar[tuple[str, ...]] = ("target",)  # not in the body: what the client asked

    id: str
    operation: str
    request_id: str
    waited: bool
    positions: dict[str, float]
    target: dict[str, float] | None = field(default=None, compare=False)
    raw: JsonObject = field(default_factory=dict, repr=False, compare=False)

    @classmethod
    def from_json(cls, d: JsonObject, target: dict[str, float] | None = None) -> MoveResult:
        positions = {p["axis"]: p["position_um"] for p in d["positions"]}
        return cls(d["id"], d["operation"], d["request_id"], d["waited"], positions, target, raw=d)

    def arrived(self, tolerance_um: float = 1.0) -> bool:
        """Whether a waited absolute move stopped within `tolerance_um` of its target on every
        axis (False when a HALT or a limit stopped it short)."""
        if not self.waited or self.target is None:
            raise ValueError("arrived() needs an absolute move made with wait=True")
        return all(
            axis in self.positions and abs(self.positions[axis] - um) <= tolerance_um
            for axis, um in self.target.items()
        )


@dataclass(frozen=True)
class LeaseGrant:
    """A lease as its holder sees it (with the `lease_id` to send as Lease-Id)."""

    SCHEMA: ClassVar[str] = "Lease"

    lease_id: str
    controller: str
    holder: str
    acquired: str
    expires: str
    expires_in_s: float

    @classmethod
    def from_json(cls, d: JsonObject) -> LeaseGrant:
        return cls(d["lease_id"], d["controller"], d["holder"], d["acquired"], d["expires"], d["expires_in_s"])


@dataclass(frozen=True)
class LeaseInfo:
    """A lease as everyone sees it (no id)."""

    SCHEMA: ClassVar[str] = "LeaseInfo"

    controller: str
    holder: str
    acquired: str
    expires: str
    expires_in_s: float

    @classmethod
    def from_json(cls, d: JsonObject) -> LeaseInfo:
        return cls(d["controller"], d["holder"], d["acquired"], d["expires"], d["expires_in_s"])


@dataclass(frozen=True)
class JobProgress:
    SCHEMA: ClassVar[str] = "JobProgress"

    steps_done: int
    steps_total: int
    percent: float
    current_step: str
    elapsed_s: float
    remaining_s: float | None
    waiting_for: str | None
    eta: str | None

    @classmethod
    def from_json(cls, d: JsonObject) -> JobProgress:
        return cls(
            steps_done=d["steps_done"],
            steps_total=d["steps_total"],
            percent=d["percent"],
            current_step=d["current_step"],
            elapsed_s=d["elapsed_s"],
            remaining_s=d["remaining_s"],
            waiting_for=d["waiting_for"],
            eta=d["eta"],
        )

    @classmethod
    def from_step_event(cls, d: JsonObject) -> JobProgress:
        """A step event carries the progress flat, with the step's name; older stored steps may
        lack waiting_for and eta."""
        return cls(
            steps_done=d["steps_done"],
            steps_total=d["steps_total"],
            percent=d["percent"],
            current_step=d["name"],
            elapsed_s=d["elapsed_s"],
            remaining_s=d["remaining_s"],
            waiting_for=d.get("waiting_for"),
            eta=d.get("eta"),
        )


@dataclass(frozen=True)
class Job:
    """A job record (GET /api/v1/jobs/{id})."""

    SCHEMA: ClassVar[str] = "Job"

    id: str
    controller: str
    type: str
    state: str
    spec: JsonObject
    progress: JobProgress
    estimated_s: float
    path: str
    reason: str
    submitted_by: str
    request_id: str
    idempotency_key: str | None
    created: str
    started: str | None
    finished: str | None
    updated: str
    raw: JsonObject = field(default_factory=dict, repr=False, compare=False)

    @classmethod
    def from_json(cls, d: JsonObject) -> Job:
        return cls(
            id=d["id"],
            controller=d["controller"],
            type=d["type"],
            state=d["state"],
            spec=d["spec"],
            progress=JobProgress.from_json(d["progress"]),
            estimated_s=d["estimated_s"],
            path=d["path"],
            reason=d["reason"],
            submitted_by=d["submitted_by"],
            request_id=d["request_id"],
            idempotency_key=d["idempotency_key"],
            created=d["created"],
            started=d["started"],
            finished=d["finished"],
            updated=d["updated"],
            raw=d,
        )

    @property
    def ended(self) -> bool:
        return self.state in TERMINAL_JOB_STATES


@dataclass(frozen=True)
class JobPlan:
    """A dry run's answer: nothing was stored, nothing moved. `plan` holds the path, summary,
    steps, serial commands, estimate, bounds and warnings as JSON."""

    SCHEMA: ClassVar[str] = "JobPlan"

    dry_run: bool
    controller: str
    type: str
    plan: JsonObject

    @classmethod
    def from_json(cls, d: JsonObject) -> JobPlan:
        return cls(d["dry_run"], d["controller"], d["type"], d["plan"])

    @property
    def estimated_s(self) -> float:
        return float(self.plan["estimated_s"])

    @property
    def commands(self) -> list[str]:
        return list(self.plan["commands"])


@dataclass(frozen=True)
class JobUpdate:
    """What a progress callback receives: one event of the job's topic with the progress after it.
    `step` is the completed step's name for a step event, None for a state change."""

    job_id: str
    state: str
    progress: JobProgress
    step: str | None
    event: JsonObject


@dataclass(frozen=True)
class GcodeFile:
    SCHEMA: ClassVar[str] = "GcodeFile"

    id: str
    name: str
    bytes: int
    lines: int
    created: str

    @classmethod
    def from_json(cls, d: JsonObject) -> GcodeFile:
        return cls(d["id"], d["name"], d["bytes"], d["lines"], d["created"])


@dataclass(frozen=True)
class Recording:
    """A position recording (GET /api/v1/recordings/{id}): the encoder positions a controller with a
    report port sends at each trigger on its IN0 input, counted from 0, losses marked. `job` names
    the job whose run made it (a spec with "record": true)."""

    SCHEMA: ClassVar[str] = "Recording"

    id: str
    controller: str
    name: str
    state: str
    reason: str
    started: str
    stopped: str | None
    frames: int
    losses: int
    axes: str
    ttl_in_mode: int
    metadata: JsonObject
    max_frames: int | None
    max_s: float | None
    rate_hz: float | None
    job: str | None
    raw: JsonObject = field(default_factory=dict, repr=False, compare=False)

    @classmethod
    def from_json(cls, d: JsonObject) -> Recording:
        return cls(
            id=d["id"],
            controller=d["controller"],
            name=d["name"],
            state=d["state"],
            reason=d["reason"],
            started=d["started"],
            stopped=d["stopped"],
            frames=d["frames"],
            losses=d["losses"],
            axes=d["axes"],
            ttl_in_mode=d["ttl_in_mode"],
            metadata=d["metadata"],
            max_frames=d["max_frames"],
            max_s=d["max_s"],
            rate_hz=d["rate_hz"],
            job=d["job"],
            raw=d,
        )

    @property
    def ended(self) -> bool:
        return self.state != "recording"
