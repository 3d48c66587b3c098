#!/usr/bin/python3
"""Shared controller ports (issue 32), end to end: the real asi-gateway owning external ms2000-sims
with control sockets, programs that speak to an MS-2000 themselves connected through the shared pty
(pyserial on the pseudo-terminal, as Micro-Manager or a lab script opens a serial port) and the shared
TCP port (raw bytes, and pyserial's rfc2217:// client), while REST clients and the gateway's polls use
the same controllers.

What is checked: every client gets exactly the replies to its own commands, byte for byte (hundreds of
queries of one axis while REST moves another; multi-line and error replies identical to the REST raw
command's), in order, and nothing else; the roles; leases and jobs refusing shared motion with ":N-90"
while reads and HALT work; share.lease; a shared HALT stops a move and pauses a job like any HALT;
what a shared client changes is seen by the gateway; the report stream shared byte for byte to a pty
and a TCP reader; the bad-input bounds (over-long and non-printable
lines, a flood, a client that never reads, a client gone mid-command, too many clients); unplug and
replug with the pty left open; the share in GET /api/v1/controllers/{id} and /metrics.

Run by ctest with Debian's /usr/bin/python3 (python3-serial, python3-yaml, python3-jsonschema).
"""

import argparse
import grp
import os
import socket
import stat
import sys
import threading
import time

import serial  # Debian python3-serial (pyserial)

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "api"))
from gateway_fixture import TOKENS, Failure, Fixture, auth_tokens, check, free_port, run_main, wait_until  # noqa: E402
from http_api_test import Client, Contract  # noqa: E402

ADMIN = TOKENS["admin"]
OP = TOKENS["operator"]
VIEW = TOKENS["viewer"]
REPLY_WAIT = 5.0  # a reply through the gateway on a loaded 2-core machine


def read_reply(port, timeout=REPLY_WAIT):
    """One reply (bytes, ending CR LF) from a pyserial port, or b"" when none came in `timeout`."""
    port.timeout = timeout
    return port.read_until(b"\r\n")


def ask(port, line, timeout=REPLY_WAIT):
    port.write(line.encode() + b"\r")
    return read_reply(port, timeout)


class TcpClient:
    """A raw TCP client of the shared port (ser2net-style, no Telnet)."""

    def __init__(self, port):
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=REPLY_WAIT)
        self.buffer = b""

    def ask(self, line, timeout=REPLY_WAIT):
        self.sock.sendall(line.encode() + b"\r")
        return self.reply(timeout)

    def reply(self, timeout=REPLY_WAIT):
        deadline = time.monotonic() + timeout
        while b"\r\n" not in self.buffer:
            left = deadline - time.monotonic()
            if left <= 0:
                return b""
            self.sock.settimeout(left)
            try:
                chunk = self.sock.recv(4096)
            except socket.timeout:
                return b""
            if not chunk:
                return b""
            self.buffer += chunk
        line, _, self.buffer = self.buffer.partition(b"\r\n")
        return line + b"\r\n"

    def close(self):
        self.sock.close()


def controller(c, cid):
    r = c.request("GET", f"/api/v1/controllers/{cid}", token=VIEW)
    check(r.status == 200, f"GET controller {cid}: {r.status} {r.body[:300]}")
    return r.json()


def raw(c, cid, line, force=False):
    body = {"command": line}
    if force:
        body["force"] = True
    r = c.request("POST", f"/api/v1/controllers/{cid}/command", body, token=ADMIN)
    check(r.status == 200, f"raw {line!r} on {cid}: {r.status} {r.body[:300]}")
    return r.json()["raw_reply"].encode() + b"\r\n"


def move(c, cid, axes, token=OP, headers=None, status=200):
    r = c.request("POST", f"/api/v1/controllers/{cid}/move", {"axes": axes, "wait": True}, token=token,
                  headers=headers)
    check(r.status == status, f"move {axes} on {cid}: expected {status}, got {r.status} {r.body[:300]}")
    return r


