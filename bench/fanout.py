#!/usr/bin/python3
"""Benchmark: report fan-out from many controllers to many WebSocket clients (issue 16).

The rig, built to cost little next to the gateway on a small machine:
* bench/report_generator.c: --controllers ptys, one binary TTL_REPORT frame (16 bytes) to each every
  1/--rate s; each pty is one controller's report port in the gateway's config;
* one ms2000-sim per controller for its command port (plain, no report port of its own: the
  generator's pty takes that place), polled by the gateway at its defaults;
* bench/fanout_client.c: --clients WebSocket connections in one epoll loop, each subscribed to
  controllers/+/reports (?batch_ms=--batch-ms, or plain messages with --batch-ms -1), counting every
  event and gap and taking each event's latency from its time_ms (the gateway's clock when the bytes
  arrived) to when the client read it;
* MQTT at the same time: the gateway's bridge publishes the report batches to a mosquitto broker, and
  bench/mqtt_fanout_client.c subscribes --mqtt-clients connections to them (0: no MQTT);
* then the peer, mosquitto alone (skipped with --no-peer): bench/mqtt_report_publisher.c publishes the
  same frames, one message each, as the gateway would batch them, at the same rate, to a broker that
  fans them out to --clients MQTT subscribers. Its CPU per delivered message is the figure the
  gateway's CPU per delivered frame is set against.

Each run measures --seconds of frames, then 2 s for the last ones to arrive, and prints: frames the generator
wrote; events every client should have got and did (min and max over clients); what gap events told
them they missed; connections the gateway closed; latency p50/p99/max; CPU seconds of the gateway,
the generator, the simulators and the client, per second and (the gateway's) per delivered event;
the gateway's RSS at the end. With --results the table is appended to bench/RESULTS.md.

  scripts/build && /usr/bin/python3 bench/fanout.py [--controllers 32] [--rate 500] [--clients 100] \\
      [--batch-ms 10] [--mqtt-clients 1] [--mqtt-batch-ms 10] [--seconds 10] [--no-peer]

The per-second worst latency of each client program goes to stderr ("second N max_ms M").
"""

import argparse
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

sys.dont_write_bytecode = True
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_broker import Mosquitto  # noqa: E402
from bench_gateway import Gateway  # noqa: E402
from bench_machine import publish_section  # noqa: E402
from bench_sim import Sim  # noqa: E402
from gateway_rig import cpu_seconds, rss_mib  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def metric_sum(gw, name):
    """The sum of a metric's series in the gateway's /api/v1/metrics."""
    status, text = gw.request("GET", "/api/v1/metrics")
    if status != 200:
        raise RuntimeError(f"/api/v1/metrics answered {status}")
    return sum(float(line.rsplit(" ", 1)[1]) for line in text.splitlines()
               if line.startswith(name + "{") or line.startswith(name + " "))


def build(workdir, name):
    out = os.path.join(workdir, name)
    if not os.path.exists(out):
        subprocess.run(["cc", "-O2", "-std=c11", "-o", out, os.path.join(ROOT, "bench", name + ".c")], check=True)
    return out


def wait_for_report_ports(gw, timeout=120):
    deadline = time.monotonic() + timeout
    while True:
        status, body = gw.request("GET", "/api/v1/controllers")
        if status == 200 and all(c["report_port"] == "open" for c in body["controllers"]):
            return
        if time.monotonic() > deadline:
            raise RuntimeError("the report ports did not open")
        time.sleep(0.2)


def read_line(proc, expected):
    line = proc.stdout.readline()
    if not line.startswith(expected):
        raise RuntimeError(f"expected {expected!r}, got {line!r}")
    return line


def pairs(line):
    words = line.split()
    return {words[i]: float(words[i + 1]) for i in range(0, len(words) - 1, 2)}


def stop_all(procs):
    for p in procs:
        if p and p.poll() is None:
            p.kill()
            p.wait()


