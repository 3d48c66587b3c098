"""A fleet of gateways on a broker whose node dies (issue 37): N real asi-gateway processes (default
100), two simulated controllers each (--simulate 2: reports off, positions published at 1 Hz), on a
3-node NATS JetStream cluster (Debian's nats-server, MQTT 3.1.1) and, for comparison, on one mosquitto.

For each broker set-up:
- idle: every gateway's birth present at a watcher; CPU and memory per gateway over `--idle-s`;
- a scheduler sends a signed command (a relative move of 1 um, its own id, QoS 1, with reply_to) to
  every gateway every second, from `--lead-s` before the kill to `--tail-s` after it;
- the kill: NATS, kill -9 of one node (the gateways are spread over the three nodes, each given them
  all, its own first): the first, or with `--kill sessions-leader` the leader of NATS's MQTT session
  stream, so that NATS must elect a new one before it takes a connect (`--kill messages-leader`: of
  its message stream, which stores the QoS 1 commands); mosquitto, kill -9 and an immediate restart
  (the only node);
- with `--session-expiry-s N` the gateways keep their sessions and subscribe to commands at QoS 1,
  and NATS runs with `ack_wait` 2 s (the README's advice);
- from the kill, per gateway that was on the dead node: when it published its birth again (the birth's
  own time, as a watcher received it: p50, p99, max, and the spread: how many in the busiest 100 ms,
  so a lockstep reconnect shows);
- afterwards, every gateway's audit trail is read: each command ran once, not at all (lost, or
  refused as stale), or more than once (never expected: the gateway takes a (sender, id) once).

Debian's /usr/bin/python3 with python3-paho-mqtt; nats-server and mosquitto from Debian (bench/setup).
  /usr/bin/python3 bench/fleet_failover.py [--gateways 100] [--brokers nats mosquitto] \
      [--kill first|sessions-leader|messages-leader] [--session-expiry-s N] [--no-results]
"""

import argparse
import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests", "integration", "api"))
from bench_broker import MOSQUITTO  # noqa: E402
from bench_machine import publish_section  # noqa: E402
from gateway_fixture import TOKENS, auth_tokens, signed_command, signing_keys_config  # noqa: E402
from gateway_rig import Http, cpu_seconds, free_port, rss_mib, stop_process, wait_until  # noqa: E402
from nats_cluster import NatsCluster  # noqa: E402

import paho.mqtt.client as mqtt  # noqa: E402

PREFIX = "fleet"
REPLY = "clients/scheduler/replies"


class Watcher:
    """An MQTT 3.1.1 client (QoS 0 subscriptions: on NATS a QoS 1 one is a JetStream consumer) that
    notes the births and the answers, with their arrival times."""

    def __init__(self, port, name):
        self.lock = threading.Lock()
        self.births = {}    # gateway -> [(arrival, birth)]
        self.answers = {}   # command id -> [(arrival, answer)]
        self.c = mqtt.Client(client_id=name, protocol=mqtt.MQTTv311)
        self.c.on_message = self.on_message
        self.connected = threading.Event()
        self.c.on_connect = self.on_connect
        self.c.reconnect_delay_set(0.1, 1)  # back at once after a broker's restart
        self.c.connect("127.0.0.1", port, keepalive=30)
        self.c.loop_start()
        if not self.connected.wait(30):
            raise RuntimeError(f"watcher {name} could not connect")

    def on_connect(self, client, userdata, flags, rc):
        # A clean session: subscribed again after every connect.
        self.c.subscribe(f"{PREFIX}/+/status", qos=0)
        self.c.subscribe(REPLY, qos=0)
        self.connected.set()

    def on_message(self, client, userdata, msg):
        now = time.monotonic()
        try:
            body = json.loads(msg.payload)
        except ValueError:
            return
        with self.lock:
            if msg.topic == REPLY:
                self.answers.setdefault(str(body.get("id")), []).append((now, body))
            elif body.get("state") == "online":
                self.births.setdefault(body["gateway"], []).append((now, body))

    def births_since(self, wall_t):
        """gateway -> seconds from `wall_t` (time.time()) to the first birth it published after it, by
        the birth's own "time" (the gateways' clock is this machine's): a watcher that itself
        reconnects gets the births retained meanwhile all at once, which says nothing of when they
        were published."""
        out = {}
        with self.lock:
            for g, births in self.births.items():
                times = [published(b) for _, b in births]
                after = [t for t in times if t is not None and t >= wall_t]
                out[g] = min(after) - wall_t if after else None
        return out

    def close(self):
        self.c.loop_stop()
        self.c.disconnect()


