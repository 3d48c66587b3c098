"""Errors: every problem+json `type` the gateway answers becomes an exception class of its own.

The gateway answers errors as RFC 9457 problem details whose `type` is a stable URI
(`https://asi-gateway.dev/problems/<kind>`, listed in openapi.yaml under
components.schemas.Problem). Each kind is one class below, named after it, so a script can
`except Leased:` instead of comparing strings. The classes are grouped by HTTP status where a
script would catch a group (`except NotFound:` covers unknown controller, job and file).

A test (tests/test_schema.py) fails when openapi.yaml lists a `type` that has no class here.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar

PROBLEM_BASE = "https://asi-gateway.dev/problems/"

# The standard members of a problem; everything else in the body is an extension member.
_STANDARD_MEMBERS = frozenset({"type", "title", "status", "detail", "instance", "request_id"})


class GatewayError(Exception):
    """Base of every error this package raises."""


class GatewayUnreachable(GatewayError):
    """The gateway could not be reached (connection refused, DNS, TLS handshake, timeout)."""


class UnexpectedResponse(GatewayError):
    """An answer that is neither a success nor a problem+json body (a proxy's error page, say)."""

    def __init__(self, status: int, body: str) -> None:
        super().__init__(f"HTTP {status}: {body[:300]}")
        self.status = status
        self.body = body


class Problem(GatewayError):
    """A problem+json answer. Subclasses stand for one `type` each; an unknown `type` (from a newer
    gateway) raises this class itself, with every field kept."""

    problem_type: ClassVar[str] = ""

    def __init__(self, body: Mapping[str, Any]) -> None:
        self.body: dict[str, Any] = dict(body)
        self.type: str = str(body.get("type", ""))
        self.title: str = str(body.get("title", ""))
        self.status: int = int(body.get("status", 0))
        self.detail: str = str(body.get("detail", ""))
        self.instance: str | None = body.get("instance")
        self.request_id: str | None = body.get("request_id")
        # Extension members (field, controller_code, line, ...), also readable as attributes below.
        self.extensions: dict[str, Any] = {k: v for k, v in body.items() if k not in _STANDARD_MEMBERS}
        super().__init__(f"{self.status} {self.title}: {self.detail}" if self.detail else self.title)

    @property
    def kind(self) -> str:
        """The last part of `type` ("leased")."""
        return self.type.removeprefix(PROBLEM_BASE)

    @property
    def field(self) -> str | None:
        """The offending request field ("axes.Q", "spec.colour"), when the gateway names one."""
        value = self.extensions.get("field")
        return value if isinstance(value, str) else None

    def __reduce__(self) -> tuple[Any, ...]:
        # Exceptions are rebuilt from their args when pickled; ours from the body.
        return (type(self), (self.body,))


# ---- groups ---------------------------------------------------------------------------------


class NotFound(Problem):
    """404: no such route, controller, job or file."""

    problem_type = PROBLEM_BASE + "not-found"


class Conflict(Problem):
    """409: the request does not fit the current state (module, motion, lease, job state)."""


class Unavailable(Problem):
    """503: try again later; `retry_after` is set when the gateway said when."""

    retry_after: float | None = None


# ---- one class per problem type (in the order of openapi.yaml) -------------------------------


class MalformedJson(Problem):
    problem_type = PROBLEM_BASE + "malformed-json"


class BadRequest(Problem):
    problem_type = PROBLEM_BASE + "bad-request"


class Unauthorized(Problem):
    """401: no token, or a token the gateway does not know."""

    problem_type = PROBLEM_BASE + "unauthorized"


class Forbidden(Problem):
    """403: the token's role is too low for this request."""

    problem_type = PROBLEM_BASE + "forbidden"


class CrossOrigin(Forbidden):
    """403: a browser page of another origin asked to change something (its Origin header)."""

    problem_type = PROBLEM_BASE + "cross-origin"


class UnsupportedMediaType(Problem):
    """415: a JSON body without Content-Type: application/json."""

    problem_type = PROBLEM_BASE + "unsupported-media-type"


class MisdirectedRequest(Problem):
    """421: a gateway without tokens answers only to a loopback Host (or http.allowed_hosts)."""

    problem_type = PROBLEM_BASE + "misdirected-request"


class MethodNotAllowed(Problem):
    problem_type = PROBLEM_BASE + "method-not-allowed"


class PayloadTooLarge(Problem):
    problem_type = PROBLEM_BASE + "payload-too-large"


class HeaderTooLarge(Problem):
    problem_type = PROBLEM_BASE + "header-too-large"


class NotImplementedOnGateway(Problem):
    """501: this gateway build lacks the feature (named so as not to shadow NotImplementedError)."""

    problem_type = PROBLEM_BASE + "not-implemented"


class TooManyConnections(Unavailable):
    problem_type = PROBLEM_BASE + "too-many-connections"


class BodyBudgetExhausted(Unavailable):
    problem_type = PROBLEM_BASE + "body-budget-exhausted"


class PortScanBusy(Unavailable):
    problem_type = PROBLEM_BASE + "port-scan-busy"


class UnknownController(NotFound):
    problem_type = PROBLEM_BASE + "unknown-controller"


class InvalidValue(Problem):
    """422: an unknown field or a value out of range; `field` names it. Nothing was sent."""

    problem_type = PROBLEM_BASE + "invalid-value"


class MissingModule(Conflict):
    """409: the controller's firmware lacks the module this needs."""

    problem_type = PROBLEM_BASE + "missing-module"


class Busy(Conflict):
    """409: the stage is moving, or jobs from before a lease hold the controller."""

    problem_type = PROBLEM_BASE + "busy"


class Leased(Conflict):
    """409: another client holds the controller's lease."""

    problem_type = PROBLEM_BASE + "leased"


class JobActive(Conflict):
    """409: a job runs on (or is paused holding) the controller; only the holder of the lease it runs
    under may change the controller (the detail names the job). Reads and HALT are open to all."""

    problem_type = PROBLEM_BASE + "job-active"


class Halted(Conflict):
    """409: a HALT stopped it (the gateway's own refusal of a job's command after a HALT)."""

    problem_type = PROBLEM_BASE + "halted"


class NotConnected(Unavailable):
    problem_type = PROBLEM_BASE + "not-connected"


class ControllerTimeout(Problem):
    """504: the controller did not answer, or the stage did not arrive, in time."""

    problem_type = PROBLEM_BASE + "timeout"


class ControllerError(Problem):
    """502: the controller answered an error (`controller_code`, `controller_code_name`)."""

    problem_type = PROBLEM_BASE + "controller-error"

    @property
    def controller_code(self) -> int | None:
        value = self.extensions.get("controller_code")
        return value if isinstance(value, int) else None

    @property
    def controller_code_name(self) -> str | None:
        value = self.extensions.get("controller_code_name")
        return value if isinstance(value, str) else None


class QueueFull(Unavailable):
    problem_type = PROBLEM_BASE + "queue-full"


class UnknownJob(NotFound):
    problem_type = PROBLEM_BASE + "unknown-job"


class InvalidState(Conflict):
    """409: the job or lease is not in a state that allows this request."""

    problem_type = PROBLEM_BASE + "invalid-state"


class StorageUnavailable(Unavailable):
    problem_type = PROBLEM_BASE + "storage-unavailable"


class UnknownFile(NotFound):
    problem_type = PROBLEM_BASE + "unknown-file"


class UnknownRecording(NotFound):
    problem_type = PROBLEM_BASE + "unknown-recording"


class StaleCommand(Problem):
    """408: an MQTT command that arrived after its deadline, not run (MQTT answers only)."""

    problem_type = PROBLEM_BASE + "stale-command"


class InvalidGcode(Problem):
    """422: a program error at `line` and `column` (`message` is the translator's)."""

    problem_type = PROBLEM_BASE + "invalid-gcode"

    @property
    def line(self) -> int | None:
        value = self.extensions.get("line")
        return value if isinstance(value, int) else None

    @property
    def column(self) -> int | None:
        value = self.extensions.get("column")
        return value if isinstance(value, int) else None

    @property
    def message(self) -> str | None:
        value = self.extensions.get("message")
        return value if isinstance(value, str) else None


class PlannerBusy(Unavailable):
    problem_type = PROBLEM_BASE + "planner-busy"


class Internal(Problem):
    problem_type = PROBLEM_BASE + "internal"


# ---- raised by the client itself -------------------------------------------------------------


class LeaseLost(InvalidState):
    """The lease a `with stage.lease():` block holds ended under it: its renewal was refused (it
    expired, or an admin ended it). Carries the refusal's problem fields. Raised by the next
    operation in the block and when the block ends, so a script never moves a stage it no longer
    holds. (The gateway itself accepts a stale Lease-Id on a free controller.)"""


def _all_subclasses(cls: type[Problem]) -> list[type[Problem]]:
    out: list[type[Problem]] = []
    for sub in cls.__subclasses__():
        out.append(sub)
        out.extend(_all_subclasses(sub))
    return out


def _registry() -> dict[str, type[Problem]]:
    registry: dict[str, type[Problem]] = {}
    for cls in _all_subclasses(Problem):
        # A class that only inherits its parent's type (LeaseLost) does not claim it.
        if cls.problem_type and "problem_type" in cls.__dict__:
            registry[cls.problem_type] = cls
    return registry


PROBLEM_CLASSES: Mapping[str, type[Problem]] = _registry()


def problem_from_body(body: Mapping[str, Any], retry_after: float | None = None) -> Problem:
    """The exception for a problem+json body: its type's class, or Problem for an unknown type."""
    cls = PROBLEM_CLASSES.get(str(body.get("type", "")), Problem)
    error = cls(body)
    if isinstance(error, Unavailable):
        error.retry_after = retry_after
    return error


class JobEnded(GatewayError):
    """Waiting for a job that ended otherwise than succeeded. `job` is its final record."""

    def __init__(self, job: Any) -> None:
        self.job = job
        state = getattr(job, "state", "?")
        reason = getattr(job, "reason", "")
        super().__init__(f"job {getattr(job, 'id', '?')} {state}" + (f": {reason}" if reason else ""))


class JobFailed(JobEnded):
    """The job failed; `job.reason` says why."""


class JobCancelled(JobEnded):
    """The job was cancelled."""


class HaltIncomplete(GatewayError):
    """HALT ALL reached some controllers but not all; `results` has each controller's outcome."""

    def __init__(self, results: Mapping[str, Any]) -> None:
        self.results = dict(results)
        failed = [cid for cid, r in self.results.items() if isinstance(r, BaseException)]
        super().__init__(f"HALT failed on {', '.join(failed)}")