def run(args, tmp):
    """The gateway: report frames on ptys in, WebSocket clients and MQTT (through a broker) out."""
    generator_bin, client_bin = build(tmp, "report_generator"), build(tmp, "fanout_client")
    reports = os.path.join(tmp, "reports")
    os.makedirs(reports)
    generator = subprocess.Popen([generator_bin, reports, str(args.controllers), str(args.rate)],
                                 stdout=subprocess.PIPE, text=True)
    sims, gw, client, broker, mqtt_client = [], None, None, None, None
    try:
        read_line(generator, "ready")
        sims = [Sim(args.sim, tmp, f"c{i}", 115200) for i in range(args.controllers)]
        controllers = [{"id": f"c{i}", "port": s.link, "report_port": os.path.join(reports, f"r{i}"), "baud": 115200}
                       for i, s in enumerate(sims)]
        config = {"controllers": controllers,
                  "http": {"limits": {"max_connections": 2000, "max_connections_per_address": 1500}}}
        if args.mqtt_clients > 0:
            broker = Mosquitto(tmp)
            config["mqtt"] = {"enabled": True, "brokers": [f"mqtt://127.0.0.1:{broker.port}"], "gateway_id": "bench",
                              "telemetry": {"reports_batch_ms": args.mqtt_batch_ms},
                              "tcp_nodelay": not args.mqtt_nagle}
        gw_dir = os.path.join(tmp, "gateway")
        os.makedirs(gw_dir)
        gw = Gateway(args.gateway, gw_dir, config)
        gw.wait_ready()
        wait_for_report_ports(gw)
        client = subprocess.Popen([client_bin, str(gw.port), str(args.clients), str(args.batch_ms),
                                   "controllers/+/reports"], stdout=subprocess.PIPE, text=True)
        read_line(client, "subscribed")
        if broker:
            mqtt_client = subprocess.Popen([build(tmp, "mqtt_fanout_client"), str(broker.port), str(args.mqtt_clients),
                                            "asi/bench/controllers/+/reports"], stdout=subprocess.PIPE, text=True)
            read_line(mqtt_client, "subscribed")
        time.sleep(1)

        procs = {"gateway": gw.proc.pid, "generator": generator.pid, "client": client.pid}
        if broker:
            procs.update({"broker": broker.proc.pid, "mqtt_client": mqtt_client.pid})
        before = {k: cpu_seconds(p) for k, p in procs.items()}
        sims_before = sum(cpu_seconds(s.proc.pid) for s in sims)
        generator.send_signal(signal.SIGUSR1)
        start = time.monotonic()
        time.sleep(args.seconds)
        generator.terminate()
        written = pairs(generator.stdout.readline())
        time.sleep(2)  # the last frames on their way
        elapsed = time.monotonic() - start
        after = {k: cpu_seconds(p) for k, p in procs.items()}
        sims_after = sum(cpu_seconds(s.proc.pid) for s in sims)
        rss = rss_mib(gw.proc.pid)
        decoded = metric_sum(gw, "gw_controller_report_frames_total")
        skipped = metric_sum(gw, "gw_controller_report_bytes_skipped_total")
        mqtt_dropped = metric_sum(gw, "gw_mqtt_dropped_total") if broker else 0
        broker_dropped = broker.dropped() if broker else 0
        client.terminate()
        got = pairs(client.stdout.readline())
        mqtt_got = None
        if mqtt_client:
            mqtt_client.terminate()
            mqtt_got = pairs(mqtt_client.stdout.readline())
        cpu = {k: after[k] - before[k] for k in procs}
        cpu["simulators"] = sims_after - sims_before
        return {"written": written, "got": got, "mqtt": mqtt_got, "cpu": cpu, "elapsed": elapsed, "rss": rss,
                "decoded": decoded, "skipped": skipped, "mqtt_dropped": mqtt_dropped, "broker_dropped": broker_dropped}
    finally:
        stop_all([client, mqtt_client, generator])
        if gw:
            gw.stop()
        if broker:
            broker.stop()
        for s in sims:
            s.stop()