class Scheduler(threading.Thread):
    """Every second, one signed command to every gateway (a relative move of 1 um), QoS 1."""

    def __init__(self, port, gateways):
        super().__init__(daemon=True)
        self.gateways = gateways
        self.sent = {}  # id -> (gateway, time)
        self.stop_at = None
        self.c = mqtt.Client(client_id="fleet-scheduler", protocol=mqtt.MQTTv311)
        self.c.reconnect_delay_set(0.1, 1)
        connected = threading.Event()
        self.c.on_connect = lambda *a: connected.set()
        self.c.connect("127.0.0.1", port, keepalive=30)
        self.c.loop_start()
        if not connected.wait(30):
            raise RuntimeError("the scheduler could not connect")

    def run(self):
        tick = 0
        next_at = time.monotonic()
        while self.stop_at is None or time.monotonic() < self.stop_at:
            for g in self.gateways:
                cid = f"{g}-{tick}"
                topic = f"{PREFIX}/{g}/controllers/sim1/cmd"
                body = {"id": cid, "operation": "move", "reply_to": REPLY,
                        "args": {"axes": {"X": 1}, "mode": "relative"}}
                self.c.publish(topic, signed_command(topic, body, "operator"), qos=1)
                self.sent[cid] = (g, time.monotonic())
            tick += 1
            next_at += 1.0
            time.sleep(max(0.0, next_at - time.monotonic()))

    def close(self):
        self.c.loop_stop()
        self.c.disconnect()


class Mosquitto:
    """One mosquitto on a free port, kill -9 and start again on the same port."""

    def __init__(self, tmp):
        self.port = free_port()
        self.conf = os.path.join(tmp, "mosquitto.conf")
        with open(self.conf, "w") as f:
            f.write("\n".join(["allow_anonymous true", "persistence false", "max_connections -1",
                               *(["user root"] if os.geteuid() == 0 else []),
                               f"listener {self.port} 127.0.0.1"]) + "\n")
        self.start()

    def start(self):
        self.proc = subprocess.Popen([MOSQUITTO, "-c", self.conf], stdout=subprocess.DEVNULL,
                                     stderr=subprocess.STDOUT)
        wait_until("mosquitto accepting", lambda: self._accepting(), timeout=10)

    def _accepting(self):
        import socket
        try:
            socket.create_connection(("127.0.0.1", self.port), 1).close()
            return True
        except OSError:
            return False

    def uris(self):
        return [f"tcp://127.0.0.1:{self.port}"]

    def stop(self):
        stop_process(self.proc)


def published(birth):
    """A birth's "time" (ISO 8601 UTC with ms) as seconds since the epoch, or None."""
    import datetime
    try:
        return datetime.datetime.strptime(birth["time"], "%Y-%m-%dT%H:%M:%S.%fZ").replace(
            tzinfo=datetime.timezone.utc).timestamp()
    except (KeyError, TypeError, ValueError):
        return None


def streams_led_again(cluster, since):
    """Seconds from `since` (epoch) to the last "new stream leader" a live node logged for one of the
    MQTT streams (sessions, messages, retained): NATS takes no MQTT connect and no retained message for
    a stream without a leader. None when no MQTT stream needed a new leader."""
    import datetime
    last = None
    for i, p in enumerate(cluster.nodes):
        if p is None or p.poll() is not None:
            continue
        with open(cluster.log(i)) as f:
            for line in f:
                if "new stream leader for '$G > $MQTT_" not in line:
                    continue
                # "[pid] 2026/12/06 13:35:15.386334 [INF] ...", in the machine's local time
                stamp = " ".join(line.split()[1:3])
                try:
                    at = datetime.datetime.strptime(stamp, "%Y/%m/%d %H:%M:%S.%f").timestamp()
                except ValueError:
                    continue
                if at > since:
                    last = max(last or 0.0, at - since)
    return last


def gateway_config(name, port, tmp, brokers, nats, session_expiry_s=0):
    # A kept session only queues commands for QoS 1 subscriptions: on NATS those are then QoS 1 too.
    qos = {"responses": 0} if nats and not session_expiry_s else {}
    return {
        "http": {"listen_address": "127.0.0.1", "port": port},
        "storage": {"path": os.path.join(tmp, name)},
        "auth": auth_tokens(),
        "logging": {"level": "warn"},
        "mqtt": {"enabled": True, "brokers": brokers, "gateway_id": name, "topic_prefix": PREFIX,
                 "protocol": "3.1.1" if nats else "5",
                 "telemetry": {"position_max_hz": 1},
                 "qos": qos, "session_expiry_s": session_expiry_s,
                 "commands": {"enabled": True, "signing_keys": signing_keys_config()}},
    }