class Scene:
    """The gateway with three external simulators and their shares."""

    def __init__(self, fx, args):
        self.fx = fx
        self.sims = {name: fx.start_sim(args.sim, name, preset, time_scale=10, report=name == "s1")
                     for name, preset in (("s1", "full"), ("s2", "plain"), ("s3", "plain"))}
        self.report_pty = os.path.join(fx.tmp, "s1-report-share")
        self.report_tcp = free_port()
        self.http_port = free_port()
        self.tcp = {name: free_port() for name in ("s1", "s2", "s3")}
        self.pty = {name: os.path.join(fx.tmp, f"{name}-share") for name in ("s1", "s2", "s3")}
        shares = {
            "s1": {"pty": self.pty["s1"], "tcp": f"127.0.0.1:{self.tcp['s1']}", "max_clients": 3,
                   "report_pty": self.report_pty, "report_tcp": f"127.0.0.1:{self.report_tcp}"},
            "s2": {"pty": self.pty["s2"], "tcp": f"127.0.0.1:{self.tcp['s2']}", "role": "viewer",
                   "pty_mode": "0640", "pty_group": grp.getgrgid(os.getgid()).gr_name},
            "s3": {"pty": self.pty["s3"], "tcp": f"127.0.0.1:{self.tcp['s3']}", "lease": True, "role": "admin"},
        }
        config = {
            "http": {"port": self.http_port},
            "auth": auth_tokens(),
            "controllers": [dict({"id": name, "port": sim.link, "baud": 115200, "share": shares[name]},
                                 **({"report_port": sim.report_link} if sim.report_link else {}))
                            for name, sim in self.sims.items()],
            "simulate": {"count": 0},
        }
        fx.start_gateway(args.gateway, config)
        with open(args.openapi) as f:
            self.c = Client(self.http_port, Contract(f.read()))
        for name in self.sims:
            wait_until(f"{name} connected", lambda n=name: controller(self.c, n)["state"] == "connected")

    def open_pty(self, name):
        return serial.Serial(self.pty[name], 115200, timeout=REPLY_WAIT)


def test_pty_answers_like_the_controller(s):
    with s.open_pty("s1") as p:
        version = ask(p, "V")
        check(version.startswith(b":A") and version.endswith(b"\r\n"), f"V: {version!r}")
        check(version == raw(s.c, "s1", "V"), f"V through the pty {version!r} differs from REST's")
        build = ask(p, "BU X")
        check(b"\r" in build[:-2] and build == raw(s.c, "s1", "BU X"), f"BU X: {build!r}")
        refused = ask(p, "M Q=1")
        check(refused == b":N-2\r\n", f"the controller's own refusal: {refused!r}")
        lower = ask(p, "w x")
        check(lower.startswith(b":A ") and len(lower.split()) == 2, f"a lower-case command goes verbatim: {lower!r}")
    share = controller(s.c, "s1")["share"]
    check(share["pty"] == s.pty["s1"] and share["tcp"] == f"127.0.0.1:{s.tcp['s1']}", f"share: {share}")
    check(share["role"] == "operator" and share["commands"] >= 4, f"share counts: {share}")


def read_exact(port, n, timeout=REPLY_WAIT):
    """n bytes from a pyserial port, whatever they are (RDSBYTE's answer may hold CR and LF)."""
    port.timeout = timeout
    return port.read(n)


def test_rdsbyte_answers_raw_bytes(s):
    """RB's answer is a colon and one raw status byte per axis, then CR LF: bytes that may be a CR or a
    LF themselves (10, axis enabled and joystick on, is a line feed), framed by count, not by line."""
    raw(s.c, "s1", "H X=0 Y=0")
    with s.open_pty("s1") as p:
        p.write(b"RB X Y\r")
        idle = read_exact(p, 5)
        check(len(idle) == 5 and idle[:1] == b":" and idle[3:] == b"\r\n", f"RB X Y: {idle!r}")
        rs_x, rs_y = (int(ask(p, f"RS {axis}").split()[1]) for axis in "XY")
        check((idle[1], idle[2]) == (rs_x, rs_y), f"RB X Y {idle!r} is RS X, RS Y ({rs_x}, {rs_y}) in binary")
        check(idle[1] & 1 == 0 and idle[1] & 2, f"idle and enabled: {idle[1]:#x}")
        check(ask(p, "W X").startswith(b":A "), "the next line is framed as usual")
        check(ask(p, "M X=500000") == b":A\r\n", "a long move starts")
        p.write(b"rb x\r")
        moving = read_exact(p, 4)
        check(len(moving) == 4 and moving[1] & 1, f"RB X during a commanded move has bit 0: {moving!r}")
        check(ask(p, "\\") == b":N-21\r\n", "HALT")
        check(ask(p, "RB Q") == b":N-2\r\n", "an unknown axis is the controller's own refusal")
    tcp = TcpClient(s.tcp["s1"])
    try:
        tcp.sock.sendall(b"RB X\r")
        deadline = time.monotonic() + REPLY_WAIT
        while len(tcp.buffer) < 4 and time.monotonic() < deadline:
            tcp.buffer += tcp.sock.recv(16)
        check(len(tcp.buffer) == 4 and tcp.buffer[:1] == b":" and tcp.buffer[2:] == b"\r\n",
              f"RB X through TCP: {tcp.buffer!r}")
    finally:
        tcp.close()
    r = s.c.request("POST", "/api/v1/controllers/s1/command", {"command": "RB X"}, token=ADMIN)
    check(r.status == 422 and "RS X" in r.json()["detail"],
          f"REST refuses RB (its answer is not text) and says what to use: {r.status} {r.body[:300]}")


