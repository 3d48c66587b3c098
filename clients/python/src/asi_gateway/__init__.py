"""asi_gateway: a Python client for asi-gateway (ASI MS-2000 stages over REST and WebSocket).

Synchronous:

    from asi_gateway import Gateway
    with Gateway("http://127.0.0.1:8080") as gw:
        gw.stage("sim1").move({"X": 1000}, wait=True)

asyncio:

    from asi_gateway import AsyncGateway
    async with AsyncGateway("http://127.0.0.1:8080") as gw:
        await gw.stage("sim1").move({"X": 1000}, wait=True)
"""

from .client import AsyncGateway
from .gcode import AsyncGcode
from .jobs import AsyncJobs
from .leases import AsyncLease
from .models import (
    AxisState,
    ControllerState,
    GcodeFile,
    Identity,
    Job,
    JobPlan,
    JobProgress,
    JobUpdate,
    LeaseGrant,
    LeaseInfo,
    MoveResult,
    OperationResult,
)
from .problems import (
    PROBLEM_CLASSES,
    BadRequest,
    BodyBudgetExhausted,
    Busy,
    Conflict,
    ControllerError,
    ControllerTimeout,
    Forbidden,
    GatewayError,
    GatewayUnreachable,
    Halted,
    HaltIncomplete,
    HeaderTooLarge,
    Internal,
    InvalidGcode,
    InvalidState,
    InvalidValue,
    JobActive,
    JobCancelled,
    JobEnded,
    JobFailed,
    Leased,
    LeaseLost,
    MalformedJson,
    MethodNotAllowed,
    MissingModule,
    NotConnected,
    NotFound,
    NotImplementedOnGateway,
    PayloadTooLarge,
    PlannerBusy,
    PortScanBusy,
    Problem,
    QueueFull,
    StorageUnavailable,
    TooManyConnections,
    Unauthorized,
    Unavailable,
    UnexpectedResponse,
    UnknownController,
    UnknownFile,
    UnknownJob,
)
from .stage import AsyncStage
from .subscription import Event, Gap, Message, Retired, Subscription
from .sync import Gateway, Gcode, Jobs, Lease, Stage, SyncSubscription

__version__ = "0.1.0"

__all__ = [
    "PROBLEM_CLASSES",
    "AsyncGateway",
    "AsyncGcode",
    "AsyncJobs",
    "AsyncLease",
    "AsyncStage",
    "AxisState",
    "BadRequest",
    "BodyBudgetExhausted",
    "Busy",
    "Conflict",
    "ControllerError",
    "ControllerState",
    "ControllerTimeout",
    "Event",
    "Forbidden",
    "Gap",
    "Gateway",
    "GatewayError",
    "GatewayUnreachable",
    "Gcode",
    "GcodeFile",
    "HaltIncomplete",
    "Halted",
    "HeaderTooLarge",
    "Identity",
    "Internal",
    "InvalidGcode",
    "InvalidState",
    "InvalidValue",
    "Job",
    "JobActive",
    "JobCancelled",
    "JobEnded",
    "JobFailed",
    "JobPlan",
    "JobProgress",
    "JobUpdate",
    "Jobs",
    "Lease",
    "LeaseGrant",
    "LeaseInfo",
    "LeaseLost",
    "Leased",
    "MalformedJson",
    "Message",
    "MethodNotAllowed",
    "MissingModule",
    "MoveResult",
    "NotConnected",
    "NotFound",
    "NotImplementedOnGateway",
    "OperationResult",
    "PayloadTooLarge",
    "PlannerBusy",
    "PortScanBusy",
    "Problem",
    "QueueFull",
    "Retired",
    "Stage",
    "StorageUnavailable",
    "Subscription",
    "SyncSubscription",
    "TooManyConnections",
    "Unauthorized",
    "Unavailable",
    "UnexpectedResponse",
    "UnknownController",
    "UnknownFile",
    "UnknownJob",
]
