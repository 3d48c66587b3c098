"""What the browser tests in this directory share: Checks runs each named check and records it in
the gateway Fixture, and reports the "no console errors" check; unexpected_console() keeps the
browser's console errors that none of a test's allow rules (such as lease_404 and whoami_404)
accepts; parser() and main() are the common command line (--gateway, --sim), the skip (exit 77)
without chromium, and the Fixture around the test's main_async(args, fx).
"""

import argparse
import asyncio
import os
import re
import time

from cdp import find_chromium
from gateway_fixture import Failure, Fixture  # the tests put tests/integration/api on sys.path

# What a failing check raises; a test may catch more (Checks' also_catch).
CHECK_ERRORS = (Failure, AssertionError, RuntimeError, OSError, asyncio.TimeoutError)


class Checks:
    """Runs named checks against the browser b, recording each in fx.passed or fx.failures."""

    def __init__(self, fx, b, also_catch=(), timed=False):
        self.fx = fx
        self.b = b
        self.catch = CHECK_ERRORS + tuple(also_catch)
        self.timed = timed  # print how long each passed check took
        self.by_design = set()  # indices in b.console of the entries a check's `expected` matched

    async def run(self, name, coro_fn, *a, expected=None):
        """Awaits coro_fn(*a); True if it passed. The console entries it causes whose text matches the
        regex `expected` are noted in by_design."""
        first = len(self.b.console)
        started = time.monotonic()
        try:
            await coro_fn(*a)
            self.fx.passed.append(name)
            took = f" ({time.monotonic() - started:.1f} s)" if self.timed else ""
            print(f"[ OK ] {name}{took}", flush=True)
            ok = True
        except self.catch as e:
            self.fx.failures.append((name, e))
            print(f"[FAIL] {name}: {e}", flush=True)
            ok = False
        if expected:
            self.by_design.update(i for i in range(first, len(self.b.console))
                                  if re.search(expected, self.b.console[i][1] or ""))
        return ok

    def console_check(self, bad):
        """The "no console errors" check: fails, showing the first five, if `bad` (from
        unexpected_console) is not empty. With GW_BROWSER_TEST_VERBOSE set, prints every console entry."""
        if bad:
            self.fx.failures.append(("no console errors", Failure(f"{bad[:5]}")))
            print(f"[FAIL] no console errors: {bad[:5]}")
        else:
            self.fx.passed.append("no console errors")
            print(f"[ OK ] no console errors ({len(self.b.console)} console entries seen)")
        if os.environ.get("GW_BROWSER_TEST_VERBOSE"):
            for e in self.b.console:
                print("console:", e)


def lease_404(text, url):
    """GET /api/v1/controllers/{id}/lease answers 404 for a free controller."""
    return url.endswith("/lease") and "404" in text


def whoami_404(text, url):
    """A gateway from before GET /api/v1/whoami: the page then shows everything."""
    return url.endswith("/api/v1/whoami") and "404" in text


def unexpected_console(entries, *allowed):
    """The error entries (level, text, url) of the console that no allow rule accepts; a rule is
    called as rule(text, url) and returns True for an error the API causes by design."""
    out = []
    for level, text, url in entries:
        if level not in ("error", "assert", "exception"):
            continue
        if any(rule(text or "", url) for rule in allowed):
            continue
        out.append((level, text, url))
    return out


def parser(sim_unused=None):
    """The command line every browser test takes: --gateway and --sim (the ms2000-sim binary; a test
    that does not use it passes sim_unused, the help saying why, and the option is then optional)."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    ap.add_argument("--sim", required=sim_unused is None, help=sim_unused)
    return ap


def main(args, main_async, fixture_prefix):
    """Runs main_async(args, fx) with a new Fixture, then checks the gateway's log and cleans up; the
    exit status (77: skipped, chromium is not installed)."""
    if not find_chromium():
        print("chromium is not installed (scripts/install-deps --tests installs it): skipped")
        return 77
    fx = Fixture(fixture_prefix)
    try:
        asyncio.run(main_async(args, fx))
        fx.finish_log(60)
    finally:
        fx.cleanup()
    return fx.report()