def test_the_pty_has_the_mode_and_group_configured(s):
    st = os.stat(s.pty["s2"])  # the slave the link points to
    check(stat.S_IMODE(st.st_mode) == 0o640, f"mode {oct(stat.S_IMODE(st.st_mode))}")
    check(st.st_gid == os.getgid(), f"group {st.st_gid}")
    check(os.path.islink(s.pty["s2"]) and os.readlink(s.pty["s2"]).startswith("/dev/pts/"), "a link to the pty")


def test_replies_go_to_their_own_client(s):
    """A pty client reads X and a TCP client reads Y hundreds of times while REST moves Y: every answer
    has exactly one value, and each client's values are of its own axis."""
    raw(s.c, "s1", "H X=1234.5")
    errors = []
    stop = threading.Event()

    def mover():
        y = 0
        while not stop.is_set():
            y = 2000 - y
            try:
                move(s.c, "s1", {"Y": y})
            except Failure as e:
                errors.append(str(e))

    t = threading.Thread(target=mover)
    t.start()
    tcp = TcpClient(s.tcp["s1"])
    try:
        with s.open_pty("s1") as p:
            for i in range(300):
                x = ask(p, "W X")
                if x.split() != [b":A", b"1234.5"] or not x.endswith(b"\r\n"):
                    errors.append(f"W X #{i} through the pty: {x!r}")
                    break
                y = tcp.ask("W Y")
                parts = y.split()
                if len(parts) != 2 or parts[0] != b":A" or not -1 <= float(parts[1]) <= 20001:
                    errors.append(f"W Y #{i} through TCP: {y!r}")
                    break
    finally:
        stop.set()
        t.join()
        tcp.close()
    check(not errors, "; ".join(errors[:3]))


def test_several_clients_and_the_limit(s):
    clients = [TcpClient(s.tcp["s1"]) for _ in range(3)]
    try:
        wait_until("3 TCP clients listed", lambda: sum(
            c["name"].startswith("tcp ") for c in controller(s.c, "s1")["share"]["clients"]) == 3)
        extra = socket.create_connection(("127.0.0.1", s.tcp["s1"]), timeout=REPLY_WAIT)
        extra.settimeout(REPLY_WAIT)
        check(extra.recv(16) == b"", "a fourth client (max_clients 3) is closed at once")
        extra.close()
        for i, cl in enumerate(clients):
            r = cl.ask("W X")
            check(r.startswith(b":A "), f"client {i}: {r!r}")
        check(controller(s.c, "s1")["share"]["connections_refused"] >= 1, "the refused connection is counted")
    finally:
        for cl in clients:
            cl.close()
    r = s.c.request("GET", "/api/v1/metrics", token=VIEW)
    check('gw_share_connections_refused_total{controller="s1"}' in r.body, "share metrics")


