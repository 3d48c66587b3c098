#!/usr/bin/env python3
"""Proves that storm-control's ASI stage driver (github.com/ZhuangLab/storm-control at commit
33756cf7d27177d07066d8b8cfa0aac8e8a2868c: storm_control/sc_hardware/appliedScientificInstrumentation/
tiger.py, class Tiger, over sc_hardware/serial/RS232.py), unmodified, works through the given port.
It is written for the Tiger, whose command language the MS-2000 shares (storm-control's own
ms2000.py is Python 2 and cannot run). RS232.commWithResp writes the command, sleeps 10 x wait_time
(100 ms) and returns whatever has arrived by then, so it only sees prompt replies. Steps: WHO at
connection, S X= Y=, W X Y, M and R in tenths of a micron, M Z / W Z, H X Y, VE (jog) started and
stopped, J and MC off and on. The driver has no busy query and no halt: the runner polls position().

storm-control is not on PyPI. Give a checkout at that commit with --source DIR (or
$STORM_CONTROL_SRC); the files the runner imports are checked against their sha256 below. Without
it the runner prints n/a and exits 77. Needs PyQt5 (sc_library/hdebug.py imports QtCore).

Usage: run_storm.py --port PATH_OR_URL --source DIR [--allow-known-gaps] [--verbose]
"""

import hashlib
import os
import sys
import time

from _harness import Runner, check_near, wait_for

# The files of storm-control 33756cf7d271 that run, with their sha256.
PINNED = {
    "storm_control/sc_hardware/appliedScientificInstrumentation/tiger.py":
        "c43651a62078cf4139cdf717c73480d16f5847d183f72863f5b9b2dc761c5983",
    "storm_control/sc_hardware/serial/RS232.py":
        "b6affc7a25f98152f6a45df9bc312ce67064bb53bdf269b6b5a912b6a4c58cd4",
    "storm_control/sc_library/hdebug.py":
        "a6540273b489f16ac43f976aca3a024e7de82cdb1129f1465dd5345f0a817d81",
}


