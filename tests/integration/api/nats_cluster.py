"""A 3-node NATS JetStream cluster with its MQTT front end (Debian's nats-server 2.9), for the tests
and benchmarks of a gateway given every node as a broker.

Each node: a client port, a cluster route to the two others, JetStream in the scratch directory, and
an MQTT listener (MQTT 3.1.1, QoS 0/1) whose sessions and retained messages live in streams
replicated on all three nodes (`stream_replicas 3`), so that they survive one node's death.

    cluster = NatsCluster(fx.tmp, fx.procs)
    cluster.start()                      # waits until every MQTT listener accepts and JetStream is up
    brokers = cluster.broker_uris()      # ["tcp://127.0.0.1:P1", ...] for mqtt.brokers
    cluster.kill(1)                      # SIGKILL node 1
    cluster.stream_leader("$MQTT_msgs")  # the node that leads NATS's MQTT message stream
    NatsCluster(tmp, procs, ack_wait="2s")  # NATS's mqtt ack_wait (the README's advice for kept sessions)
"""

import os
import shutil
import signal
import socket
import subprocess
import time

NATS_SERVER = shutil.which("nats-server") or "/usr/sbin/nats-server"


def _free_ports(n):
    socks, ports = [], []
    try:
        for _ in range(n):
            s = socket.socket()
            s.bind(("127.0.0.1", 0))
            socks.append(s)
            ports.append(s.getsockname()[1])
    finally:
        for s in socks:
            s.close()
    return ports


def _accepting(port):
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=0.2):
            return True
    except OSError:
        return False


class NatsCluster:
    def __init__(self, tmp, procs, nodes=3, name="c1", ack_wait=None):
        self.tmp = tmp
        # NATS's mqtt.ack_wait (default 30 s): a QoS 1 message a client has not acknowledged is sent
        # again after it, and what a kept session held while its client was away came only then.
        self.ack_wait = ack_wait
        self.procs = procs  # the fixture's list: whatever is left running is stopped at clean-up
        self.name = name
        ports = _free_ports(3 * nodes)
        self.client_ports = ports[0:nodes]
        self.route_ports = ports[nodes:2 * nodes]
        self.mqtt_ports = ports[2 * nodes:3 * nodes]
        self.nodes = [None] * nodes
        self.restarted = set()  # nodes started again after a kill
        for i in range(nodes):
            self._write_config(i)

    def conf(self, i):
        return os.path.join(self.tmp, f"nats-n{i + 1}.conf")

    def log(self, i):
        return os.path.join(self.tmp, f"nats-n{i + 1}.log")

    def _write_config(self, i):
        ack_wait = f', ack_wait: "{self.ack_wait}"' if self.ack_wait else ""
        routes = ", ".join(f"nats-route://127.0.0.1:{p}" for j, p in enumerate(self.route_ports) if j != i)
        text = f"""server_name: n{i + 1}
listen: 127.0.0.1:{self.client_ports[i]}
jetstream {{ store_dir: "{os.path.join(self.tmp, f'nats-n{i + 1}')}" }}
cluster {{ name: {self.name}, listen: 127.0.0.1:{self.route_ports[i]}, routes: [{routes}] }}
mqtt {{ listen: 127.0.0.1:{self.mqtt_ports[i]}, stream_replicas: {len(self.nodes)}{ack_wait} }}
"""
        with open(self.conf(i), "w") as f:
            f.write(text)

    def broker_uris(self):
        return [f"tcp://127.0.0.1:{p}" for p in self.mqtt_ports]

    def start_node(self, i):
        if self.nodes[i] is not None:
            self.restarted.add(i)
        log = open(self.log(i), "a")
        self.nodes[i] = subprocess.Popen([NATS_SERVER, "-c", self.conf(i)], stdout=log, stderr=subprocess.STDOUT)
        log.close()
        self.procs.append(self.nodes[i])

    def start(self, timeout=60.0):
        deadline = time.monotonic() + timeout
        # One after the other, each once it takes routes: nodes that dial each other at the same
        # instant make duplicate routes, and NATS 2.9 was once seen to leave a node without its
        # JetStream meta leader after resolving them.
        for i in range(len(self.nodes)):
            self.start_node(i)
            while not _accepting(self.route_ports[i]) and time.monotonic() < deadline:
                if self.nodes[i].poll() is not None:
                    raise RuntimeError(f"nats-server n{i + 1} exited: {self.tail(i)}")
                time.sleep(0.02)
        while time.monotonic() < deadline:
            if all(_accepting(p) for p in self.mqtt_ports) and self.jetstream_ready():
                return
            for i, p in enumerate(self.nodes):
                if p.poll() is not None:
                    raise RuntimeError(f"nats-server n{i + 1} exited: {self.tail(i)}")
            time.sleep(0.2)
        tails = " | ".join(self.tail(i) for i in range(len(self.nodes)))
        raise RuntimeError("the NATS cluster did not come up: " + tails)

    def jetstream_ready(self):
        """Every node's log says JetStream has a meta leader (MQTT needs its streams)."""
        for i in range(len(self.nodes)):
            try:
                with open(self.log(i)) as f:
                    text = f.read()
            except OSError:
                return False
            if ("JetStream cluster new metadata leader" not in text
                    and "Self is new JetStream cluster metadata leader" not in text):
                return False
        return True

    def rejoined(self, i):
        """Node i accepts MQTT and has its routes again (after start_node)."""
        if not _accepting(self.mqtt_ports[i]):
            return False
        with open(self.log(i)) as f:
            text = f.read()
        # Its last start's part of the log: the routes to the others, and a JetStream meta leader known.
        text = text[text.rfind("Starting nats-server"):]
        return text.count("Route connection created") >= len(self.nodes) - 1 and "metadata leader" in text

    def stream_leader(self, stream):
        """The node (0-based) that last logged itself the new leader of `stream` (e.g. "$MQTT_msgs")."""
        latest = (None, "")
        for i in range(len(self.nodes)):
            with open(self.log(i)) as f:
                for line in f:
                    if f"new stream leader for '$G > {stream}'" in line:
                        stamp = " ".join(line.split()[1:3])
                        if stamp > latest[1]:
                            latest = (i, stamp)
        if latest[0] is None:
            raise RuntimeError(f"no node has said it leads {stream}")
        return latest[0]

    def kill(self, i):
        """SIGKILL node i (0-based): no goodbye to its clients or its routes."""
        p = self.nodes[i]
        if p and p.poll() is None:
            p.send_signal(signal.SIGKILL)
            p.wait()

    def node_of_port(self, mqtt_port):
        return self.mqtt_ports.index(mqtt_port)

    def tail(self, i, n=15):
        try:
            with open(self.log(i)) as f:
                return "".join(f.readlines()[-n:])
        except OSError:
            return ""