def test_roles(s):
    viewer = TcpClient(s.tcp["s2"])
    try:
        check(viewer.ask("W X").startswith(b":A "), "a viewer reads")
        check(viewer.ask("M X=10") == b":N-91\r\n", "a viewer cannot move")
        check(viewer.ask("\\") in (b":A\r\n", b":N-21\r\n"), "a viewer may HALT")
    finally:
        viewer.close()
    operator = TcpClient(s.tcp["s1"])
    try:
        check(operator.ask("SS Z") == b":N-91\r\n", "an operator cannot write the flash")
        check(operator.ask("BAUD X=9600") == b":N-91\r\n", "an operator cannot change the baud rate")
        check(operator.ask("XYZZY") == b":N-91\r\n", "an unknown verb needs admin")
        check(operator.ask("S X=2") == b":A\r\n" or operator.ask("S X?").startswith(b":A"), "an operator sets")
    finally:
        operator.close()
    admin = TcpClient(s.tcp["s3"])
    try:
        r = admin.ask("XYZZY")
        check(r == b":N-1\r\n", f"an admin's unknown verb reaches the controller, which refuses it: {r!r}")
    finally:
        admin.close()


def test_a_lease_refuses_shared_motion(s):
    r = s.c.request("POST", "/api/v1/controllers/s1/lease", {"ttl_s": 60}, token=OP)
    check(r.status in (200, 201), f"lease: {r.status} {r.body[:200]}")
    lease = r.json()["lease_id"]
    try:
        with s.open_pty("s1") as p:
            check(ask(p, "M X=100") == b":N-90\r\n", "a move while someone else holds the lease")
            check(ask(p, "W X").startswith(b":A "), "a read while leased")
            check(ask(p, "\\") in (b":A\r\n", b":N-21\r\n"), "HALT while leased")
    finally:
        r = s.c.request("DELETE", "/api/v1/controllers/s1/lease", token=OP, headers={"Lease-Id": lease})
        check(r.status in (200, 204), f"release: {r.status} {r.body[:200]}")
        s.c.request("POST", "/api/v1/jobs/halt/release", token=OP, validate=False)
    with s.open_pty("s1") as p:
        check(ask(p, "M X=100") == b":A\r\n", "a move once the lease is released")


def test_share_lease(s):
    holder = TcpClient(s.tcp["s3"])
    try:
        wait_until("the port holds the lease", lambda: controller(s.c, "s3")["share"]["holds_lease"])
        move(s.c, "s3", {"X": 50}, status=409)
        check(holder.ask("M X=50") == b":A\r\n", "the port's own client moves under its lease")
    finally:
        holder.close()
    wait_until("the lease released", lambda: not controller(s.c, "s3")["share"]["holds_lease"])
    move(s.c, "s3", {"X": 0})


def test_a_job_refuses_shared_motion_and_a_shared_halt_pauses_it(s):
    r = s.c.request("POST", "/api/v1/jobs", {"controller": "s1", "type": "array", "spec": {
        "grid": {"columns": 3, "rows": 1, "column_step_mm": 0.5, "row_step_mm": -0.5},
        "a1": {"X": 0, "Y": 0}, "advance": "next", "mode": "host"}}, token=OP)
    check(r.status == 201, f"submit: {r.status} {r.body[:300]}")
    job_id = r.json()["id"]

    def state():
        return s.c.request("GET", f"/api/v1/jobs/{job_id}", token=VIEW).json()

    wait_until("the job runs", lambda: state()["state"] == "running")
    with s.open_pty("s1") as p:
        check(ask(p, "M X=100") == b":N-90\r\n", "a move while a job runs")
        check(ask(p, "W X").startswith(b":A "), "a read while a job runs")
        check(ask(p, "\\") in (b":A\r\n", b":N-21\r\n"), "HALT while a job runs")
    j = wait_until("the job paused by the HALT", lambda: (lambda j: j if j["state"] == "paused" else None)(state()))
    halted = controller(s.c, "s1")["halted"]
    check(halted and halted["by"].startswith("shared-port/s1"), f"halted by: {halted}")
    check("halt" in (j.get("progress", {}).get("waiting_for") or "") or j["state"] == "paused", f"job: {j}")
    r = s.c.request("POST", f"/api/v1/jobs/{job_id}/cancel", token=OP)
    check(r.status == 200, f"cancel: {r.status} {r.body[:200]}")