def start_fleet(binary, n, tmp, uris, nats, session_expiry_s=0):
    fleet = []
    for i in range(n):
        name = f"gw{i:03d}"
        port = free_port()
        # Each its own node first: the fleet spread over the cluster, as a lab would list its nodes.
        order = uris[i % len(uris):] + uris[:i % len(uris)]
        cfg = os.path.join(tmp, name + ".json")
        with open(cfg, "w") as f:
            json.dump(gateway_config(name, port, tmp, order, nats, session_expiry_s), f)
        log = open(os.path.join(tmp, name + ".log"), "w")
        proc = subprocess.Popen([binary, "--config", cfg, "--simulate", "2", "--sim-dir",
                                 os.path.join(tmp, name + "-sims")], stdout=log, stderr=subprocess.STDOUT)
        log.close()
        fleet.append({"name": name, "port": port, "proc": proc, "first": order[0]})
    for g in fleet:
        wait_until(f"{g['name']} ready", lambda g=g: Http(g["port"]).request("GET", "/api/v1/ready")[0] == 200,
                   timeout=120)
    return fleet


def link_report(g):
    """A gateway's own word on its broker link: health's mqtt, and what it published and dropped."""
    report = json.loads(Http(g["port"]).request("GET", "/api/v1/health")[1]).get("mqtt")
    status, text = Http(g["port"]).request("GET", "/api/v1/metrics", token=TOKENS["viewer"])
    if status == 200:
        report["counts"] = [line for line in text.splitlines()
                            if line.startswith(("gw_mqtt_published_total", "gw_mqtt_dropped_total"))]
    return report


def pct(values, p):
    if not values:
        return float("nan")
    s = sorted(values)
    return s[min(len(s) - 1, int(round(p / 100 * (len(s) - 1))))]


def audit_counts(g, ids_prefix):
    """request id -> entries in the gateway's audit trail (the scheduler's commands only)."""
    counts = {}
    before = None
    while True:
        path = "/api/v1/audit?principal=operator&limit=500" + (f"&before={before}" if before else "")
        status, body = Http(g["port"]).request("GET", path, token=TOKENS["admin"])
        if status != 200:
            raise RuntimeError(f"audit of {g['name']}: {status} {body}")
        page = json.loads(body)
        for e in page["entries"]:
            rid = e["request_id"]
            if rid.startswith("mqtt." + ids_prefix):
                counts[rid[len("mqtt."):]] = counts.get(rid[len("mqtt."):], 0) + 1
        before = page.get("next_before")
        if not before:
            return counts


