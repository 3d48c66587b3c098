"""pytest fixtures: one real gateway for the session (tests/gateway_process.py), clients per
role, and a clean-up after every test so that no lease, job or motion leaks into the next."""

from __future__ import annotations

import contextlib
import os
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

from gateway_process import TOKENS, GatewayProcesses, RunningGateway

from asi_gateway import Gateway, InvalidState, NotFound

REPO_ROOT = Path(__file__).resolve().parents[3]


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--gateway", default=os.environ.get("ASI_GATEWAY_BIN"), help="the asi-gateway binary")
    parser.addoption("--sim", default=os.environ.get("MS2000_SIM_BIN"), help="the ms2000-sim binary")


@pytest.fixture(scope="session")
def gateway(request: pytest.FixtureRequest) -> Iterator[RunningGateway]:
    gateway_bin = request.config.getoption("--gateway")
    sim_bin = request.config.getoption("--sim")
    if not gateway_bin or not sim_bin:
        pytest.fail("give --gateway and --sim (or $ASI_GATEWAY_BIN and $MS2000_SIM_BIN)")
    processes = GatewayProcesses(str(gateway_bin), str(sim_bin))
    try:
        running = processes.start()
        yield running
        failed = request.session.testsfailed
        if failed:
            print("\n---- gateway log (tail) ----\n" + running.log_tail())
    finally:
        processes.stop()


@pytest.fixture
def operator(gateway: RunningGateway) -> Iterator[Gateway]:
    with Gateway(gateway.url, token=TOKENS["operator"]) as gw:
        yield gw


@pytest.fixture
def admin(gateway: RunningGateway) -> Iterator[Gateway]:
    with Gateway(gateway.url, token=TOKENS["admin"]) as gw:
        yield gw


@pytest.fixture(autouse=True)
def clean_gateway(request: pytest.FixtureRequest) -> Iterator[None]:
    """After a test that used the gateway: cancel its unfinished jobs, end leases, halt, and
    wait until every stage is idle again."""
    yield
    if "gateway" not in request.fixturenames:
        return
    running: RunningGateway = request.getfixturevalue("gateway")
    with Gateway(running.url, token=TOKENS["admin"]) as gw:
        for state in ("running", "paused", "queued", "interrupted"):
            jobs, _ = gw.jobs.list(state=state)
            for job in jobs:
                with contextlib.suppress(InvalidState, NotFound):
                    gw.jobs.cancel(job.id)
        for recording in gw.recordings.list(state="recording"):
            gw.recordings.stop(recording.id)
        for lease in gw.leases():
            with contextlib.suppress(InvalidState, NotFound):
                gw.stage(lease.controller).force_release_lease()
        gw.halt_all()
        deadline = time.monotonic() + 60
        while any(c.busy for c in gw.list_controllers()) and time.monotonic() < deadline:
            time.sleep(0.2)