def test_a_shared_halt_stops_a_long_move(s):
    sim = s.sims["s1"]
    raw(s.c, "s1", "H X=0")
    with s.open_pty("s1") as p:
        check(ask(p, "M X=500000") == b":A\r\n", "a long move starts")
        time.sleep(0.3)
        started = time.monotonic()
        r = ask(p, "\\")
        took = time.monotonic() - started
        check(r == b":N-21\r\n", f"HALT during a commanded move answers :N-21: {r!r}")
        print(f"       HALT round trip through the shared pty during a move: {took * 1000:.1f} ms")
        first = ask(p, "W X")
        time.sleep(0.5)
        second = ask(p, "W X")
        check(first == second and first.startswith(b":A "), f"the stage stopped: {first!r} then {second!r}")
    del sim


def test_what_a_shared_client_changes_the_gateway_sees(s):
    with s.open_pty("s1") as p:
        check(ask(p, "TTL X=2") == b":A\r\n", "TTL X=2")
        check(ask(p, "M X=1000 Y=0") == b":A\r\n", "a move")
    wait_until("the TTL mode read back", lambda: controller(s.c, "s1")["ttl"]["in0_mode"] == 2)

    def at_target():
        axes = {a["axis"]: a for a in controller(s.c, "s1")["axes"]}
        return abs((axes["X"]["position_um"] or 0) - 100) < 1 and not axes["X"]["busy"]

    wait_until("the shared client's move seen by polling", at_target)
    with s.open_pty("s1") as p:
        ask(p, "TTL X=0")


def test_bad_input_is_bounded(s):
    with s.open_pty("s1") as p:
        check(ask(p, "W " + "X" * 400) == b":N-92\r\n", "an over-long line")
        check(ask(p, "W \x01X") == b":N-92\r\n", "a control byte")
        p.write(b"W \xff\xfeX\r")
        check(read_reply(p) == b":N-92\r\n", "bytes outside ASCII")
        check(ask(p, "W X").startswith(b":A "), "the next line works")
        # A flood: 500 queries written at once are all answered, in order, one reply each.
        p.write(b"W X\r" * 500)
        replies = [read_reply(p) for _ in range(500)]
        check(all(r.startswith(b":A ") for r in replies), f"flood replies: {[r for r in replies if not r.startswith(b':A ')][:3]}")
        check(read_reply(p, 0.5) == b"", "exactly one reply per line")
    # Gone mid-command: the next client is served.
    cl = TcpClient(s.tcp["s1"])
    cl.sock.sendall(b"BU X\r")
    cl.close()
    cl = TcpClient(s.tcp["s1"])
    try:
        check(cl.ask("W X").startswith(b":A "), "served after a client left mid-command")
    finally:
        cl.close()
    # A client that never reads: its replies are dropped beyond the bound; nobody else waits for it.
    deaf = os.open(s.pty["s1"], os.O_RDWR | os.O_NOCTTY)
    try:
        os.write(deaf, b"BU X\r" * 100 + b"INFO X\r" * 100)  # replies far beyond what a client may leave unread
        for _ in range(3):
            r = s.c.request("GET", "/api/v1/controllers/s1", token=VIEW)
            check(r.status == 200, "REST answers while a pty client does not read")
        tcp = TcpClient(s.tcp["s1"])
        try:
            check(tcp.ask("W X").startswith(b":A "), "another client is served while the pty client does not read")
        finally:
            tcp.close()
        wait_until("the deaf client's dropped replies counted", lambda: any(
            c["name"] == "pty" and c["dropped_bytes"] > 0 for c in controller(s.c, "s1")["share"]["clients"]))
    finally:
        os.close(deaf)


def test_unplug_and_replug_with_the_pty_open(s):
    sim = s.sims["s2"]
    with s.open_pty("s2") as p:
        check(ask(p, "W X").startswith(b":A "), "before the unplug")
        sim.control("unplug")
        wait_until("s2 unreachable", lambda: controller(s.c, "s2")["state"] != "connected")
        check(ask(p, "W X", timeout=1.5) == b"", "no reply while unplugged (a cable's silence)")
        sim.control("replug")
        wait_until("s2 connected again", lambda: controller(s.c, "s2")["state"] == "connected")
        check(ask(p, "W X").startswith(b":A "), "the same open pty works after the replug")


def read_exactly(read, n, timeout=REPLY_WAIT * 4):
    data, deadline = b"", time.monotonic() + timeout
    while len(data) < n and time.monotonic() < deadline:
        data += read()
    return data


