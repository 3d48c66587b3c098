#!/usr/bin/env python3
"""The README's shell examples, run in order on a gateway started as ./scripts/run starts it.

Every ```sh block of README.md runs, except one right after a line `<!-- not run by ...: reason -->`
(the two commands themselves, an interactive session, examples that need a broker). The blocks run in
one bash with `set -euo pipefail`, in order, in a scratch directory, so a placeholder that no earlier
command set fails the test, as would a command that fails. Every curl's HTTP status is recorded and
checked against what the README says next to it: a comment `# 409 ...`, `# HTTP/1.1 201 Created` or
`# 204` on the same line or on the line after the command; without one, any 2xx. The only change made
to the text is the port: `localhost:8080` becomes a free port, so the test can run beside others.

Needs curl and jq (scripts/install-deps installs both). Debian's /usr/bin/python3, standard library.
"""

import argparse
import os
import re
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gateway_fixture import WAIT, Fixture, check, free_port, http_request, run_main, wait_until  # noqa: E402

NOT_RUN = re.compile(r"^<!-- not run by [^:]+: .+ -->$")
STATUS = re.compile(r"#\s*(?:HTTP/1\.1\s+)?([1-5]\d\d)\b")


def runnable_blocks(readme_text):
    """The ```sh blocks to run, each as its list of lines."""
    blocks, lines = [], readme_text.split("\n")
    i = 0
    while i < len(lines):
        if lines[i].strip() == "```sh":
            skip = i > 0 and NOT_RUN.match(lines[i - 1].strip())
            end = lines.index("```", i + 1)
            if not skip:
                blocks.append(lines[i + 1:end])
            i = end
        i += 1
    return blocks


def expected_statuses(block):
    """One entry per curl call, in order: the status the README gives, or None (any 2xx)."""
    out = []
    i = 0
    while i < len(block):
        line = block[i]
        code = line.split(" #", 1)[0] if not line.lstrip().startswith("#") else ""
        calls = len(re.findall(r"(?:^|[\s|$(])curl\s", code))
        # A command continued over several lines ends at the first line without a trailing backslash.
        while block[i].rstrip().endswith("\\") and i + 1 < len(block):
            i += 1
            line = block[i]
        if calls:
            comment = line.split(" #", 1)[1] if " #" in line else ""
            m = STATUS.match("#" + comment) if comment else None
            if not m and i + 1 < len(block) and block[i + 1].lstrip().startswith("#"):
                m = STATUS.match(block[i + 1].strip())
            out.extend([int(m.group(1)) if m else None] * calls)
        i += 1
    return out


def run_blocks(fx, blocks, port, gateway):
    work = os.path.join(fx.tmp, "work")
    os.makedirs(os.path.join(work, "build", "gateway"))
    os.symlink(gateway, os.path.join(work, "build", "gateway", "asi-gateway"))  # as in a clone
    statuses = os.path.join(fx.tmp, "statuses")
    script = ["set -euo pipefail",
              # Every curl's status goes to a file; the examples' own output is left as it is.
              f"curl() {{ command curl -w '%{{stderr}}HTTP_STATUS %{{http_code}}\\n' \"$@\" 2>>{statuses}; }}"]
    for b in blocks:
        script.extend(line.replace("localhost:8080", f"localhost:{port}").replace("127.0.0.1:8080", f"127.0.0.1:{port}")
                      for line in b)
    with open(os.path.join(fx.tmp, "examples.sh"), "w") as f:
        f.write("\n".join(script) + "\n")
    out = subprocess.run(["bash", os.path.join(fx.tmp, "examples.sh")], cwd=work, capture_output=True, text=True,
                         timeout=600)
    got = [int(line.split()[1]) for line in open(statuses) if line.startswith("HTTP_STATUS")] \
        if os.path.exists(statuses) else []
    return out, got


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    ap.add_argument("--readme", required=True)
    args = ap.parse_args()
    gateway = os.path.abspath(args.gateway)
    blocks = runnable_blocks(open(args.readme).read())
    expected = [s for b in blocks for s in expected_statuses(b)]
    fx = Fixture("gw-readme-")
    try:
        port = free_port()
        # ./scripts/run's gateway: the embedded default (four simulated controllers in real time).
        log = open(os.path.join(fx.tmp, "gateway.log"), "w")
        proc = subprocess.Popen([gateway, "--port", str(port), "--storage",
                                 os.path.join(fx.tmp, "store"), "--sim-dir", os.path.join(fx.tmp, "sims")],
                                stdout=log, stderr=subprocess.STDOUT)
        fx.procs.append(proc)
        wait_until("gateway ready", lambda: http_request(port, "GET", "/api/v1/ready", token=None)[0] == 200)

        def examples():
            check(len(blocks) >= 4 and len(expected) >= 30, f"only {len(blocks)} blocks, {len(expected)} curl calls")
            out, got = run_blocks(fx, blocks, port, gateway)
            for n, (want, status) in enumerate(zip(expected, got)):
                ok = (200 <= status < 300) if want is None else status == want
                check(ok, f"curl call {n + 1}: HTTP {status}, the README says {want or '2xx'}\n{out.stdout[-1500:]}")
            check(out.returncode == 0, f"the examples failed (exit {out.returncode}): {out.stderr[-1500:]}")
            check(len(got) == len(expected), f"{len(got)} curl calls ran, the README has {len(expected)}")

        fx.run("every README example runs and answers what the README says", examples)
        proc.terminate()
        proc.wait(timeout=WAIT)
    finally:
        fx.cleanup()
    return fx.report()


if __name__ == "__main__":
    run_main(main)