def run_peer(args, tmp):
    """mosquitto alone: the same frames published one message each, fanned out to --clients subscribers."""
    broker, publisher, client = Mosquitto(tmp), None, None
    try:
        publisher = subprocess.Popen([build(tmp, "mqtt_report_publisher"), str(broker.port), str(args.controllers),
                                      str(args.rate), "asi/bench"], stdout=subprocess.PIPE, text=True)
        read_line(publisher, "ready")
        client = subprocess.Popen([build(tmp, "mqtt_fanout_client"), str(broker.port), str(args.clients),
                                   "asi/bench/controllers/+/reports"], stdout=subprocess.PIPE, text=True)
        read_line(client, "subscribed")
        time.sleep(1)
        procs = {"broker": broker.proc.pid, "publisher": publisher.pid, "client": client.pid}
        before = {k: cpu_seconds(p) for k, p in procs.items()}
        publisher.send_signal(signal.SIGUSR1)
        start = time.monotonic()
        time.sleep(args.seconds)
        publisher.terminate()
        written = pairs(publisher.stdout.readline())
        time.sleep(2)
        elapsed = time.monotonic() - start
        after = {k: cpu_seconds(p) for k, p in procs.items()}
        rss = rss_mib(broker.proc.pid)
        client.terminate()
        got = pairs(client.stdout.readline())
        return {"written": written, "got": got, "cpu": {k: after[k] - before[k] for k in procs}, "elapsed": elapsed,
                "rss": rss}
    finally:
        stop_all([client, publisher])
        broker.stop()


def latencies(got):
    """"p50 / p99 / max" in ms, or "none arrived"."""
    if got["p50_ms"] < 0:
        return "none arrived"
    return f"{got['p50_ms']:.1f} / {got['p99_ms']:.1f} / {got['max_ms']:.1f}"


