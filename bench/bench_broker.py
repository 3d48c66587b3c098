"""A mosquitto broker for a benchmark: anonymous, no persistence, on a free loopback port, forwarding
each message at once (set_tcp_nodelay, as the README advises for report latency)."""

import os
import socket
import subprocess
import time

from bench_gateway import free_port

MOSQUITTO = "/usr/sbin/mosquitto"


class Mosquitto:
    def __init__(self, workdir):
        self.port = free_port()
        conf = os.path.join(workdir, "mosquitto.conf")
        with open(conf, "w") as f:
            f.write("\n".join(["allow_anonymous true", "persistence false", "sys_interval 1", "set_tcp_nodelay true",
                               *(["user root"] if os.geteuid() == 0 else []),
                               f"listener {self.port} 127.0.0.1"]) + "\n")
        self.proc = subprocess.Popen([MOSQUITTO, "-c", conf], stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 10
        while True:
            try:
                socket.create_connection(("127.0.0.1", self.port), 1).close()
                return
            except OSError:
                if self.proc.poll() is not None or time.monotonic() > deadline:
                    raise RuntimeError("mosquitto did not start (bench/setup installs it)")
                time.sleep(0.1)

    def dropped(self):
        """Messages the broker dropped (its $SYS counter: a subscriber's queue was full), or -1."""
        out = subprocess.run(["mosquitto_sub", "-p", str(self.port), "-t", "$SYS/broker/publish/messages/dropped",
                              "-C", "1", "-W", "3"], capture_output=True, text=True)
        return int(out.stdout.strip()) if out.stdout.strip().isdigit() else -1

    def stop(self):
        self.proc.terminate()
        self.proc.wait(10)
