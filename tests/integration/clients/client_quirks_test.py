#!/usr/bin/python3
"""Drives ms2000-sim the way real third-party MS-2000 drivers do (see ms2000-protocol.md section 4):
Micro-Manager's ASIStage, navigate, python-microscope, qudi and dirigo. Each scenario repeats the
client's own wire habits (doubled CR, flush-then-read, reading to CR only, fixed string offsets) and
asserts that the reply can be parsed the way that client parses it.

Usage: client_quirks_test.py --sim PATH/TO/ms2000-sim
Needs Debian's python3-serial. Prints 'N passed, N failed' and exits non-zero on any failure.
"""
import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
import traceback

import serial

results = {"passed": 0, "failed": 0}


def check(name, fn):
    try:
        fn()
        results["passed"] += 1
        print(f"ok   {name}")
    except Exception:  # noqa: BLE001 - every failure is reported, the run goes on
        results["failed"] += 1
        print(f"FAIL {name}")
        traceback.print_exc()


class Sim:
    """One ms2000-sim process with its port symlink in a private directory."""

    def __init__(self, exe, preset, time_scale=20):
        self.dir = tempfile.mkdtemp(prefix="quirks-")
        self.link = os.path.join(self.dir, "port")
        self.proc = subprocess.Popen(
            [exe, "--preset", preset, "--link", self.link, "--no-report-port",
             "--time-scale", str(time_scale)],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        deadline = time.monotonic() + 15
        while not os.path.exists(self.link):
            if self.proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError("ms2000-sim did not start: " + self.proc.stderr.read().decode())
            time.sleep(0.02)

    def open(self, **kw):
        kw.setdefault("timeout", 2)
        return serial.Serial(self.link, 115200, **kw)

    def close(self):
        self.proc.terminate()
        self.proc.wait(10)
        shutil.rmtree(self.dir, ignore_errors=True)


def nothing_pending(port, wait=0.3):
    """A reply the client does not expect would break its next read."""
    time.sleep(wait)
    extra = port.read(port.in_waiting or 0)
    assert extra == b"", f"unexpected extra bytes {extra!r}"


def wait_idle(port, timeout=30):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        port.write(b"/\r")
        if port.readline().strip() == b"N":
            return
        time.sleep(0.02)
    raise AssertionError("stage still busy")


def navigate(sim):
    """navigate: cmd + '\\r' where cmd already ends in '\\r' (doubled CR), readline(), split(' ')."""
    with sim.open() as p:
        p.reset_input_buffer()
        p.write(b"MOVE X=1234.5 Y=-10\r\r")
        reply = p.readline()
        assert reply.endswith(b"\r\n") and not reply.startswith(b":N"), reply
        nothing_pending(p)  # the empty line after the doubled CR is ignored
        wait_idle(p)
        p.write(b"WHERE X Y Z\r\r")
        fields = p.readline().decode().split()
        assert fields[0] == ":A", fields
        x_um = float(fields[1]) / 10
        assert abs(x_um - 123.45) < 0.05, x_um  # quantised to encoder counts
        assert abs(float(fields[2]) + 10) < 0.1, fields
        p.write(b"/\r\r")
        assert p.readline().strip() in (b"B", b"N")
        p.write(b"SPEED X=1000 Y=1000 Z=1000\r\r")
        assert p.readline().strip() == b":A"
        p.write(b"SPEED X? Y? Z?\r\r")
        tokens = p.readline().decode().split()
        assert tokens[0] == ":A" and [t[:2] for t in tokens[1:]] == ["X=", "Y=", "Z="], tokens
        assert abs(float(tokens[1][2:]) - 6.8) < 1e-6, tokens  # clamped to lead screw B's maximum
        p.write(b"CNTS X?\r\r")
        counts = float(p.readline().decode().split("=")[1].split()[0])
        assert 45000 < counts < 46000, counts
        p.write(b"BOGUS\r\r")
        assert p.readline().strip() == b":N-1"


def micro_manager(sim):
    """Micro-Manager ASIStage: version at index 16, ':X=' shapes for AC/B, ':A X=' for S, HALT -21."""
    with sim.open() as p:
        p.reset_input_buffer()
        p.write(b"V\r")
        answer = p.readline().decode().rstrip("\r\n")
        assert answer.startswith(":A Version: USB-"), answer
        assert answer[16:].split(" ")[0] == "9.50", answer
        for query, prefix in ((b"AC X?\r", ":X="), (b"B X?\r", ":X="), (b"E X?\r", ":X="), (b"WT X?\r", ":X=")):
            p.write(query)
            reply = p.readline().decode()
            assert reply.startswith(prefix) and reply.rstrip().endswith("A"), (query, reply)
        p.write(b"S X?\r")
        reply = p.readline().decode()
        assert reply.startswith(":A X=") and float(reply[5:]) > 0, reply
        p.write(b"UM X=10000 Y=10000\r")
        assert p.readline().startswith(b":A")
        p.write(b"M X=200000\r")
        assert p.readline().strip() == b":A"
        p.write(b"/\r")
        assert p.read(1) == b"B"
        p.readline()
        p.write(b"\\\r")
        assert p.readline().strip() == b":N-21"  # HALT during a move; MM counts it as success
        wait_idle(p)
        p.write(b"\\\r")
        assert p.readline().strip() == b":A"  # HALT when idle


def python_microscope(sim):
    """python-microscope: read_until(b'\\r'), so every read after the first starts with the '\\n'."""
    with sim.open(timeout=0.5) as p:
        p.reset_input_buffer()
        p.write(b"INFO X\r")
        lines = []
        while True:
            chunk = p.read_until(b"\r")
            if not chunk:
                break
            lines.append(chunk.decode(errors="replace").strip("\r\n"))
        text_lines = [line for line in lines if line]
        assert len(text_lines) >= 10, lines
        assert sum(len(line) for line in lines) > 1023, "INFO is longer than 1023 characters"
        p.write(b"INFO F\r")  # an axis this controller does not have: nothing before the timeout
        assert p.read_until(b"\r") == b""
        p.write(b"RDSTAT X\r")
        reply = p.read_until(b"\r")
        assert int(reply.strip()[3:]) & 1 == 0, reply
        p.write(b"WHERE X\r")
        reply = p.read_until(b"\r")
        float(reply.strip()[2:])
        p.write(b"HERE X=0\r")
        assert p.read_until(b"\r").strip() == b":A"


def qudi(sim):
    """qudi: writes a move without reading ':A', then flushes input and polls '/ ' (trailing space)."""
    with sim.open() as p:
        p.reset_input_buffer()
        p.write(b"M X=5000\r")
        time.sleep(0.05)  # qudi relies on the ':A' having arrived by the time it flushes
        p.reset_input_buffer()
        p.write(b"/ \r")
        assert p.readline().strip() in (b"B", b"N")
        wait_idle(p)
        p.reset_input_buffer()
        p.write(b"W X\r")
        assert abs(float(p.readline()[3:]) - 5000) < 1
        p.write(b"S X?\r")
        assert float(p.readline()[5:]) > 0


def dirigo(sim):
    """dirigo (pyvisa, read to '\\r'): WHO must contain ASI-MS2000; SETLOW/SETUP X? Y? Z? tokens[1:]."""
    with sim.open() as p:
        p.reset_input_buffer()
        p.write(b"WHO\r")
        assert b"ASI-MS2000" in p.readline()
        for verb in (b"SETLOW", b"SETUP"):
            p.write(verb + b" X? Y? Z?\r")
            tokens = p.readline().decode().split()[1:]
            limits = [float(t[2:]) for t in tokens]
            assert len(limits) == 3, tokens
        p.write(b"STATUS\r")
        assert p.readline().strip() in (b"N", b"B")


def led_and_errors(sim):
    """LED X? answers 'X=<n> :A' (MM's ASILED); WRDAC out of range is :N-4 (seed: DAC OUT)."""
    with sim.open() as p:
        p.reset_input_buffer()
        p.write(b"LED X=40\r")
        assert p.readline().strip() == b":A"
        p.write(b"LED X?\r")
        assert p.readline().strip() == b"X=40 :A"
        p.write(b"WRDAC X=1.1\r")
        assert p.readline().strip() == b":A"
        p.write(b"WRDAC X=20\r")
        assert p.readline().strip() == b":N-4"


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--sim", required=True)
    exe = parser.parse_args().sim

    full = Sim(exe, "full")
    try:
        check("navigate: doubled CR, MOVE/WHERE/SPEED/CNTS, :N-1", lambda: navigate(full))
        check("Micro-Manager: version offset, query shapes, HALT :N-21", lambda: micro_manager(full))
        check("python-microscope: read_until CR, INFO, absent axis", lambda: python_microscope(full))
        check("qudi: flush-then-read, '/ ' polling", lambda: qudi(full))
        check("dirigo: WHO, SETLOW/SETUP, STATUS", lambda: dirigo(full))
    finally:
        full.close()
    planar = Sim(exe, "planar")
    try:
        check("LED and WRDAC shapes", lambda: led_and_errors(planar))
    finally:
        planar.close()

    print(f"{results['passed']} passed, {results['failed']} failed")
    return 1 if results["failed"] else 0


if __name__ == "__main__":
    sys.exit(main())