def table(args, r, peer):
    w, g, cpu, m = r["written"], r["got"], r["cpu"], r["mqtt"]
    frames = int(w["written"])
    expected = frames * args.clients
    delivered = int(g["events"])
    mode = "plain messages" if args.batch_ms < 0 else f"batch_ms={args.batch_ms}"
    per_event_us = cpu["gateway"] / delivered * 1e6 if delivered else float("nan")
    lines = [
        "| figure | value |", "|---|---:|",
        f"| controllers x rate | {args.controllers} x {args.rate:g} frames/s |",
        f"| WebSocket clients | {args.clients} ({mode}) |",
        f"| frames written (refused by a full pty, late ticks) | {frames:,} ({int(w['refused']):,}, "
        f"{int(w['late']):,}) |",
        f"| frames the gateway decoded (bytes it skipped) | {int(r['decoded']):,} ({int(r['skipped']):,}) |",
        f"| events due to the WebSocket clients | {expected:,} |",
        f"| events delivered (per client min / max) | {delivered:,} ({int(g['min_events']):,} / "
        f"{int(g['max_events']):,}) |",
        f"| told missed (gap events) | {int(g['missed']):,} |",
        f"| unaccounted | {expected - delivered - int(g['missed']):,} |",
        f"| clients closed by the gateway | {int(g['closed'])} |",
        f"| latency p50 / p99 / max ms | {latencies(g)} |",
    ]
    mqtt_ok = True
    if m:
        due = frames * args.mqtt_clients
        got = int(m["events"])
        mqtt_ok = got == due and 0 <= m["p99_ms"] < 20
        lines += [
            f"| MQTT subscribers (through mosquitto) | {args.mqtt_clients} (reports_batch_ms={args.mqtt_batch_ms}, "
            f"tcp_nodelay {'false' if args.mqtt_nagle else 'true'}) |",
            f"| MQTT frames due / delivered / told missed | {due:,} / {got:,} / {int(m['missed']):,} |",
            f"| MQTT messages (report batches) | {int(m['messages']):,} |",
            f"| MQTT messages dropped: by the gateway / by mosquitto (a full subscriber queue) | "
            f"{int(r['mqtt_dropped']):,} / {r['broker_dropped']:,} |",
            f"| MQTT latency p50 / p99 / max ms (1 ms clock) | {latencies(m)} |",
        ]
    lines += [
        f"| gateway CPU (cores) | {cpu['gateway'] / r['elapsed']:.2f} |",
        f"| gateway CPU per delivered event | {per_event_us:.2f} us |",
        f"| rig CPU (cores): generator / simulators / client | {cpu['generator'] / r['elapsed']:.2f} / "
        f"{cpu['simulators'] / r['elapsed']:.2f} / {cpu['client'] / r['elapsed']:.2f} |",
    ]
    if m:
        lines.append(f"| rig CPU (cores): mosquitto / MQTT client | {cpu['broker'] / r['elapsed']:.2f} / "
                     f"{cpu['mqtt_client'] / r['elapsed']:.2f} |")
    lines.append(f"| gateway RSS at the end | {r['rss']:.1f} MiB |")
    met = (delivered == expected and int(g["closed"]) == 0 and g["p99_ms"] < 20
           and cpu["gateway"] / r["elapsed"] < 1.0 and mqtt_ok)
    if peer:
        pw, pg, pcpu = peer["written"], peer["got"], peer["cpu"]
        pframes = int(pw["written"])
        pdue, pgot = pframes * args.clients, int(pg["events"])
        peer_us = pcpu["broker"] / pgot * 1e6 if pgot else float("nan")
        lines += [
            "",
            f"The peer in the same run: mosquitto alone, the same {args.controllers} x {args.rate:g} frames/s "
            f"published one message each (late ticks: {int(pw['late']):,}), to {args.clients} MQTT subscribers.",
            "",
            "| figure | gateway (WebSocket) | mosquitto |",
            "|---|---:|---:|",
            f"| frames due to the clients | {expected:,} | {pdue:,} |",
            f"| delivered | {delivered:,} | {pgot:,} |",
            f"| latency p50 / p99 / max ms | {latencies(g)} | {latencies(pg)} (1 ms clock) |",
            f"| server CPU (cores) | {cpu['gateway'] / r['elapsed']:.2f} | {pcpu['broker'] / peer['elapsed']:.2f} |",
            f"| server CPU per delivered frame (goal: gateway <= mosquitto) | {per_event_us:.2f} us | "
            f"{peer_us:.2f} us |",
            f"| server RSS at the end | {r['rss']:.1f} MiB | {peer['rss']:.1f} MiB |",
            f"| client CPU (cores) | {cpu['client'] / r['elapsed']:.2f} | {pcpu['client'] / peer['elapsed']:.2f} |",
        ]
        met = met and per_event_us <= peer_us
    return "\n".join(lines), met


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--gateway", default=os.path.join(ROOT, "build", "gateway", "asi-gateway"))
    p.add_argument("--sim", default=os.path.join(ROOT, "build", "devices", "sim", "ms2000-sim"))
    p.add_argument("--controllers", type=int, default=32)
    p.add_argument("--rate", type=float, default=500)
    p.add_argument("--clients", type=int, default=100)
    p.add_argument("--batch-ms", type=int, default=10, help="the clients' batch_ms; -1: plain messages")
    p.add_argument("--mqtt-clients", type=int, default=1, help="MQTT subscribers of the gateway's bridge; 0: none")
    p.add_argument("--mqtt-batch-ms", type=int, default=10, help="the gateway's mqtt.telemetry.reports_batch_ms")
    p.add_argument("--mqtt-nagle", action="store_true", help="the gateway's mqtt.tcp_nodelay false")
    p.add_argument("--no-peer", action="store_true", help="skip the mosquitto run")
    p.add_argument("--seconds", type=float, default=10)
    p.add_argument("--results", default="", help="append the table to this file (e.g. bench/RESULTS.md)")
    args = p.parse_args()
    tmp = tempfile.mkdtemp(prefix="gw-fanout-")
    try:
        load_before = os.getloadavg()
        r = run(args, tmp)
        peer = None if args.no_peer else run_peer(args, tmp)
        load_after = os.getloadavg()
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    text, met = table(args, r, peer)
    details = (f"{args.seconds:g} s of frames per run. Goal (issue 16): every frame to every client, WebSocket "
               "and MQTT, none closed, p99 under 20 ms, the gateway under one core and at most mosquitto's CPU per "
               "delivered frame.")
    return publish_section("Report fan-out", "bench/fanout.py", details, load_before, load_after, text, met,
                           args.results)


if __name__ == "__main__":
    sys.exit(main())
