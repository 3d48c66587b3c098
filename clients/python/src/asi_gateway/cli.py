"""`asi-gateway-client` (also `python -m asi_gateway`): the client for quick scripted use.

    asi-gateway-client list
    asi-gateway-client move sim1 X=1000 Y=-250 [--relative] [--no-wait]
    asi-gateway-client halt sim1 | halt --all
    asi-gateway-client job submit sim1 array '{"plate":"96","a1":"current"}' [--dry-run] [--wait]
    asi-gateway-client job wait j-...
    asi-gateway-client follow 'controllers/+/position' [--count N] [--resume TOPIC=SEQ]

The gateway comes from --url or $ASI_GATEWAY_URL (default http://127.0.0.1:8080), the token from
--token or $ASI_GATEWAY_TOKEN. Exit status: 0 done, 1 the gateway refused or failed (the problem
is printed on stderr), 2 a bad command line, 3 a waited job did not succeed.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
from collections.abc import Sequence
from typing import Any

from .models import ControllerState, JobUpdate
from .problems import GatewayError, JobEnded, Problem
from .subscription import Event, Gap, Retired
from .sync import Gateway


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="asi-gateway-client", description="Drive an asi-gateway from the shell.")
    p.add_argument("--url", default=os.environ.get("ASI_GATEWAY_URL", "http://127.0.0.1:8080"))
    p.add_argument("--token", default=os.environ.get("ASI_GATEWAY_TOKEN"), help="bearer token")
    p.add_argument("--ca-file", help="trust this CA (PEM) for an https gateway")
    p.add_argument("--insecure", action="store_true", help="do not verify the https certificate")
    commands = p.add_subparsers(dest="command", required=True)

    ls = commands.add_parser("list", help="every controller: state, build, positions")
    ls.add_argument("--json", action="store_true", help="the full states as JSON")

    move = commands.add_parser("move", help="move a stage: AXIS=UM ...")
    move.add_argument("controller")
    move.add_argument("axes", nargs="+", metavar="AXIS=UM")
    move.add_argument("--relative", action="store_true")
    move.add_argument("--no-wait", action="store_true", help="return once the controller took the move")
    move.add_argument("--timeout", type=float, default=60.0, metavar="S")

    halt = commands.add_parser("halt", help="HALT one controller, or every one with --all")
    target = halt.add_mutually_exclusive_group(required=True)
    target.add_argument("controller", nargs="?")
    target.add_argument("--all", action="store_true")

    job = commands.add_parser("job", help="submit or wait for a job")
    job_commands = job.add_subparsers(dest="job_command", required=True)
    submit = job_commands.add_parser("submit", help="submit a job; SPEC is JSON or @file")
    submit.add_argument("controller")
    submit.add_argument("type", choices=["array", "scan", "ring_buffer", "planar_correction", "gcode"])
    submit.add_argument("spec")
    submit.add_argument("--dry-run", action="store_true", help="plan only: nothing moves")
    submit.add_argument("--wait", action="store_true", help="follow it to its end")
    submit.add_argument("--idempotency-key")
    wait = job_commands.add_parser("wait", help="follow a job to its end, printing its progress")
    wait.add_argument("job_id")
    wait.add_argument("--timeout", type=float, metavar="S")

    follow = commands.add_parser("follow", help="print a topic's events as JSON lines")
    follow.add_argument("topics", nargs="+")
    follow.add_argument("--resume", action="append", default=[], metavar="TOPIC=SEQ")
    follow.add_argument("--count", type=int, help="stop after this many messages")
    return p


def _axes(items: Sequence[str]) -> dict[str, float]:
    axes: dict[str, float] = {}
    for item in items:
        axis, sep, value = item.partition("=")
        if not sep or not axis:
            raise SystemExit(f"asi-gateway-client: expected AXIS=UM, got {item!r}")
        try:
            axes[axis.upper()] = float(value)
        except ValueError:
            raise SystemExit(f"asi-gateway-client: not a number in {item!r}") from None
    return axes


def _spec(text: str) -> dict[str, Any]:
    if text.startswith("@"):
        with open(text[1:]) as f:
            text = f.read()
    try:
        spec = json.loads(text)
    except ValueError as e:
        raise SystemExit(f"asi-gateway-client: SPEC is not JSON: {e}") from None
    if not isinstance(spec, dict):
        raise SystemExit("asi-gateway-client: SPEC must be a JSON object")
    return spec


def _print_json(value: Any) -> None:
    print(json.dumps(value, sort_keys=True), flush=True)


def _controller_line(c: ControllerState) -> str:
    build = c.identity.build if c.identity else "-"
    axes = " ".join(f"{a}={'?' if p is None else f'{p:.2f}'}" for a, p in c.positions.items())
    return f"{c.id:<10} {c.state:<12} {build:<16} {'busy' if c.busy else 'idle':<5} {axes}"


def _progress_line(update: JobUpdate) -> None:
    p = update.progress
    step = f" {update.step}" if update.step else ""
    print(f"{update.job_id} {update.state} {p.steps_done}/{p.steps_total} {p.percent:.1f}%{step}", flush=True)


def _run(args: argparse.Namespace, gw: Gateway) -> int:
    if args.command == "list":
        controllers = gw.list_controllers()
        if args.json:
            _print_json([c.raw for c in controllers])
        else:
            for c in controllers:
                print(_controller_line(c))
        return 0
    if args.command == "move":
        stage = gw.stage(args.controller)
        axes = _axes(args.axes)
        wait = not args.no_wait
        if args.relative:
            result = stage.move_relative(axes, wait=wait, timeout_s=args.timeout)
        else:
            result = stage.move(axes, wait=wait, timeout_s=args.timeout)
        _print_json(result.raw)
        return 0
    if args.command == "halt":
        if args.all:
            _print_json({cid: r.raw for cid, r in gw.halt_all().items()})
        else:
            _print_json(gw.stage(args.controller).halt().raw)
        return 0
    if args.command == "job":
        if args.job_command == "submit":
            spec = _spec(args.spec)
            if args.dry_run:
                _print_json(dataclasses.asdict(gw.jobs.dry_run(args.controller, args.type, spec)))
                return 0
            job = gw.jobs.submit(args.controller, args.type, spec, idempotency_key=args.idempotency_key)
            _print_json(job.raw)
            if not args.wait:
                return 0
            job_id = job.id
            timeout = None
        else:
            job_id = args.job_id
            timeout = args.timeout
        final = gw.jobs.wait(job_id, on_progress=_progress_line, timeout_s=timeout)
        _print_json(final.raw)
        return 0
    if args.command == "follow":
        resume: dict[str, int] = {}
        for item in args.resume:
            topic, sep, seq = item.rpartition("=")
            if not sep or not seq.isdigit():
                raise SystemExit(f"asi-gateway-client: expected TOPIC=SEQ, got {item!r}")
            resume[topic] = int(seq)
        shown = 0
        with gw.subscribe(args.topics, resume=resume) as sub:
            for message in sub:
                if isinstance(message, Event):
                    _print_json(
                        {
                            "type": "event",
                            "topic": message.topic,
                            "seq": message.seq,
                            "time": message.time,
                            "data": message.data,
                        }
                    )
                elif isinstance(message, Gap):
                    _print_json(
                        {
                            "type": "gap",
                            "topic": message.topic,
                            "missed": message.missed,
                            "from": message.from_seq,
                            "to": message.to_seq,
                        }
                    )
                elif isinstance(message, Retired):
                    _print_json({"type": "retired", "topic": message.topic, "last_seq": message.last_seq})
                shown += 1
                if args.count is not None and shown >= args.count:
                    break
        return 0
    raise AssertionError(args.command)


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        with Gateway(args.url, token=args.token, ca_file=args.ca_file, verify=not args.insecure) as gw:
            return _run(args, gw)
    except JobEnded as e:
        print(f"asi-gateway-client: {e}", file=sys.stderr)
        _print_json(e.job.raw)
        return 3
    except Problem as e:
        print(f"asi-gateway-client: {e}", file=sys.stderr)
        print(json.dumps(e.body, sort_keys=True), file=sys.stderr)
        return 1
    except (GatewayError, TimeoutError) as e:
        print(f"asi-gateway-client: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
