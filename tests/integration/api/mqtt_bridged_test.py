"""Site brokers bridged to a central one (issue 37): two site mosquittos (Debian's 2.0.11), each
bridged to a central mosquitto (QoS 1, cleansession false), a gateway on each site given its site
broker first and the central one second, and fleet clients on the central broker only. Site 1's
bridge speaks MQTT 5, site 2's MQTT 3.1.1; each goes through a link the test can cut
(tests/support/link_cutter.py).

- Through the bridges: the central broker has every gateway's retained birth and states, and a
  command published there reaches its gateway and is answered there: over the MQTT 5 bridge with
  the response topic and correlation data, over the 3.1.1 bridge (which carries no properties) to
  the command's reply_to.
- The MQTT 5 bridge cut: mosquitto 2.0.11 keeps no session for it on the central broker (it sends no
  session expiry interval: the central broker answers "session present 0" after the cut), so a
  command published for site 1 meanwhile is dropped there. It is never run, late or otherwise.
- The 3.1.1 bridge cut: its session is kept, so commands published for site 2 meanwhile wait on the
  central broker and are delivered when the link is back: the one older than
  mqtt.commands.max_age_s is answered stale-command and not run, the one still in time runs.
- kill -9 of site 1's broker: its gateway connects to the central broker directly (the next broker
  at once) and its birth is there again; commands reach it. The time from the kill is printed.

Run by ctest (mqtt_bridged); by hand:
  /usr/bin/python3 tests/integration/api/mqtt_bridged_test.py --gateway build/gateway/asi-gateway \\
      --asyncapi openapi/asyncapi.yaml
"""

import argparse
import json
import os
import signal
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "support"))
from gateway_fixture import (TOKENS, Failure, Fixture, check, run_main, signing_keys_config,  # noqa: E402
                             axis_position, wait_until)
from link_cutter import LinkCutter  # noqa: E402
from mqtt_api_test import Broker, Client, Contract, Gateway, command, metric, payload_json  # noqa: E402

MAX_AGE_S = 5
REPLY = "clients/fleet/replies"


def x_of(gw):
    return axis_position(gw.port, "sim1")


def bridge_lines(site, gateway, central_port, version):
    """A bridge from a site broker to the central one: the gateway's tree both ways (its publications
    out, commands in), answers out; QoS 1, cleansession false (a session kept on the central broker
    where the protocol lets mosquitto keep one)."""
    return [f"connection {site}-to-central", f"address 127.0.0.1:{central_port}",
            f"bridge_protocol_version {version}", "cleansession false", f"remote_clientid bridge-{site}",
            f"topic asi/{gateway}/# both 1", "topic clients/# out 1", "restart_timeout 1 2",
            "keepalive_interval 10"]


def birth_of(gw, pred=lambda j: True):
    def match(t, p, retained, props):
        if t != gw.topic("status") or not p:
            return False
        j = payload_json(p)
        return j.get("state") == "online" and pred(j)
    return match


def test_through_bridges(sites, central, contract):
    for site in sites:
        gw = site["gw"]
        c = Client(central.port, f"late-{gw.name}")
        try:
            c.subscribe(gw.topic("status"), gw.topic("controllers", "+", "state"))
            _, p, retained, _ = c.wait_for(f"{gw.name}'s birth on the central broker", birth_of(gw), timeout=20)
            check(retained, "retained on the central broker")
            contract.validate(gw.topic("status"), p)
            check(payload_json(p)["broker"] == site["uri"], f"it is on its site broker: {payload_json(p)}")
            c.wait_for(f"{gw.name}'s sim1 state", lambda t, p, r, pr: t == gw.topic("controllers", "sim1", "state")
                       and r)
        finally:
            c.close()
    gw = sites[0]["gw"]
    c = Client(central.port, "fleet-cmd")
    try:
        c.subscribe(REPLY)
        ans = command(c, gw.topic("controllers", "sim1", "cmd"),
                      {"id": "through-1", "operation": "move", "args": {"axes": {"X": 300}, "wait": True},
                       "token": TOKENS["operator"]}, REPLY)
        contract.validate(REPLY, json.dumps(ans))
        check(ans["type"] == "result" and ans["id"] == "through-1", f"answered through both bridges: {ans}")
        # The 3.1.1 bridge carries no MQTT 5 properties: the answer goes to reply_to.
        ans = command(c, sites[1]["gw"].topic("controllers", "sim1", "cmd"),
                      {"id": "through-2", "operation": "halt", "reply_to": REPLY, "token": TOKENS["operator"]},
                      REPLY, v5=False)
        check(ans["type"] == "result" and ans["id"] == "through-2", f"answered through the 3.1.1 bridge: {ans}")
    finally:
        c.close()


