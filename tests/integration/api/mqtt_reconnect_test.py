"""MQTT reconnect after a broker outage (issue 12, point 7): the retained state is back within 5 s of
the broker's return, whatever the length of the outage.

A real mosquitto (no persistence: its retained messages die with it) and the real asi-gateway
(--simulate 2) with the MQTT section's reconnect settings left at their defaults. For each outage
length (--outages, default 3 s and 20 s) the broker is killed with SIGKILL, stays away that long and
is started again on the same port; from the moment it accepts connections, the test waits for the
gateway's birth ("online") and every controller's state (a watcher notes when they arrive; a fresh
client then checks that they are retained). The deadline is 5 s (--deadline-s). With the old backoff (doubling from 0.5 s up to 30 s) the attempt after a 20 s outage
came only at 31.5 s, 11.5 s after the broker's return.

Run by ctest (mqtt_reconnect); by hand:
  /usr/bin/python3 tests/integration/api/mqtt_reconnect_test.py --gateway build/gateway/asi-gateway \
      --asyncapi openapi/asyncapi.yaml
"""

import argparse
import os
import socket
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gateway_fixture import Failure, Fixture, check  # noqa: E402
from mqtt_api_test import Broker, Client, Contract, Gateway, payload_json, status_is  # noqa: E402


def accepting(port):
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=0.2):
            return True
    except OSError:
        return False


class StampedClient(Client):
    """A Client that notes when each message arrived (time.monotonic())."""

    def __init__(self, *a, **kw):
        self.arrived = []
        super().__init__(*a, **kw)

    def _on_message(self, client, userdata, msg):
        self.arrived.append(time.monotonic())
        super()._on_message(client, userdata, msg)

    def first(self, pred):
        """Arrival time and payload of the first recorded message for which pred(...) holds, or None."""
        with self.cv:
            for t, m in zip(self.arrived, self.messages):
                if pred(*m):
                    return t, m[1]
        return None


def state_back(gw, broker, cids, deadline, give_up=40.0):
    """Seconds from now until the gateway's birth and every controller's state reach a watcher on the
    restarted broker (the broker keeps a retained message before it forwards it), and the birth
    payload; then a fresh client checks that they are retained. Past `deadline` it keeps looking (until
    `give_up`) only to say in the Failure when they did come back."""
    t0 = time.monotonic()
    watcher = StampedClient(broker.port, f"watcher-{time.monotonic_ns()}")
    try:
        watcher.subscribe(gw.topic("status"), gw.topic("controllers", "+", "state"))
        wanted = [status_is(gw, "online")] + [
            (lambda t, p, r, pr, cid=cid: t == gw.topic("controllers", cid, "state") and bool(p)) for cid in cids]
        while True:
            found = [watcher.first(pred) for pred in wanted]
            if all(found):
                break
            if time.monotonic() - t0 > give_up:
                raise Failure(f"the gateway's birth and states were not back {give_up:.0f} s after the broker "
                              f"returned")
            time.sleep(0.02)
    finally:
        watcher.close()
    took = max(t for t, _ in found) - t0
    check(took <= deadline, f"the retained state was back only {took:.1f} s after the broker returned "
                            f"(deadline {deadline:.0f} s)")
    fresh = Client(broker.port, f"fresh-{time.monotonic_ns()}")
    try:
        fresh.subscribe(gw.topic("status"), gw.topic("controllers", "+", "state"))
        for pred in wanted:
            _, _, retained, _ = fresh.wait_for("a retained birth or state", pred, timeout=5)
            check(retained, "the birth and the states are retained")
    finally:
        fresh.close()
    return took, found[0][1]


def test_outage(gw, broker, contract, outage_s, deadline_s):
    c = Client(broker.port, f"before-outage-{outage_s}")
    try:
        c.subscribe(gw.topic("status"))
        c.wait_for("online before the outage", status_is(gw, "online"))
    finally:
        c.close()
    broker.proc.kill()  # SIGKILL: no clean disconnect, no persistence file
    broker.proc.wait(timeout=10)
    time.sleep(outage_s)
    check(not accepting(broker.port), "the broker is really gone")
    broker.start()  # same port, same config; returns once it accepts connections
    took, birth = state_back(gw, broker, ("sim1", "sim2"), deadline_s)
    contract.validate(gw.topic("status"), birth)
    check(payload_json(birth)["state"] == "online", f"birth: {birth}")
    print(f"       outage {outage_s:.0f} s: retained birth and states back {took:.2f} s after the broker returned",
          flush=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    ap.add_argument("--asyncapi", default="")
    ap.add_argument("--outages", default="3,20", help="outage lengths in seconds, comma separated")
    ap.add_argument("--deadline-s", type=float, default=5.0)
    args = ap.parse_args()
    fx = Fixture("asi-mqtt-reconnect-")
    contract = Contract(args.asyncapi)
    gw = None
    try:
        broker = Broker(fx, "broker")
        broker.start()
        gw = Gateway(fx, args.gateway, "gw-r", [f"mqtt://127.0.0.1:{broker.port}"])
        del gw.config["mqtt"]["reconnect"]  # the defaults are what is under test
        gw.start()
        for outage in (float(x) for x in args.outages.split(",") if x):
            fx.run(f"retained state back within {args.deadline_s:.0f} s after a {outage:.0f} s outage",
                   test_outage, gw, broker, contract, outage, args.deadline_s)
    except Exception as e:  # noqa: BLE001
        fx.failures.append(("setup", e))
        print(f"[FAIL] setup: {e}")
    finally:
        if fx.failures and gw and gw.proc:
            print(f"---- {gw.name} log (tail) ----\n{gw.tail()}")
        code = fx.report()
        fx.cleanup()
    return code


if __name__ == "__main__":
    sys.exit(main())