def report_frames(data):
    """Binary TTL_REPORT frames (AID, int32 little-endian per axis, CR) -> [{axis id: count}]."""
    frames, i = [], 0
    while i < len(data):
        frame = {}
        while data[i] != 0x0D:
            frame[data[i]] = int.from_bytes(data[i + 1:i + 5], "little", signed=True)
            i += 5
        frames.append(frame)
        i += 1
    return frames


def test_the_report_stream_is_shared_unchanged(s):
    """20 IN0 edges: a program on the shared report pty and one on the report TCP port read the same
    bytes, 20 well-formed frames with the controller's own encoder counts."""
    sim = s.sims["s1"]
    raw(s.c, "s1", "M X=10000 Y=0")
    wait_until("s1 at X 1000 um", lambda: not controller(s.c, "s1")["busy"])
    fd = os.open(s.report_pty, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    tcp = socket.create_connection(("127.0.0.1", s.report_tcp), timeout=REPLY_WAIT)
    try:
        wait_until("two report readers", lambda: len(controller(s.c, "s1")["share"]["report_readers"]) == 2)
        raw(s.c, "s1", "TTL X=1")
        check(sim.control("pulse 20 100") == "ok", "pulse train")

        def from_pty():
            try:
                return os.read(fd, 4096)
            except BlockingIOError:
                time.sleep(0.01)
                return b""

        tcp.settimeout(0.2)

        def from_tcp():
            try:
                return tcp.recv(4096)
            except socket.timeout:
                return b""

        pty_bytes = read_exactly(from_pty, 20 * 16)
        tcp_bytes = read_exactly(from_tcp, len(pty_bytes))
        frames = report_frames(pty_bytes)
        check(len(frames) == 20, f"{len(frames)} frames from {len(pty_bytes)} bytes")
        check(pty_bytes == tcp_bytes, "the pty and the TCP reader got the same bytes")
        counts_per_mm = next(a["counts_per_mm"] for a in controller(s.c, "s1")["axes"] if a["axis"] == "X")
        expected_x = round(1.0 * counts_per_mm)
        check(all(abs(f[0x18] - expected_x) <= 1 for f in frames), f"X counts {frames[0]} vs {expected_x}")
    finally:
        raw(s.c, "s1", "TTL X=0")
        os.close(fd)
        tcp.close()


def test_rfc2217(s):
    port = serial.serial_for_url(f"rfc2217://127.0.0.1:{s.tcp['s1']}", baudrate=115200, timeout=REPLY_WAIT)
    try:
        port.baudrate = 9600  # acknowledged, the real link is unchanged
        port.write(b"W X\r")
        r = port.read_until(b"\r\n")
        check(r.startswith(b":A "), f"W X through rfc2217://: {r!r}")
    finally:
        port.close()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    ap.add_argument("--sim", required=True)
    ap.add_argument("--openapi", required=True)
    args = ap.parse_args()
    fx = Fixture("share-test-")
    try:
        s = Scene(fx, args)
        for name, fn in [
            ("the pty answers like the controller", test_pty_answers_like_the_controller),
            ("RDSBYTE answers raw bytes", test_rdsbyte_answers_raw_bytes),
            ("the pty has the mode and group configured", test_the_pty_has_the_mode_and_group_configured),
            ("replies go to their own client", test_replies_go_to_their_own_client),
            ("several clients and the limit", test_several_clients_and_the_limit),
            ("roles", test_roles),
            ("a lease refuses shared motion", test_a_lease_refuses_shared_motion),
            ("share.lease", test_share_lease),
            ("a job refuses shared motion; a shared HALT pauses it", test_a_job_refuses_shared_motion_and_a_shared_halt_pauses_it),
            ("a shared HALT stops a long move", test_a_shared_halt_stops_a_long_move),
            ("what a shared client changes the gateway sees", test_what_a_shared_client_changes_the_gateway_sees),
            ("bad input is bounded", test_bad_input_is_bounded),
            ("unplug and replug with the pty open", test_unplug_and_replug_with_the_pty_open),
            ("the report stream is shared unchanged", test_the_report_stream_is_shared_unchanged),
            ("rfc2217://", test_rfc2217),
        ]:
            fx.run(name, fn, s)
        fx.finish_log(80)
        return fx.report()
    finally:
        fx.cleanup()


if __name__ == "__main__":
    run_main(main)
