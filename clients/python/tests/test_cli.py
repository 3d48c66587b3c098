"""The command line, run as a user would: `asi-gateway-client` and `python -m asi_gateway`."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from gateway_process import TOKENS, RunningGateway

SCRIPT = Path(sys.executable).parent / "asi-gateway-client"


def run(
    gateway: RunningGateway, *args: str, token: str = TOKENS["operator"], module: bool = False
) -> subprocess.CompletedProcess[str]:
    command = [sys.executable, "-m", "asi_gateway"] if module else [str(SCRIPT)]
    env = {**os.environ, "ASI_GATEWAY_URL": gateway.url, "ASI_GATEWAY_TOKEN": token}
    return subprocess.run([*command, *args], capture_output=True, text=True, env=env, timeout=180, check=False)


def test_list(gateway: RunningGateway) -> None:
    done = run(gateway, "list")
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert [line.split()[0] for line in lines] == ["ext1", "cam1", "sim1", "sim2"]
    assert all("connected" in line for line in lines)
    as_json = json.loads(run(gateway, "list", "--json", module=True).stdout)
    assert [c["id"] for c in as_json] == ["ext1", "cam1", "sim1", "sim2"]


def test_move_and_halt(gateway: RunningGateway) -> None:
    done = run(gateway, "move", "sim2", "X=700", "y=-30", module=True)
    assert done.returncode == 0, done.stderr
    positions = {p["axis"]: p["position_um"] for p in json.loads(done.stdout)["positions"]}
    assert abs(positions["X"] - 700) <= 1 and abs(positions["Y"] + 30) <= 1
    relative = json.loads(run(gateway, "move", "sim2", "X=100", "--relative").stdout)
    assert abs(relative["positions"][0]["position_um"] - 800) <= 1
    halted = run(gateway, "halt", "sim2")
    assert halted.returncode == 0 and json.loads(halted.stdout)["operation"] == "halt"
    every = run(gateway, "halt", "--all")
    assert every.returncode == 0 and set(json.loads(every.stdout)) == {"cam1", "ext1", "sim1", "sim2"}


def test_errors_exit_1_with_the_problem(gateway: RunningGateway) -> None:
    done = run(gateway, "move", "nope", "X=1")
    assert done.returncode == 1
    assert "404 Unknown controller" in done.stderr
    assert json.loads(done.stderr.splitlines()[-1])["type"].endswith("/unknown-controller")
    assert run(gateway, "move", "sim1", "X1").returncode != 0  # a bad command line
    viewer = run(gateway, "move", "sim1", "X=1", token=TOKENS["viewer"])
    assert viewer.returncode == 1 and "403" in viewer.stderr


def test_job_submit_wait_and_follow(gateway: RunningGateway) -> None:
    spec = json.dumps({"grid": {"columns": 2, "rows": 1, "column_step_mm": 0.1, "row_step_mm": 0.1}, "a1": "current"})
    plan = run(gateway, "job", "submit", "sim1", "array", spec, "--dry-run")
    assert plan.returncode == 0 and json.loads(plan.stdout)["dry_run"] is True
    done = run(gateway, "job", "submit", "sim1", "array", spec, "--wait")
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    submitted, final = json.loads(lines[0]), json.loads(lines[-1])
    assert final["id"] == submitted["id"] and final["state"] == "succeeded"
    assert any(" 2/2 100.0%" in line for line in lines[1:-1]), lines
    again = run(gateway, "job", "wait", submitted["id"], module=True)
    assert again.returncode == 0 and json.loads(again.stdout.splitlines()[-1])["state"] == "succeeded"
    topic = "jobs/" + submitted["id"]
    followed = run(gateway, "follow", topic, "--resume", f"{topic}=0", "--count", "2")
    assert followed.returncode == 0, followed.stderr
    events = [json.loads(line) for line in followed.stdout.splitlines()]
    assert [e["seq"] for e in events] == [1, 2] and events[0]["data"]["state"] == "queued"


def test_failed_job_exits_3(gateway: RunningGateway) -> None:
    spec = json.dumps(
        {"grid": {"columns": 3, "rows": 1, "column_step_mm": 0.1, "row_step_mm": 0.1}, "a1": "current", "mode": "host"}
    )
    assert gateway.ext.control("refuse-next M -4") == "ok"
    done = run(gateway, "job", "submit", "ext1", "array", spec, "--wait")
    assert done.returncode == 3, done.stderr
    assert json.loads(done.stdout.splitlines()[-1])["state"] == "failed"
