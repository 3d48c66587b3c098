#!/usr/bin/env python3
"""Proves that navigate's MS-2000 stage driver (PyPI "navigate-micro": navigate.model.devices.stage.asi
MS2000Stage over navigate.model.devices.APIs.asi.asi_MS2000_controller MS2000Controller), unmodified,
works through the given port. The driver drains input before each command, sends it with a doubled
CR, sleeps 100 ms, reads one line and raises on ':N'. Its set-up writes AA/AZ, PC, E, B, JSSPD and
sets 90% of the maximum speed it learns from SPEED X=1000 Y=1000 Z=1000 / SPEED X? Y? Z?; then the
runner reads positions (WHERE X Y Z), moves absolutely (MOVE) and relatively (MOVREL), watches
busy ('/') and RS X?, reads CNTS X? and halts a long move (HALT, ':N-21').

Usage: run_navigate.py --port PATH_OR_URL [--allow-known-gaps] [--verbose]

navigate's package __init__ imports the whole acquisition model (numpy, scipy, pandas, scikit-image,
...). The runner registers navigate.model, navigate.model.devices and navigate.config as packages with
their real directories but without running their __init__, so only the stage and ASI modules (and
their own imports) run; their code is as installed.
"""

import multiprocessing
import os
import sys
import time
import types

from _harness import Runner, check_near, wait_for

import navigate

_root = os.path.dirname(navigate.__file__)
for _name in ("navigate.model", "navigate.model.devices", "navigate.config"):
    _package = types.ModuleType(_name)
    _package.__path__ = [os.path.join(_root, *_name.split(".")[1:])]
    sys.modules[_name] = _package

from navigate.model.devices.stage.asi import MS2000Stage  # noqa: E402

# Stage limits in microns, as in a navigate configuration file.
LIMITS = {f"{axis}_{end}": sign * 100000 for axis in "xyz" for end, sign in (("min", -1), ("max", 1))}


def configuration(manager):
    # navigate hands its devices the configuration through a multiprocessing manager; MS2000Stage
    # reads hardware[device_id], which only works on the manager's list proxy.
    hardware = manager.list([{"axes": ["x", "y", "z"], "axes_mapping": ["X", "Y", "Z"], "jsspd": 50}])
    scope = {"zoom": {"pixel_size": {"1x": 1.0}}, "stage": {"hardware": hardware, **LIMITS}}
    return {"configuration": {"microscopes": {"scope": scope}}}


def main():
    run = Runner("navigate", __doc__)
    manager = multiprocessing.Manager()
    state = {}

    def position(axis):
        return state["stage"].report_position()[f"{axis}_pos"]  # microns, from WHERE X Y Z

    def wait_idle(*axes):
        for axis in axes:
            if not state["stage"].wait_until_complete(axis, timeout=60):  # RS <axis>? until not B
                raise AssertionError(f"RS {axis}? still busy")

    def connect():
        with run.serial_factory():
            controller = state["controller"] = MS2000Stage.connect(run.port, 115200)
        if not controller.is_open():
            raise AssertionError("the serial port did not open")
        return f"opened at 115200 baud ({run.port_note()})"

    def set_up():
        stage = state["stage"] = MS2000Stage("scope", state["controller"], configuration(manager))
        maximum = state["controller"]._max_speeds
        speed = stage.get_speed("x")  # SPEED X?
        check_near("speed X (mm/s)", speed, 0.9 * maximum[0], 1e-4)
        return f"AA/AZ, PC, E, B, JSSPD accepted; maximum speeds {maximum} mm/s, 90% read back {speed}"

    def read_position():
        where = state["stage"].report_position()
        if sorted(where) != ["x_pos", "y_pos", "z_pos"]:
            raise AssertionError(f"report_position: {where}")
        return f"WHERE X Y Z -> {where}"

    def move_absolute():
        stage, controller = state["stage"], state["controller"]
        if not stage.move_absolute({"x_abs": 5000.0, "y_abs": -4000.5, "z_abs": 250.0}):
            raise AssertionError("move_absolute returned False")
        busy = controller.is_moving()  # '/' 100 ms after MOVE: the 5 mm move is still running
        wait_idle("X", "Y", "Z")
        idle = controller.is_moving()
        if not busy or idle:
            raise AssertionError(f"'/' gave busy {busy} during the move, {idle} after it")
        for axis, target in (("x", 5000.0), ("y", -4000.5), ("z", 250.0)):
            check_near(f"{axis} (um)", position(axis), target, 0.05)
        return "MOVE X=50000.0 Y=-40005.0 Z=2500.0; '/' B then N; WHERE matches"

    def move_relative():
        stage = state["stage"]
        if not stage.move_axis_relative("x", -1234.5):  # MOVREL x=-12345.0
            raise AssertionError("move_axis_relative returned False")
        wait_idle("X")
        check_near("x (um)", position("x"), 3765.5, 0.05)
        return f"MOVREL x=-12345.0 -> x {position('x'):.2f} um"

    def encoder():
        counts = state["controller"].get_encoder_counts_per_mm("X")  # CNTS X?
        if not counts > 1000:
            raise AssertionError(f"CNTS X? -> {counts}")
        return f"CNTS X? -> {counts} counts/mm"

    def halt():
        stage, controller = state["stage"], state["controller"]
        start = position("x")
        stage.move_absolute({"x_abs": start + 40000.0})  # 40 mm: several seconds
        wait_for("'/' answers B", controller.is_moving, timeout=2)
        time.sleep(0.3)
        stage.stop()  # HALT; the driver reports ':N-21' (halted a move) as a failed halt and goes on
        waited = wait_for("'/' answers N after HALT", lambda: not controller.is_moving(), timeout=3)
        stopped = position("x")
        if not start + 100 < stopped < start + 39000:
            raise AssertionError(f"x stopped at {stopped} um, started at {start}, target {start + 40000}")
        stage.move_absolute({"x_abs": 0.0, "y_abs": 0.0, "z_abs": 0.0})
        wait_idle("X", "Y", "Z")
        return f"halted at x {stopped:.1f} um of {start + 40000:.1f}, idle {waited:.2f} s after HALT"

    run.step("connect: MS2000Stage.connect", connect, required=True)
    run.step("set up: MS2000Stage() (AA, AZ, PC, E, B, JSSPD, SPEED)", set_up, required=True)
    run.step("read position: report_position (WHERE X Y Z)", read_position)
    run.step("move absolute, busy then idle: move_absolute, is_moving, wait_until_complete", move_absolute)
    run.step("move relative: move_axis_relative (MOVREL)", move_relative)
    run.step("settings: get_encoder_counts_per_mm (CNTS X?)", encoder)
    run.step("halt: stop (HALT) during a 40 mm move", halt)
    run.not_applicable("wait_until_done=True", "navigate 0.0.13's MS2000Controller.wait_for_device reads "
                       "self.report, which nothing sets (AttributeError, asi_MS2000_controller.py:164); "
                       "the runner waits with MS2000Stage.wait_until_complete (RS X?) instead")
    state["controller"].disconnect_from_serial()
    return run.finish()


if __name__ == "__main__":
    sys.exit(main())