def cut_and_publish(site, central, c, commands):
    """Cuts the site's bridge, checks the central broker still serves the retained birth, publishes
    each (command, seconds to wait after it) for the site's gateway at the central broker, mends the
    link; returns the time it was mended."""
    gw = site["gw"]
    site["link"].cut()
    time.sleep(1)
    late = Client(central.port, f"late-during-cut-{gw.name}")
    try:
        late.subscribe(gw.topic("status"))
        late.wait_for("the retained birth while the bridge is down", birth_of(gw), timeout=5)
    finally:
        late.close()
    for body, wait_s in commands:
        c.publish(gw.topic("controllers", "sim1", "cmd"), body)
        time.sleep(wait_s)
    site["link"].mend()
    return time.monotonic()


def answer_to(c, cid, start, timeout=30):
    _, p, _, _ = c.wait_for(f"the answer to {cid}", lambda t, p, r, pr: t == REPLY and payload_json(p).get("id") == cid,
                            timeout=timeout, start=start)
    return payload_json(p)


def test_v5_bridge_cut(sites, central):
    site = sites[0]
    gw = site["gw"]
    c = Client(central.port, "fleet-cut-v5")
    try:
        c.subscribe(REPLY)
        start_x = x_of(gw)
        mark = c.mark()
        cut5 = {"id": "cut5", "operation": "move", "reply_to": REPLY, "args": {"axes": {"X": start_x + 1500}},
                "token": TOKENS["operator"]}
        cut_and_publish(site, central, c, [(cut5, 2)])
        # A barrier through the mended bridge (asked again until the bridge is back): answered, and
        # nothing came for the dropped command before it.
        tries = [0]

        def barrier():
            tries[0] += 1
            cid = f"barrier5-{tries[0]}"
            c.publish(gw.topic("controllers", "sim1", "cmd"), {"id": cid, "operation": "halt", "reply_to": REPLY,
                                                                "token": TOKENS["viewer"]})
            try:
                return answer_to(c, cid, mark, timeout=2)
            except Failure:
                return None
        wait_until("a command through the mended MQTT 5 bridge", barrier, timeout=30)
        time.sleep(1)
        dropped = [m for m in c.all(lambda t: t == REPLY, mark) if payload_json(m[1]).get("id") == "cut5"]
        check(not dropped, f"the command published during the cut is not delivered: {dropped}")
        check(abs(x_of(gw) - start_x) < 1, f"and never run: X={x_of(gw)}, was {start_x}")
    finally:
        c.close()


def test_v311_bridge_cut(sites, central, contract):
    site = sites[1]
    gw = site["gw"]
    c = Client(central.port, "fleet-cut-v311")
    try:
        c.subscribe(REPLY)
        start_x = x_of(gw)
        mark = c.mark()
        mended = cut_and_publish(site, central, c, [
            ({"id": "cut-old", "operation": "move", "reply_to": REPLY, "args": {"axes": {"X": start_x + 1500}},
              "token": TOKENS["operator"]}, MAX_AGE_S + 2),
            ({"id": "cut-new", "operation": "move", "reply_to": REPLY,
              "args": {"axes": {"X": start_x + 700}, "wait": True}, "token": TOKENS["operator"]}, 0)])
        old = answer_to(c, "cut-old", mark)
        print(f"    the queued commands arrived {time.monotonic() - mended:.2f} s after the link was mended")
        contract.validate(REPLY, json.dumps(old))
        check(old["type"] == "error" and old["problem"]["type"].endswith("/stale-command"),
              f"the command that waited past its deadline is refused: {old}")
        new = answer_to(c, "cut-new", mark)
        check(new["type"] == "result", f"the one still in time runs: {new}")
        check(abs(x_of(gw) - (start_x + 700)) < 1, f"X at {start_x + 700}, never at {start_x + 1500}: {x_of(gw)}")
    finally:
        c.close()