def main():
    def arguments(parser):
        parser.add_argument("--source", default=os.environ.get("STORM_CONTROL_SRC"),
                            help="storm-control checkout at commit 33756cf7d271 ($STORM_CONTROL_SRC)")

    run = Runner("storm-control", __doc__, arguments)
    if not run.args.source:
        run.skip("no storm-control source given (--source DIR or $STORM_CONTROL_SRC)")
    state = {}

    def pinned_source():
        for path, digest in PINNED.items():
            with open(os.path.join(run.args.source, path), "rb") as file:
                if hashlib.sha256(file.read()).hexdigest() != digest:
                    raise AssertionError(f"{path} is not the file of commit 33756cf7d271")
        sys.path.insert(0, os.path.abspath(run.args.source))
        global tiger_module
        import storm_control.sc_hardware.appliedScientificInstrumentation.tiger as tiger_module
        return f"{len(PINNED)} files match commit 33756cf7d271"

    def position():
        return state["stage"].position()  # W X Y, microns

    def wait_at(x, y):
        def arrived():
            now = position()
            return abs(now["x"] - x) <= 0.05 and abs(now["y"] - y) <= 0.05
        return wait_for(f"position ({x}, {y})", arrived, timeout=30, interval=0.05)

    def connect():
        with run.serial_factory():
            stage = state["stage"] = tiger_module.Tiger(port=run.port, baudrate=115200)
        if not stage.live:
            raise AssertionError("WHO got no reply within 100 ms")
        return f"WHO answered ({run.port_note()})"

    def velocity():
        stage = state["stage"]
        stage.setVelocity(3.0, 3.0)  # S X=3.00 Y=3.00
        reply = stage.commWithResp("S X? Y?").split()
        check_near("speed X (mm/s)", float(reply[1][2:]), 3.0, 1e-6)
        return f"S X=3.00 Y=3.00 -> S X? Y? {reply[1:]}"

    def read_position():
        now = position()
        if sorted(now) != ["x", "y"]:
            raise AssertionError(f"position() -> {now}")
        return f"W X Y -> {now} um"

    def move_absolute():
        state["stage"].goAbsolute(1500.0, -750.0)  # M X=15000.0 Y=-7500.0
        waited = wait_at(1500.0, -750.0)
        return f"M X=15000.0 Y=-7500.0 -> W X Y at the target after {waited:.1f} s"

    def move_relative():
        state["stage"].goRelative(-500.0, 250.0)  # R X=-5000.0 Y=2500.0
        waited = wait_at(1000.0, -500.0)
        return f"R X=-5000.0 Y=2500.0 -> W X Y (1000, -500) um after {waited:.1f} s"

    def z_axis():
        stage = state["stage"]
        stage.zMoveTo(123.45)  # M Z=1234.50
        wait_for("W Z", lambda: abs(stage.zPosition()["z"] - 123.45) <= 0.05, timeout=30, interval=0.05)
        stage.zMoveTo(0.0)
        wait_for("W Z", lambda: abs(stage.zPosition()["z"]) <= 0.05, timeout=30, interval=0.05)
        return "M Z=1234.50 -> W Z 123.45 um; M Z=0.00 -> 0"

    def origin():
        stage = state["stage"]
        stage.zero()  # H X Y
        zeroed = position()
        stage.commWithResp("H X=10000 Y=-5000")  # the old coordinates again, for the next client
        check_near("x after H X Y", zeroed["x"], 0, 0.05)
        check_near("y after H X Y", zeroed["y"], 0, 0.05)
        check_near("x after H X=10000", position()["x"], 1000.0, 0.05)
        return "H X Y -> W X Y (0, 0); H X=10000 Y=-5000 -> (1000, -500) um"

    def jog():
        stage = state["stage"]
        start = position()["x"]
        stage.jog(200.0, 0.0)  # VE X=2.000 Y=0.000 (storm's um/s to 'mm/s' conversion, as written)
        time.sleep(0.5)
        stage.jog(0.0, 0.0)  # VE X=0.000 Y=0.000
        time.sleep(0.5)
        stopped = position()["x"]
        time.sleep(0.3)
        still = position()["x"]
        if not stopped > start + 100 or abs(still - stopped) > 0.05:
            raise AssertionError(f"x {start} -> {stopped} -> {still} um")
        stage.goAbsolute(0.0, 0.0)
        wait_at(0.0, 0.0)
        return f"VE X=2.000 moved x {start:.1f} -> {stopped:.1f} um; VE X=0.000 stopped it"

    def joystick():
        stage = state["stage"]
        stage.joystickOnOff(False)  # J X- Y-, MC X- Y- Z-
        off = stage.commWithResp("MC X?").split()
        stage.joystickOnOff(True)  # J X+ Y+, MC X+ Y+ Z+
        on = stage.commWithResp("MC X?").split()
        if off[1:2] != ["0"] or on[1:2] != ["1"]:
            raise AssertionError(f"MC X? -> {off} after off, {on} after on")
        return "J X- Y-, MC X- Y- Z- -> MC X? 0; J X+ Y+, MC X+ Y+ Z+ -> 1"

    run.step("source: pinned files of commit 33756cf7d271", pinned_source, required=True)
    run.step("connect: Tiger() sends WHO", connect, required=True)
    run.step("speed: setVelocity (S X= Y=)", velocity)
    run.step("read position: position (W X Y)", read_position)
    run.step("move absolute: goAbsolute (M X= Y=), position polled", move_absolute)
    run.step("move relative: goRelative (R X= Y=), position polled", move_relative)
    run.step("z: zMoveTo (M Z=), zPosition (W Z)", z_axis)
    run.step("origin: zero (H X Y)", origin)
    run.step("jog and stop: jog (VE X= Y=), jog(0, 0)", jog)
    run.step("joystick and motors: joystickOnOff (J, MC)", joystick)
    run.not_applicable("busy and halt", "storm-control's Tiger class has neither; it polls position()")
    state["stage"].tty.close()
    return run.finish()


if __name__ == "__main__":
    sys.exit(main())