def run_setup(kind, args, tmp):
    nats = kind == "nats"
    procs = []
    # Kept sessions on NATS: its ack_wait short, as the README advises (what a session held while its
    # gateway was away is handed over only when ack_wait runs out).
    ack_wait = "2s" if args.session_expiry_s else None
    broker = NatsCluster(tmp, procs, ack_wait=ack_wait) if nats else Mosquitto(tmp)
    if nats:
        broker.start()
    uris = broker.broker_uris() if nats else broker.uris()
    result = {"kind": kind, "gateways": args.gateways,
              "killed": {"sessions-leader": "the sessions' leader", "messages-leader": "the messages' leader"}
              .get(args.kill, "a node"),
              "sessions": (f"kept {args.session_expiry_s} s" + (f", NATS ack_wait {ack_wait}" if nats else ""))
              if args.session_expiry_s else "clean"}
    fleet = []
    watcher = scheduler = None
    try:
        started = time.monotonic()
        fleet = start_fleet(args.gateway, args.gateways, tmp, uris, nats, args.session_expiry_s)
        names = [g["name"] for g in fleet]
        # NATS: the node to kill, and the watcher and the scheduler on one that lives.
        leads = {"sessions-leader": "$MQTT_sess", "messages-leader": "$MQTT_msgs"}.get(args.kill)
        victim = (broker.stream_leader(leads) if leads else 0) if nats else None
        port = broker.mqtt_ports[2 if victim == 0 else 0] if nats else broker.port
        watcher = Watcher(port, "fleet-watcher")
        try:
            wait_until("every birth at the watcher", lambda: len(watcher.births) >= len(fleet), timeout=60)
        except RuntimeError:
            # Told and counted, and the run goes on: NATS 2.9 was seen to serve a retained message on
            # the node it was published to and not on another.
            for g in fleet:
                if g["name"] not in watcher.births:
                    print(f"  {g['name']}: no retained birth at the watcher; it says {link_report(g)}", flush=True)
        result["start_s"] = time.monotonic() - started
        result["births"] = len(watcher.births)
        # Idle: CPU over a window, memory at its end.
        time.sleep(5)
        cpu0 = {g["name"]: cpu_seconds(g["proc"].pid) for g in fleet}
        t0 = time.monotonic()
        time.sleep(args.idle_s)
        elapsed = time.monotonic() - t0
        cpu = [100 * (cpu_seconds(g["proc"].pid) - cpu0[g["name"]]) / elapsed for g in fleet]
        rss = [rss_mib(g["proc"].pid) for g in fleet]
        result.update(cpu_mean=statistics.mean(cpu), cpu_max=max(cpu), rss_mean=statistics.mean(rss),
                      rss_max=max(rss), broker_rss=sum(rss_mib(p.pid) for p in (broker.nodes if nats else
                                                                                   [broker.proc])))
        # The failover, under the scheduler's load.
        scheduler = Scheduler(port, names)
        scheduler.start()
        time.sleep(args.lead_s)
        # The gateways on the node about to die, by their own word (a gateway whose first node was not
        # ready at its start may be on another).
        on = {g["name"]: json.loads(Http(g["port"]).request("GET", "/api/v1/health")[1])["mqtt"]["broker"]
              for g in fleet}
        killed = time.time()
        if nats:
            dead_uri = uris[victim]
            affected = [name for name, broker_uri in on.items() if broker_uri == dead_uri]
            broker.kill(victim)
        else:
            affected = names
            broker.proc.send_signal(signal.SIGKILL)
            broker.proc.wait()
            broker.start()
        scheduler.stop_at = time.monotonic() + args.tail_s
        scheduler.join()
        time.sleep(5)  # the last answers
        result["streams_led_s"] = streams_led_again(broker, killed) if nats else None
        backs = watcher.births_since(killed)
        back_s = sorted(backs[g] for g in affected if backs.get(g) is not None)
        missing = [g for g in affected if backs.get(g) is None]
        # A birth the watcher missed, or a gateway that did not come back: its own word on its link.
        result["missing"] = {g["name"]: link_report(g) for g in fleet if g["name"] in missing}
        result.update(affected=len(affected), back=len(back_s), back_p50=pct(back_s, 50), back_p99=pct(back_s, 99),
                      back_max=back_s[-1] if back_s else float("nan"), back_min=back_s[0] if back_s else float("nan"))
        # The busiest 100 ms of reconnects: a fleet in lockstep lands most of itself in one.
        buckets = {}
        for s in back_s:
            buckets[int(s * 10)] = buckets.get(int(s * 10), 0) + 1
        result["busiest_100ms"] = max(buckets.values()) if buckets else 0
        # Every command: ran once, not at all, or more than once (audit); answered how.
        ran = {}
        for g in fleet:
            ran.update(audit_counts(g, g["name"] + "-"))
        sent = scheduler.sent
        with watcher.lock:
            answers = dict(watcher.answers)
        result["sent"] = len(sent)
        result["ran_once"] = sum(1 for cid in sent if ran.get(cid, 0) == 1)
        result["ran_twice"] = sum(1 for cid in sent if ran.get(cid, 0) > 1)
        not_run = [cid for cid in sent if ran.get(cid, 0) == 0]
        stale = [cid for cid in not_run if any(a[1].get("type") == "error" and
                                               str(a[1].get("problem", {}).get("type", "")).endswith("stale-command")
                                               for a in answers.get(cid, []))]
        result["not_run"] = len(not_run)
        result["not_run_stale"] = len(stale)
        result["answered_twice"] = sum(1 for cid in sent if len(answers.get(cid, [])) > 1)
        result["unanswered_but_ran"] = sum(1 for cid in sent if ran.get(cid, 0) >= 1 and not answers.get(cid))
        return result
    finally:
        if scheduler:
            scheduler.close()
        if watcher:
            watcher.close()
        for g in fleet:
            g["proc"].terminate()
        for g in fleet:
            try:
                g["proc"].wait(timeout=20)
            except subprocess.TimeoutExpired:
                g["proc"].kill()
        if nats:
            for p in procs:
                if p.poll() is None:
                    p.kill()
        else:
            broker.stop()