def test_site_broker_death(sites, central, contract):
    site = sites[0]
    gw = site["gw"]
    watcher = Client(central.port, "fleet-watch-death")
    try:
        watcher.subscribe(gw.topic("status"))
        mark = watcher.mark()
        killed = time.monotonic()
        site["broker"].proc.send_signal(signal.SIGKILL)
        site["broker"].proc.wait(timeout=10)
        _, p, _, _ = watcher.wait_for("the birth through the central broker",
                                      birth_of(gw, lambda j: j.get("broker") == central.uri), timeout=20, start=mark)
        print(f"    birth on the central broker {time.monotonic() - killed:.2f} s after the site broker's kill -9")
        contract.validate(gw.topic("status"), p)
        wait_until("health names the central broker", lambda: metric(gw, "gw_mqtt_connected") == 1)
        watcher.subscribe(REPLY)
        ans = command(watcher, gw.topic("controllers", "sim1", "cmd"),
                      {"id": "after-death", "operation": "halt", "token": TOKENS["operator"]}, REPLY)
        check(ans["type"] == "result", f"a command after the site broker's death: {ans}")
        # The other site is untouched.
        other = sites[1]["gw"]
        check(metric(other, "gw_mqtt_connected") == 1, "site 2's gateway stays connected")
    finally:
        watcher.close()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    ap.add_argument("--asyncapi", default="")
    args = ap.parse_args()
    fx = Fixture("asi-mqtt-bridged-")
    contract = Contract(args.asyncapi)
    sites = []
    try:
        central = Broker(fx, "central")
        central.start()
        central.uri = f"mqtt://127.0.0.1:{central.port}"
        for n, version in ((1, "mqttv50"), (2, "mqttv311")):
            name = f"site{n}"
            gw_name = f"gw-site{n}"
            link = LinkCutter(central.port)
            broker = Broker(fx, name, extra=bridge_lines(name, gw_name, link.port, version))
            broker.start()
            uri = f"mqtt://127.0.0.1:{broker.port}"
            gw = Gateway(fx, args.gateway, gw_name, [uri, central.uri], sims=1,
                         mqtt_extra={"commands": {"enabled": True, "signing_keys": signing_keys_config(),
                                                  "max_age_s": MAX_AGE_S}})
            gw.start()
            sites.append({"gw": gw, "broker": broker, "link": link, "uri": uri})
        for s in sites:
            wait_until(f"{s['gw'].name} on its site broker", lambda s=s: metric(s["gw"], "gw_mqtt_connected") == 1)
        time.sleep(1)  # command subscriptions, and the bridges' own
        fx.run("births, states and commands through the bridges", test_through_bridges, sites, central, contract)
        fx.run("the MQTT 5 bridge cut: a command meanwhile is dropped, never run", test_v5_bridge_cut, sites,
               central)
        fx.run("the 3.1.1 bridge cut: the late command refused, the one in time run", test_v311_bridge_cut, sites,
               central, contract)
        fx.run("kill -9 of a site broker: its gateway goes to the central broker", test_site_broker_death, sites,
               central, contract)
        if fx.failures or os.environ.get('SHOW_LOGS'):
            for s in sites:
                print(f"---- {s['gw'].name} log (tail) ----\n{s['gw'].tail(30)}")
                print(f"---- {s['broker'].name} log ----\n{open(s['broker'].log).read()[-1500:]}")
            print(f"---- central log ----\n{open(central.log).read()[-2500:]}")
        return fx.report()
    finally:
        for s in sites:
            s["link"].close()
        fx.cleanup()


if __name__ == "__main__":
    run_main(main)
