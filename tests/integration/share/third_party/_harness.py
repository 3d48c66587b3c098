"""Shared by the run_*.py runners: command line, one printed line per step, exit status, and the
way an rfc2217:// URL reaches a driver that builds its own serial.Serial.

A runner calls Runner.step(name, fn) for each step of a driver's real control flow. fn calls the
driver's public API, checks the result and returns a short detail string; any exception fails the
step. A step marked with a known simulator gap (gap="...") prints GAP instead of FAIL when it fails
and counts as failed unless --allow-known-gaps is given. Each line starts with ok, FAIL, GAP or n/a;
the last line is "N passed, N failed". Exit status 0 only when nothing failed; 77 (SKIPPED) when the
driver itself is not at hand (a runner whose driver comes from a source checkout).
"""

import argparse
import contextlib
import logging
import sys
import time
import traceback

import serial

# The simulator's encoder: 45397.6 counts/mm (0.022 um). WHERE answers in tenths of a micron with
# one decimal, so a position read back after a move is within one count of the target: 0.05 um
# (0.5 in ASI units) leaves room for rounding.
POSITION_TOLERANCE_TENTHS = 0.5
SKIPPED = 77


class Runner:
    def __init__(self, driver, description, add_arguments=None):
        parser = argparse.ArgumentParser(description=description,
                                         formatter_class=argparse.RawDescriptionHelpFormatter)
        parser.add_argument("--port", required=True, help="serial device path or rfc2217://HOST:PORT")
        parser.add_argument("--allow-known-gaps", action="store_true",
                            help="steps that hit a known simulator gap do not fail the run")
        parser.add_argument("--no-url-shim", action="store_true",
                            help="give a URL to the driver as it is (shows whether it accepts URLs)")
        parser.add_argument("--verbose", action="store_true", help="tracebacks and the driver's own output")
        if add_arguments:
            add_arguments(parser)
        self.args = parser.parse_args()
        if self.args.verbose:
            logging.basicConfig(level=logging.DEBUG, stream=sys.stderr)
        else:
            logging.disable(logging.CRITICAL)  # the drivers log their own view of each step
        self.port = self.args.port
        self.driver = driver
        self.passed = self.failed = self.gaps = 0

    def step(self, name, fn, gap=None, required=False):
        """Runs one step. gap: the known simulator gap this step hits. required: stop on failure."""
        started = time.monotonic()
        try:
            # The drivers print progress of their own; keep stdout for the step lines.
            with contextlib.redirect_stdout(sys.stderr if self.args.verbose else _Discard()):
                detail = fn()
        except Exception as error:  # noqa: BLE001 - every failure is reported
            seconds = time.monotonic() - started
            message = f"{type(error).__name__}: {error}".strip()
            if gap:
                self.gaps += 1
                print(f"GAP  {name} ({seconds:.1f} s): {message} [known simulator gap: {gap}]", flush=True)
            else:
                self.failed += 1
                print(f"FAIL {name} ({seconds:.1f} s): {message}", flush=True)
            if self.args.verbose:
                traceback.print_exc()
            if required:
                sys.exit(self.finish())
            return False
        seconds = time.monotonic() - started
        note = " [listed as a known simulator gap, but it passed]" if gap else ""
        self.passed += 1
        print(f"ok   {name} ({seconds:.1f} s): {detail or ''}{note}", flush=True)
        return True

    def skip(self, reason):
        print(f"n/a  {self.driver}: {reason}", flush=True)
        sys.exit(SKIPPED)

    def not_applicable(self, name, reason):
        print(f"n/a  {name}: {reason}", flush=True)

    def finish(self):
        failed = self.failed + (0 if self.args.allow_known_gaps else self.gaps)
        if self.gaps:
            allowed = "allowed" if self.args.allow_known_gaps else "counted as failed"
            print(f"{self.driver}: {self.gaps} known simulator gap(s), {allowed}", flush=True)
        print(f"{self.passed} passed, {failed} failed", flush=True)
        return 1 if failed else 0

    @contextlib.contextmanager
    def serial_factory(self):
        """While active, serial.Serial(...) opens self.port with serial.serial_for_url() when the port is
        a URL: pyserial's Serial takes device names only, and the drivers build their own. The driver's
        code is not touched; only the class it finds under serial.Serial changes, for its connection."""
        if "://" not in self.port or self.args.no_url_shim:
            yield
            return
        url, real = self.port, serial.Serial

        def factory(*args, **kwargs):
            given = kwargs.pop("port", args[0] if args else None)
            if given is None:
                kwargs["do_not_open"] = True  # Serial() then .port = ... then .open()
            return serial.serial_for_url(url, *args[1:], **kwargs)

        serial.Serial = factory
        try:
            yield
        finally:
            serial.Serial = real

    def port_note(self):
        if "://" not in self.port:
            return "device path"
        return "URL given as is" if self.args.no_url_shim else "URL through serial_for_url"


class _Discard:
    def write(self, text):
        return len(text)

    def flush(self):
        pass


def check_near(what, actual, expected, tolerance=POSITION_TOLERANCE_TENTHS):
    if actual is None or abs(float(actual) - float(expected)) > tolerance:
        raise AssertionError(f"{what} is {actual}, expected {expected} +- {tolerance}")


def wait_for(what, predicate, timeout=30.0, interval=0.02):
    """Polls predicate() until it is true; returns the seconds waited."""
    started = time.monotonic()
    while not predicate():
        if time.monotonic() - started > timeout:
            raise AssertionError(f"{what}: not within {timeout} s")
        time.sleep(interval)
    return time.monotonic() - started
