#!/usr/bin/env python3
"""Proves that python-microscope's ASI MS-2000 driver (PyPI "microscope", microscope.controllers.asi,
class ASIMS2000), unmodified, works through the given port: it finds the axes from INFO X/Y/Z
(33-column INFO lines read to CR, an absent axis found by timeout), sets 67% of the maximum speed it
learns from SPEED X=100000000 / SPEED X?, reads settings in the ':A X=', ':X= A' and ':A 1' shapes,
moves absolutely and relatively (MOVE/MOVREL, then RDSTAT until bit 0 clears) and sets the origin
(HERE). The driver has no halt.

Usage: run_microscope.py --port PATH_OR_URL [--allow-known-gaps] [--verbose]
"""

import sys
import time

from _harness import Runner, check_near, wait_for

from microscope.controllers.asi import ASIMS2000


def main():
    run = Runner("python-microscope", __doc__)
    state = {}

    def connect():
        with run.serial_factory():
            # The driver's own defaults are 9600 baud and a 0.5 s timeout; lights=[]: no LED channels.
            state["controller"] = ASIMS2000(run.port, baudrate=115200, lights=[])
        stage = state["stage"] = state["controller"].devices["stage"]
        state["conn"] = stage._dev_conn  # the one _ASIController the stage axes use
        axes = sorted(stage.axes)
        if not {"X", "Y"} <= set(axes):
            raise AssertionError(f"axes found by INFO: {axes}")
        return f"INFO found axes {axes} ({run.port_note()})"

    def identify():
        stage = state["stage"]
        build, version = stage.get_setting("Build X"), stage.get_setting("Sys Ver X")
        counts = stage.get_setting("Enc Cnts/mm X")
        if not build or not float(version) or not float(counts) > 0:
            raise AssertionError(f"INFO settings: build {build!r}, version {version!r}, counts {counts!r}")
        return f"INFO X: build {build}, firmware {version}, {counts} counts/mm"

    def speed():
        stage, axis = state["stage"], state["stage"].axes["X"]
        maximum = state["conn"].find_max_speed("X")  # SPEED X=100000000, then SPEED X? ([5:])
        axis.set_speed(round(maximum * 0.67, 4))
        now = stage.get_setting("Run Speed X")  # S X? read live
        check_near("speed X (mm/s)", now, maximum * 0.67, 0.001)
        return f"maximum {maximum} mm/s, set and read back {now} mm/s"

    def settings():
        stage = state["stage"]
        ramp = stage.get_setting("Ramp Time X")  # AC X? -> ':X=<ms> A'
        enabled = stage.get_setting("Axis Enable X")  # MC X? -> ':A 1'
        kp = stage.get_setting("Kp X")  # KP X? -> ':A X=<n>'
        stage.set_setting("Backlash X", 0.01)  # B X=0.01
        backlash = stage.get_setting("Backlash X")  # B X? -> ':X=<mm> A'
        stage.set_setting("Backlash X", 0.0)
        if not (ramp > 0 and enabled == 1 and kp >= 0):
            raise AssertionError(f"ramp {ramp!r}, axis enable {enabled!r}, Kp {kp!r}")
        check_near("backlash X (mm)", backlash, 0.01, 1e-6)
        return f"ramp time {ramp} ms, axis enable {enabled}, Kp {kp}, backlash set and read 0.01 mm"

    def move_absolute():
        axis = state["stage"].axes["X"]
        axis.move_to(12345)  # MOVE X=12345, RDSTAT X until idle
        check_near("X after MOVE", axis.position, 12345)
        return f"MOVE X=12345 -> WHERE X {axis.position}"

    def move_relative():
        axis = state["stage"].axes["X"]
        axis.move_by(-2345)  # MOVREL X=-2345
        check_near("X after MOVREL", axis.position, 10000)
        return f"MOVREL X=-2345 -> WHERE X {axis.position}"

    def busy_then_idle():
        stage, conn = state["stage"], state["conn"]
        stage.move_to({"X": 60000, "Y": -30000})  # the stage-level move does not wait (its
        # wait_until_idle compares a reply read to CR with ':A \r\n', which never matches)
        busy = conn.motor_moving("X")  # RDSTAT X, bit 0
        waited = wait_for("RDSTAT X bit 0 clears", lambda: not conn.motor_moving("X"))
        wait_for("RDSTAT Y bit 0 clears", lambda: not conn.motor_moving("Y"))
        if not busy:
            raise AssertionError("RDSTAT X did not show the move (bit 0 clear straight after MOVE)")
        check_near("X", stage.axes["X"].position, 60000)
        check_near("Y", stage.axes["Y"].position, -30000)
        return f"RDSTAT bit 0 set, cleared after {waited:.1f} s; WHERE X Y = 60000, -30000"

    def origin():
        axis = state["stage"].axes["X"]
        state["conn"].reset_position("X")  # HERE X=0
        check_near("X after HERE X=0", axis.position, 0)
        state["conn"].get_command(b"HERE X=60000")  # the old coordinates again, for the next client
        state["stage"].move_to({"X": 0, "Y": 0})
        wait_for("RDSTAT X bit 0 clears", lambda: not state["conn"].motor_moving("X"))
        wait_for("RDSTAT Y bit 0 clears", lambda: not state["conn"].motor_moving("Y"))
        check_near("X after HERE X=60000, MOVE X=0", axis.position, 0)
        return "HERE X=0 -> WHERE X 0; HERE X=60000, MOVE X=0 Y=0 -> WHERE X 0"

    run.step("connect: ASIMS2000() sends INFO X, INFO Y, INFO Z", connect, required=True)
    run.step("identify: INFO settings", identify)
    run.step("speed: 67% of the maximum (SPEED X=100000000, SPEED X?)", speed)
    run.step("settings: AC X?, MC X?, KP X?, B X=, B X?", settings)
    run.step("move absolute: axis.move_to (MOVE, RDSTAT until idle)", move_absolute)
    run.step("move relative: axis.move_by (MOVREL)", move_relative)
    run.step("busy then idle: stage.move_to X, Y; motor_moving (RDSTAT bit 0)", busy_then_idle)
    run.step("origin: reset_position (HERE X=0)", origin)
    run.not_applicable("halt", "python-microscope's ASI driver has no halt or stop")
    return run.finish()


if __name__ == "__main__":
    started = time.monotonic()
    status = main()
    print(f"run_microscope: {time.monotonic() - started:.1f} s", file=sys.stderr)
    sys.exit(status)
