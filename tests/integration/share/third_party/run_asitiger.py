#!/usr/bin/env python3
"""Proves that asitiger (PyPI "asitiger", asitiger.tigercontroller.TigerController), unmodified, works
through the given port. It is written for ASI's Tiger, whose command language the MS-2000 shares; it
clears both buffers before each command, sends the short forms (W, M, R, S, /, RS, H, MC, \\), reads
one line to LF with a 10 s timeout and raises on ':N-<code>'. Steps: WHO and BU X, SPEED set and read,
WHERE, MOVE and MOVREL with STATUS polling, RDSTAT status bytes, HERE, MOTCTRL, and HALT during a
long move (which the driver raises as SerialCommandHaltedError, the ':N-21' the controller sends).

Usage: run_asitiger.py --port PATH_OR_URL [--allow-known-gaps] [--verbose]
"""

import sys
import time

from _harness import Runner, check_near, wait_for

from asitiger.errors import Errors
from asitiger.status import Status
from asitiger.tigercontroller import TigerController


def main():
    run = Runner("asitiger", __doc__)
    state = {}

    def connect():
        with run.serial_factory():
            state["tiger"] = TigerController.from_serial_port(run.port, 115200)
        return f"opened at 115200 baud ({run.port_note()})"

    def identify():
        tiger = state["tiger"]
        who, build = tiger.who(), tiger.build()  # WHO; BU X, split on CR
        axes_line = next((line for line in build if line.startswith("Motor Axes:")), "")
        if not who[0].startswith(":A") or "X" not in axes_line.split():
            raise AssertionError(f"WHO {who}, BU X {build}")
        return f"WHO {who[0]!r}; BU X {build[0]!r}, {axes_line!r}"

    def speed():
        tiger = state["tiger"]
        tiger.speed({"X": 2.5, "Y": 2.5})  # S X=2.5 Y=2.5
        read = tiger.speed({"X": "?", "Y": "?"})  # S X? Y? -> {'X': '2.500000', 'Y': ...}
        check_near("speed X (mm/s)", float(read["X"]), 2.5, 1e-6)
        check_near("speed Y (mm/s)", float(read["Y"]), 2.5, 1e-6)
        tiger.speed({"X": 5, "Y": 5})
        return f"S X=2.5 Y=2.5 -> S X? Y? {read}"

    def read_position():
        where = state["tiger"].where(["X", "Y", "Z"])
        if sorted(where) != ["X", "Y", "Z"]:
            raise AssertionError(f"W X Y Z -> {where}")
        return f"W X Y Z -> {where}"

    def move_absolute():
        tiger = state["tiger"]
        tiger.move({"X": 20000, "Y": -5000})  # M X=20000 Y=-5000
        busy = tiger.is_busy()  # '/'
        statuses = tiger.rdstat(["X", "Y"])  # RS X Y: status bytes, bit 0 = moving
        waited = wait_for("'/' answers N", lambda: not tiger.is_busy())
        if not busy or statuses[0].status is not Status.BUSY:
            raise AssertionError(f"'/' busy {busy}, RS X Y {statuses} straight after M")
        where = tiger.where(["X", "Y"])
        check_near("X", where["X"], 20000)
        check_near("Y", where["Y"], -5000)
        return f"M X=20000 Y=-5000; '/' B, RS X status byte busy; idle after {waited:.1f} s; W X Y {where}"

    def move_relative():
        tiger = state["tiger"]
        tiger.move_relative({"X": -5000.5})  # R X=-5000.5
        tiger.wait_until_idle()
        where = tiger.where(["X"])
        check_near("X", where["X"], 14999.5)
        return f"R X=-5000.5 -> W X {where['X']}"

    def origin():
        tiger = state["tiger"]
        tiger.here({"X": 0})  # H X=0
        zeroed = tiger.where(["X"])["X"]
        tiger.here({"X": 14999.5})  # the old coordinates again
        check_near("X after H X=0", zeroed, 0)
        check_near("X after H X=14999.5", tiger.where(["X"])["X"], 14999.5)
        return "H X=0 -> W X 0; H X=14999.5 -> W X 14999.5"

    def motor_control():
        tiger = state["tiger"]
        tiger.enable_axes(["X", "Y"])  # MC X+ Y+
        status = tiger.rdstat(["X"])[0]
        if status.enabled.value != 1:
            raise AssertionError(f"RS X after MC X+: {status}")
        return f"MC X+ Y+ -> RS X enabled={status.enabled.name}"

    def halt():
        tiger = state["tiger"]
        start = tiger.where(["X"])["X"]
        tiger.move({"X": start + 300000})  # 30 mm at 5 mm/s
        wait_for("'/' answers B", tiger.is_busy, timeout=2)
        time.sleep(0.3)
        try:
            tiger.halt()  # '\'
            answer = ":A"
        except Errors.SerialCommandHaltedError:
            answer = ":N-21"  # the controller says a move was halted; asitiger raises it
        waited = wait_for("'/' answers N after HALT", lambda: not tiger.is_busy(), timeout=3)
        stopped = tiger.where(["X"])["X"]
        if answer != ":N-21" or not start + 1000 < stopped < start + 290000:
            raise AssertionError(f"HALT answered {answer}; X stopped at {stopped} (from {start})")
        tiger.move({"X": 0, "Y": 0})
        tiger.wait_until_idle()
        return f"\\ -> {answer}; X stopped at {stopped} of {start + 300000}, idle {waited:.2f} s later"

    run.step("connect: TigerController.from_serial_port", connect, required=True)
    run.step("identify: who (WHO), build (BU X)", identify)
    run.not_applicable("axes", "reads the Tiger card table (Axis Types, Hex Addr) from BU X; "
                       "an MS-2000 has none")
    run.step("speed: speed (S X=, S X?)", speed)
    run.step("read position: where (W X Y Z)", read_position)
    run.step("move absolute, busy then idle: move, is_busy, rdstat", move_absolute)
    run.step("move relative: move_relative, wait_until_idle", move_relative)
    run.step("origin: here (H X=)", origin)
    run.step("motor control: enable_axes (MC X+ Y+), rdstat", motor_control)
    run.step("halt: halt (\\) during a 30 mm move", halt)
    state["tiger"].connection.disconnect()
    return run.finish()


if __name__ == "__main__":
    sys.exit(main())
