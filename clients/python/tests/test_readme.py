"""The README's Python examples run verbatim against the gateway's default run (what
./scripts/run starts: four simulated controllers, no tokens), on a free port instead of 8080."""

from __future__ import annotations

import re
import subprocess
import sys
import tempfile
import urllib.error
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import pytest
from gateway_process import free_port, wait_until

README = Path(__file__).resolve().parents[1] / "README.md"
TOP_README = Path(__file__).resolve().parents[3] / "README.md"  # the gateway's "From Python" section
MARKER = "<!-- run by tests/test_readme.py -->"
TOP_MARKER = "<!-- run by clients/python/tests/test_readme.py -->"
DEFAULT_URL = "http://127.0.0.1:8080"


def examples(readme: Path = README, marker: str = MARKER) -> list[str]:
    blocks = re.findall(re.escape(marker) + r"\n```python\n(.*?)```", readme.read_text(), re.DOTALL)
    return [str(b) for b in blocks]


@pytest.fixture(scope="module")
def default_gateway(request: pytest.FixtureRequest) -> Iterator[str]:
    """`asi-gateway` with no config, as ./scripts/run starts it, but on a free port and a scratch store."""
    gateway_bin = request.config.getoption("--gateway")
    if not gateway_bin:
        pytest.fail("give --gateway")
    port = free_port()
    with tempfile.TemporaryDirectory(prefix="asi-gateway-readme-") as tmp:
        log = open(Path(tmp) / "gateway.log", "wb")  # noqa: SIM115 - closed below, after the process
        args = [str(gateway_bin), "--port", str(port), "--storage", tmp + "/store", "--sim-dir", tmp + "/sim"]
        proc = subprocess.Popen(args, stdout=log, stderr=log)
        url = f"http://127.0.0.1:{port}"

        def ready() -> bool:
            assert proc.poll() is None, (Path(tmp) / "gateway.log").read_text()
            try:
                with urllib.request.urlopen(url + "/api/v1/ready", timeout=5) as r:
                    return bool(r.status == 200)
            except (urllib.error.URLError, OSError):
                return False

        try:
            wait_until("the default gateway", ready)
            yield url
        finally:
            proc.terminate()
            proc.wait(30)
            log.close()


def test_readme_has_examples() -> None:
    assert len(examples()) >= 5


EXPECTED = {
    0: "arrived: True",
    2: "422 axes.Q",
    3: "free again: True",
    4: "line 2, column 1",
    5: "succeeded",
    6: "well B1: X=0.0 Y=-500.0",
    7: "at X=1000 Y=-500",
    8: "plate 7: stopped, 0 frames, 0 losses",
}


def run_example(code: str, url: str) -> subprocess.CompletedProcess[str]:
    assert DEFAULT_URL in code
    return subprocess.run(
        [sys.executable, "-c", code.replace(DEFAULT_URL, url)],
        capture_output=True,
        text=True,
        timeout=240,
        check=False,
    )


@pytest.mark.parametrize("index", range(len(examples())))
def test_readme_example_runs_verbatim(default_gateway: str, index: int) -> None:
    code = examples()[index]
    done = run_example(code, default_gateway)
    assert done.returncode == 0, f"example {index} failed:\n{code}\n{done.stdout}\n{done.stderr}"
    assert done.stdout.strip()
    if index in EXPECTED:
        assert EXPECTED[index] in done.stdout, done.stdout


def test_the_gateway_readme_has_its_python_examples() -> None:
    assert len(examples(TOP_README, TOP_MARKER)) == 3  # a plain script, a Bluesky plan, a pymmcore-plus acquisition


@pytest.mark.parametrize("index", range(len(examples(TOP_README, TOP_MARKER))))
def test_gateway_readme_example_runs_verbatim(default_gateway: str, index: int) -> None:
    code = examples(TOP_README, TOP_MARKER)[index]
    done = run_example(code, default_gateway)
    assert done.returncode == 0, f"README example {index} failed:\n{code}\n{done.stdout}\n{done.stderr}"
    assert done.stdout.strip()
