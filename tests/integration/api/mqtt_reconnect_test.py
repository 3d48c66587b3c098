"""MQTT reconnect after a broker outage (issue 12, point 7): the retained state is back within 5 s of
the broker's return, whatever the length of the outage.

A real mosquitto (no persistence: its retained messages die with it) and the real asi-gateway
(--simulate 2) with the MQTT section's reconnect settings left at their defaults. For each outage
length (--outages, default 3 s and 20 s) the broker is killed with SIGKILL, stays away that long and
is started again on the same port; from the moment it accepts connections, fresh clients look for the
gateway's retained birth ("online") and every controller's retained state. The deadline is 5 s
(--deadline-s). With the old backoff (doubling from 0.5 s up to 30 s) the attempt after a 20 s outage
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


def retained_state_back(gw, broker, cids, deadline, give_up=40.0):
    """Seconds from now until a fresh client finds the retained birth and every controller's retained
    state, and the birth payload. Past `deadline` it keeps looking (until `give_up`) only to say in the
    Failure when the state did come back."""
    t0 = time.monotonic()
    n = 0
    while True:
        left = give_up - (time.monotonic() - t0)
        if left <= 0:
            raise Failure(f"the retained state was not back {give_up:.0f} s after the broker returned")
        n += 1
        try:
            c = Client(broker.port, f"after-outage-{n}-{time.monotonic_ns()}")
        except (Failure, OSError):
            continue
        try:
            c.subscribe(gw.topic("status"), gw.topic("controllers", "+", "state"))
            try:
                _, birth, retained, _ = c.wait_for("the retained birth", status_is(gw, "online"),
                                                   timeout=min(0.5, max(left, 0.05)))
                check(retained, "the birth is retained")
                for cid in cids:
                    c.wait_for(f"the retained {cid} state",
                               lambda t, p, r, pr, cid=cid: t == gw.topic("controllers", cid, "state") and r and p,
                               timeout=0.5)
            except Failure:
                continue
            took = time.monotonic() - t0
            check(took <= deadline, f"the retained state was back only {took:.1f} s after the broker returned "
                                    f"(deadline {deadline:.0f} s)")
            return took, birth
        finally:
            c.close()


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
    took, birth = retained_state_back(gw, broker, ("sim1", "sim2"), deadline_s)
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
