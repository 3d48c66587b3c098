#!/usr/bin/env python3
"""Proves that mesoSPIM-control's ASI stage driver (PyPI "mesospim-control",
mesoSPIM.src.devices.stages.asi.asicontrol.StageControlASITiger, used for Tiger and, with
card_ids=None, for an MS-2000), unmodified, works through the given port. It clears both buffers,
writes the command and reads one line (5 s timeout) each time. Steps: W with the axis letters run
together, M and R in encoder units, '/' polled until it answers N twice, TTL X=2 Y=2 / TTL X=0 Y=2,
and its halt. Positions are checked with a spaced 'W X Y Z' sent through the driver's own
_send_command, so a move is checked even where read_position hits a known simulator gap.

Usage: run_mesospim.py --port PATH_OR_URL [--allow-known-gaps] [--verbose]
Needs PyQt5 (the driver is a QObject with a pause signal); no display is used.
"""

import sys
import time

from _harness import Runner, check_near

from mesoSPIM.src.devices.stages.asi.asicontrol import StageControlASITiger

# mesoSPIM's configuration for an MS-2000: which ASI axis is which mesoSPIM stage, and ASI units
# (tenths of a micron) per micron.
PARAMETERS = {"baudrate": 115200, "stage_assignment": {"z": "X", "y": "Y", "f": "Z"},
              "encoder_conversion": {"X": 10.0, "Y": 10.0, "Z": 10.0}}

CONCATENATED_W = ("read_position sends 'W XYZ' (axis letters run together, asicontrol.py:131; mesoSPIM's "
                  "config documents 'W XYZVWT' on real controllers) and the simulator answers :N-6; "
                  "it also parses each value with int() (asicontrol.py:140), so WHERE values with a "
                  "decimal (the simulator's default, --where-decimals 1) are not read either")
BARE_BACKSLASH = ("stop sends b'\\\\r', a backslash and a letter r with no CR (asicontrol.py:104) and "
                  "reads an answer; the simulator waits for a CR, so no answer comes (5 s timeout) and "
                  "the move goes on; the firmware presumably acts on the backslash at once (fast path)")


def main():
    run = Runner("mesoSPIM", __doc__)
    state = {}

    def where():
        # The driver's own transport with the spaced form of WHERE; values in ASI units.
        reply = state["stage"]._send_command(b"W X Y Z\r")
        values = [float(v) for v in reply.split()[1:4]]
        if not reply.startswith(":A") or len(values) != 3:
            raise AssertionError(f"W X Y Z -> {reply!r}")
        return dict(zip("XYZ", values))

    def connect():
        with run.serial_factory():
            state["stage"] = StageControlASITiger({"COMport": run.port, **PARAMETERS})
        where()
        return f"opened at 115200 baud ({run.port_note()})"

    def read_position():
        truth = where()
        read = state["stage"].read_position()  # W XYZ; microns
        if not read:
            raise AssertionError(f"read_position returned {read}")
        for axis in "XYZ":
            check_near(f"{axis} (um)", read.get(axis), truth[axis] / 10, 0.05)
        return f"W XYZ -> {read} um"

    def move_absolute():
        stage = state["stage"]
        stage.move_absolute({"X": 8000, "Y": -2000.5})  # M X=80000.0 Y=-20005.0
        started = time.monotonic()
        stage.wait_until_done()  # '/' every 50 ms until two N in a row
        waited = time.monotonic() - started
        now = where()
        check_near("X", now["X"], 80000)
        check_near("Y", now["Y"], -20005)
        if waited < 0.5:
            raise AssertionError(f"wait_until_done returned after {waited:.2f} s; an 8 mm move takes longer")
        return f"M X=80000.0 Y=-20005.0; wait_until_done {waited:.1f} s; W X Y {now['X']}, {now['Y']}"

    def move_relative():
        stage = state["stage"]
        stage.move_relative({"X": -250.25})  # R X=-2502.5
        stage.wait_until_done()
        now = where()
        check_near("X", now["X"], 77497.5)
        return f"R X=-2502.5 -> W X {now['X']}"

    def ttl():
        stage = state["stage"]
        stage.enable_ttl_mode(None, True)  # TTL X=2 Y=2 (card_ids None: an MS-2000)
        on = stage._send_command(b"TTL X?\r").split()
        stage.enable_ttl_mode(None, False)  # TTL X=0 Y=2
        off = stage._send_command(b"TTL X?\r").split()
        if on[1:2] != ["X=2"] or off[1:2] != ["X=0"]:
            raise AssertionError(f"TTL X? -> {on} after enable, {off} after disable")
        return "TTL X=2 Y=2 -> TTL X? X=2; TTL X=0 Y=2 -> X=0"

    def halt():
        stage = state["stage"]
        start = where()["X"]
        stage.move_absolute({"X": start / 10 - 30000})  # 30 mm back: over 4 s at full speed
        time.sleep(0.3)
        started = time.monotonic()
        stage.stop()  # reads the controller's answer to the halt (5 s timeout)
        answered = time.monotonic() - started
        stage._send_command(b"\r")  # ends the line the stray 'r' began, whatever the controller did
        time.sleep(0.3)
        stopped = where()["X"]
        busy = stage._send_command(b"/\r").strip()
        if answered > 1 or busy != "N" or not start - 290000 < stopped < start - 1000:
            raise AssertionError(f"stop returned after {answered:.1f} s; then '/' {busy!r}, X {stopped} "
                                 f"(from {start}, target {start - 300000})")
        return f"answered in {answered:.2f} s; stopped at X {stopped} of {start - 300000}"

    def clean_up():
        stage = state["stage"]
        stage.wait_until_done()
        stage.move_absolute({"X": 0, "Y": 0})
        stage.wait_until_done()
        now = where()
        check_near("X", now["X"], 0)
        return f"M X=0 Y=0 -> W X Y {now['X']}, {now['Y']}"

    run.step("connect: StageControlASITiger()", connect, required=True)
    run.step("read position: read_position (W XYZ)", read_position, gap=CONCATENATED_W)
    run.step("move absolute, wait: move_absolute, wait_until_done ('/' until N N)", move_absolute)
    run.step("move relative: move_relative (R)", move_relative)
    run.step("settings: enable_ttl_mode (TTL X=2 Y=2, TTL X=0 Y=2)", ttl)
    run.step("halt: stop during a 30 mm move", halt, gap=BARE_BACKSLASH)
    run.step("back to 0: move_absolute, wait_until_done", clean_up)
    state["stage"].close()
    return run.finish()


if __name__ == "__main__":
    sys.exit(main())