def table(results):
    head = ("| broker | gateways | births | idle CPU per gateway (mean / max) | RSS per gateway (mean / max) | "
            "broker RSS | on the dead node | birth published again after the kill (min / p50 / p99 / max) | "
            "busiest 100 ms | NATS's MQTT streams led again | commands sent | ran once | ran twice | "
            "not run (of which refused stale) | "
            "answered twice | ran, answer lost |")
    rows = [head, "|" + " --- |" * 16]
    for r in results:
        label = f"NATS 2.9, 3 nodes (kill -9 of {r['killed']}; sessions {r['sessions']})" if r["kind"] == "nats" else \
            "mosquitto 2.0.11, 1 node (kill -9, restarted at once)"
        led = r.get("streams_led_s")
        led = "n/a" if r["kind"] != "nats" else "no election" if led is None else f"{led:.2f} s after the kill"
        rows.append(f"| {label} | {r['gateways']} | {r['births']} present | "
                    f"{r['cpu_mean']:.2f} % / {r['cpu_max']:.2f} % | "
                    f"{r['rss_mean']:.1f} / {r['rss_max']:.1f} MiB | {r['broker_rss']:.0f} MiB | {r['affected']} | "
                    f"{r['back_min']:.2f} / {r['back_p50']:.2f} / {r['back_p99']:.2f} / {r['back_max']:.2f} s "
                    f"({r['back']} of {r['affected']}) | {r['busiest_100ms']} | {led} | {r['sent']} | "
                    f"{r['ran_once']} | "
                    f"{r['ran_twice']} | {r['not_run']} ({r['not_run_stale']}) | {r['answered_twice']} | "
                    f"{r['unanswered_but_ran']} |")
    return "\n".join(rows)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", default=os.path.join(HERE, "..", "build", "gateway", "asi-gateway"))
    ap.add_argument("--gateways", type=int, default=100)
    ap.add_argument("--brokers", nargs="+", default=["nats", "mosquitto"], choices=["nats", "mosquitto"])
    ap.add_argument("--idle-s", type=float, default=20)
    ap.add_argument("--lead-s", type=float, default=10)
    ap.add_argument("--tail-s", type=float, default=30)
    ap.add_argument("--no-results", action="store_true")
    ap.add_argument("--session-expiry-s", type=int, default=0,
                    help="the gateways' mqtt.session_expiry_s: the broker keeps their sessions (and QoS 1 commands)")
    ap.add_argument("--kill", choices=["first", "sessions-leader", "messages-leader"], default="first",
                    help="NATS: kill the first node, or the leader of the MQTT session or message stream (an election)")
    args = ap.parse_args()
    load_before = os.getloadavg()
    results = []
    for kind in args.brokers:
        with tempfile.TemporaryDirectory(prefix=f"fleet-{kind}-") as tmp:
            print(f"{kind}: {args.gateways} gateways ...", flush=True)
            r = run_setup(kind, args, tmp)
            print(json.dumps(r), flush=True)
            for g, link in r["missing"].items():
                print(f"  {g}: no birth seen after the kill; it says {link}")
            results.append(r)
    load_after = os.getloadavg()
    met = all(r["births"] == args.gateways and r["ran_twice"] == 0 and r["back"] == r["affected"] for r in results)
    details = (f"{args.gateways} gateways (asi-gateway --simulate 2, positions at 1 Hz, reports off), one watcher "
               f"and one scheduler (a signed relative move to every gateway every second, QoS 1, "
               f"{args.lead_s:.0f} s before the kill to {args.tail_s:.0f} s after); idle over {args.idle_s:.0f} s. "
               "Goals: every birth present, every gateway on the dead node back, no command run twice "
               + ("(sessions kept: the broker holds the commands sent while a gateway is away; on NATS the "
                  "command subscriptions are QoS 1)." if args.session_expiry_s else
                  "(a command sent while its gateway had no broker is not run: QoS 0 subscriptions and clean "
                  "sessions, by design; see the README)."))
    return publish_section(f"Fleet failover: {args.gateways} gateways on a 3-node NATS cluster and on one mosquitto",
                           "bench/fleet_failover.py", details, load_before, load_after, table(results), met,
                           None if args.no_results else os.path.join(HERE, "RESULTS.md"))


if __name__ == "__main__":
    sys.exit(main())
