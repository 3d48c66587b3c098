#!/usr/bin/python3
"""RFC 2217 clients that make a local serial device, as Windows virtual COM port drivers do, through a
shared TCP port (issue 32): the real asi-gateway owning one external ms2000-sim shared over TCP, and two
Debian programs that give a local tty backed by an RFC 2217 port:

- cyclades-ser-cli (package cyclades-serial-client) makes a pty and turns what a program sets on it
  into RFC 2217 requests: its LD_PRELOAD library libcyclades-ser-cli.so catches tcsetattr() and
  tcsendbreak() on a device listed in /etc/cyclades-devices and hands them to cyclades-ser-cli over
  "<device>.control", which asks the server and answers the program once the server has answered (the
  library gives up after about 2 s, so an unanswered request fails tcsetattr). The test lists its
  device in a private copy of /etc/cyclades-devices, bind-mounted in a mount namespace of its own
  (unshare: root, or unprivileged user namespaces). The library applies c_cflag only, the rest of
  the termios stays as it was (a new pty echoes: a program that sets raw mode through it sends every
  reply back to the gateway as a command, endlessly), so the test sets raw mode with libc's own
  tcsetattr.
  Command: cyclades-ser-cli -x -r 1 -i 1 -p <port - 1> <device> 127.0.0.1 1
- gensiot (package gensio-bin) with a pty as its local end: a local tcsetattr reaches nobody (gensio's
  pty is no serial port); settings are asked with gensiot's escape commands typed on the pty (^] s
  9600, ^] e, ^] 7, ^] b, ^] d prints what the server reports).
  Command: gensiot -e ^] -i 'pty(raw,link=<device>)' 'telnet(rfc2217),tcp,127.0.0.1,<port>'

Each client goes through a relay that keeps both byte streams. Checked: an MS-2000 session through the
client's device (W X, M X=1000, BU X with its inner CRs, HALT) gets the controller's replies byte for
byte (as the REST raw command gets them), and the data streams carry exactly those commands and
replies; 115200 8N1, then 9600, 7E1, RTS/CTS with 2 stop bits and back, and a BREAK, are asked and
acknowledged while the real link keeps 115200 8N1 and the replies keep coming; every Telnet request of
the client has exactly the answer RFC 1143/2217 and the gateway's policy give (settings kept for the
client and echoed, queries answered with what it set, the real link before that, one NOTIFY-MODEMSTATE
once COM-PORT-OPTION is agreed) and nothing else; REST is served meanwhile and lists the client; the HALT is the gateway's HALT by that client.
Then the negotiation bytes these clients sent (recorded from cyclades-serial-client 0.94 and gensio-bin
2.6.2 on Debian bookworm) are replayed raw over a socket and the answers checked byte for byte.

Needs the Debian packages cyclades-serial-client and gensio-bin (scripts/install-deps --tests); a
missing one fails its tests. Run by ctest with Debian's /usr/bin/python3 (python3-yaml,
python3-jsonschema for the OpenAPI checks).
"""

import argparse
import ctypes
import json
import os
import select
import shutil
import signal
import socket
import subprocess
import sys
import termios
import threading
import time

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "api"))

REPLY_WAIT = 5.0  # a reply through a client and the gateway on a loaded 2-core machine
LINE_BAUD = 115200  # the real link (controllers[].baud)
SIGNATURE = b"asi-gateway"  # telnet_codec::signature
MODEM_STATE = 0xB0  # telnet_codec::modem_state: CD, DSR, CTS on

CYCLADES = "cyclades-ser-cli"
CYCLADES_LIB = "/usr/lib/libcyclades-ser-cli.so"
CYCLADES_DEVICES = "/etc/cyclades-devices"
GENSIOT = "gensiot"
ESC = b"\x1d"  # gensiot's escape character (-e ^])

# Telnet (RFC 854/855) and RFC 2217 codes.
IAC, SE, SB, WILL, WONT, DO, DONT, BRK = 255, 240, 250, 251, 252, 253, 254, 243
VERBS = {WILL: "WILL", WONT: "WONT", DO: "DO", DONT: "DONT"}
BINARY, SGA, COM_PORT = 0, 3, 44
COM_NAMES = {0: "SIGNATURE", 1: "SET-BAUDRATE", 2: "SET-DATASIZE", 3: "SET-PARITY", 4: "SET-STOPSIZE",
             5: "SET-CONTROL", 6: "NOTIFY-LINESTATE", 7: "NOTIFY-MODEMSTATE", 8: "FLOWCONTROL-SUSPEND",
             9: "FLOWCONTROL-RESUME", 10: "SET-LINESTATE-MASK", 11: "SET-MODEMSTATE-MASK", 12: "PURGE-DATA"}


# --------------------------------------------------------------------------------------------
# The tty agent: opens a client's device and does what a serial program does there. Run in a child
# process for cyclades (under LD_PRELOAD in a mount namespace of its own), in-process for gensiot.


class TtyAgent:
    SPEEDS = {9600: termios.B9600, 19200: termios.B19200, 115200: termios.B115200}
    PARITY = {"N": 0, "E": termios.PARENB, "O": termios.PARENB | termios.PARODD}
    SIZES = {5: termios.CS5, 6: termios.CS6, 7: termios.CS7, 8: termios.CS8}

    def __init__(self):
        self.fd = None

    def handle(self, req):
        return getattr(self, "op_" + req["op"])(**{k: v for k, v in req.items() if k != "op"})

    def op_open(self, path):
        self.fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
        return {}

    def op_raw(self):
        """Raw line discipline with libc's own tcsetattr (not one an LD_PRELOAD library replaced)."""
        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        buf = ctypes.create_string_buffer(256)
        if libc.tcgetattr(self.fd, buf) != 0:
            return {"error": os.strerror(ctypes.get_errno())}
        libc.cfmakeraw(buf)
        if libc.tcsetattr(self.fd, termios.TCSANOW, buf) != 0:
            return {"error": os.strerror(ctypes.get_errno())}
        return {"lflag": termios.tcgetattr(self.fd)[3]}

    def op_set(self, baud, bits, parity, stop, rtscts=False, tries=1):
        """tcsetattr() with these line settings, the rest unchanged. `tries`: attempts while it fails
        with errno 0, the cyclades library's "no answer in time" (at the first open its daemon cycles
        DTR for over a second before it takes a request)."""
        a = termios.tcgetattr(self.fd)
        a[2] &= ~(termios.CSIZE | termios.PARENB | termios.PARODD | termios.CSTOPB | termios.CRTSCTS)
        a[2] |= self.SIZES[bits] | self.PARITY[parity] | termios.CREAD | termios.CLOCAL
        if stop == 2:
            a[2] |= termios.CSTOPB
        if rtscts:
            a[2] |= termios.CRTSCTS
        a[4] = a[5] = self.SPEEDS[baud]
        started = time.monotonic()
        errors = []
        for _ in range(tries):
            try:
                termios.tcsetattr(self.fd, termios.TCSANOW, a)
                return {"ok": True, "errors": errors, "took": time.monotonic() - started}
            except termios.error as e:
                errors.append(list(e.args))
                if e.args[0] != 0:
                    break
        return {"ok": False, "errors": errors, "took": time.monotonic() - started}

    def op_break(self):
        started = time.monotonic()
        try:
            termios.tcsendbreak(self.fd, 0)
            return {"ok": True, "took": time.monotonic() - started}
        except termios.error as e:
            return {"ok": False, "errors": [list(e.args)]}

    def op_write(self, data):
        os.write(self.fd, bytes.fromhex(data))
        return {}

    def op_read_until(self, end, within):
        """Bytes up to and including `end`, or what came in `within` seconds."""
        end = bytes.fromhex(end)
        data, deadline = b"", time.monotonic() + within
        while not data.endswith(end):
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([self.fd], [], [], left)[0]:
                break
            data += os.read(self.fd, 1)
        return {"data": data.hex()}

    def op_read_for(self, seconds):
        """Whatever comes in `seconds`."""
        data, deadline = b"", time.monotonic() + seconds
        while True:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([self.fd], [], [], left)[0]:
                return {"data": data.hex()}
            data += os.read(self.fd, 4096)

    def op_close(self):
        os.close(self.fd)
        self.fd = None
        return {}


def agent_main():
    """--tty-agent: requests on stdin, one JSON object a line; each answer on stdout after "@@"
    (other lines there, e.g. from an LD_PRELOAD library, are not answers)."""
    agent = TtyAgent()
    for line in iter(sys.stdin.readline, ""):
        try:
            res = agent.handle(json.loads(line))
        except Exception as e:  # noqa: BLE001 - reported to the test, which fails the step
            res = {"exception": repr(e)}
        sys.stdout.write("@@" + json.dumps(res) + "\n")
        sys.stdout.flush()


class LocalAgent:
    def __init__(self):
        self.agent = TtyAgent()

    def call(self, op, **kw):
        res = self.agent.handle(dict(kw, op=op))
        check("exception" not in res, f"tty agent {op}: {res.get('exception')}")
        return res

    def close(self):
        if self.agent.fd is not None:
            self.agent.op_close()


class AgentProcess:
    """A TtyAgent in a child process started with `argv` (which ends by running this file with
    --tty-agent)."""

    def __init__(self, fx, argv):
        self.proc = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        fx.procs.append(self.proc)
        self.buffer = b""

    def call(self, op, timeout=30.0, **kw):
        try:
            self.proc.stdin.write((json.dumps(dict(kw, op=op)) + "\n").encode())
            self.proc.stdin.flush()
        except BrokenPipeError:
            raise Failure(f"the tty agent is gone ({op}): {self.stderr()}")
        deadline = time.monotonic() + timeout
        fd = self.proc.stdout.fileno()
        while True:
            while b"\n" in self.buffer:
                line, _, self.buffer = self.buffer.partition(b"\n")
                if line.startswith(b"@@"):
                    res = json.loads(line[2:])
                    check("exception" not in res, f"tty agent {op}: {res.get('exception')}")
                    return res
            left = deadline - time.monotonic()
            check(left > 0, f"tty agent {op}: no answer in {timeout} s")
            if select.select([fd], [], [], left)[0]:
                chunk = os.read(fd, 65536)
                check(chunk, f"the tty agent exited during {op}: {self.stderr()}")
                self.buffer += chunk

    def stderr(self):
        if self.proc.poll() is None:
            return "(running)"
        return self.proc.stderr.read().decode(errors="replace")[-2000:]

    def close(self):
        if self.proc.poll() is None:
            try:
                self.proc.stdin.close()
            except OSError:
                pass
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


if __name__ == "__main__" and sys.argv[1:] == ["--tty-agent"]:
    agent_main()
    sys.exit(0)

from gateway_fixture import (TOKENS, Failure, Fixture, auth_tokens, check, free_port, run_main,  # noqa: E402
                             wait_until)
from http_api_test import Client, Contract  # noqa: E402

ADMIN = TOKENS["admin"]
VIEW = TOKENS["viewer"]


# --------------------------------------------------------------------------------------------
# Telnet: parsing what was recorded, and what the gateway must answer


def telnet_items(stream):
    """(data, items) of one direction's bytes: the data with IAC IAC undone, and the Telnet items in
    order, each (offset, kind, value): ("WILL"|"WONT"|"DO"|"DONT", option), ("SB", payload with IAC IAC
    undone), ("CMD", code). An unfinished item at the end is left out."""
    data, items, i, n = bytearray(), [], 0, len(stream)
    while i < n:
        b = stream[i]
        if b != IAC:
            data.append(b)
            i += 1
            continue
        if i + 1 >= n:
            break
        c = stream[i + 1]
        if c == IAC:
            data.append(IAC)
            i += 2
        elif c in VERBS:
            if i + 2 >= n:
                break
            items.append((i, VERBS[c], stream[i + 2]))
            i += 3
        elif c == SB:
            payload, j, done = bytearray(), i + 2, False
            while j + 1 < n:
                if stream[j] == IAC and stream[j + 1] == IAC:
                    payload.append(IAC)
                    j += 2
                elif stream[j] == IAC and stream[j + 1] == SE:
                    done = True
                    break
                else:
                    payload.append(stream[j])
                    j += 1
            if not done:
                break
            items.append((i, "SB", bytes(payload)))
            i = j + 2
        else:
            items.append((i, "CMD", c))
            i += 2
    return bytes(data), items


def describe(item):
    kind, value = item[-2], item[-1]
    if kind == "SB":
        if len(value) >= 2 and value[0] == COM_PORT:
            cmd = value[1]
            name = COM_NAMES.get(cmd % 100, str(cmd)) + (" (answer)" if cmd >= 100 else "")
            return f"SB COM-PORT {name} {value[2:].hex(' ') or '-'}"
        return f"SB {value.hex(' ')}"
    if kind == "CMD":
        return f"IAC {value}"
    return f"{kind} {value}"


def new_port():
    """The port a client sees before it sets anything: the real link (115200 8N1), no flow control,
    BREAK off, DTR and RTS on (RFC 2217 values, by SET-CONTROL query value)."""
    return {"baud": LINE_BAUD.to_bytes(4, "big"), 2: 8, 3: 1, 4: 1, "control": {0: 1, 4: 6, 7: 8, 10: 11, 13: 14}}


def control_group(value):
    """The SET-CONTROL query value of the group a setting belongs to (RFC 2217 section 3)."""
    if value <= 3 or value in (17, 19):
        return 0
    if value <= 6:
        return 4
    if value <= 9:
        return 7
    if value <= 12:
        return 10
    return 13


def com_port_answer(payload, port):
    """The gateway's answer (payload) to a client's COM-PORT subnegotiation payload, or None: RFC 2217's
    command + 100; a setting kept in the client's own `port` (new_port()) and echoed as acknowledged (the
    real link never changes), a value outside the RFC's table and a query answered with what the port
    has, SIGNATURE with no text -> asi-gateway, a NOTIFY poll -> 0 / the modem lines."""
    if len(payload) < 2 or payload[0] != COM_PORT:
        return None
    cmd, value = payload[1], payload[2:]

    def answer(v):
        return bytes([COM_PORT, cmd + 100]) + v

    one = value[0] if len(value) == 1 else None
    if cmd == 0:
        return answer(SIGNATURE) if not value else None
    if cmd == 1:
        if len(value) != 4:
            return None
        if value != b"\0\0\0\0":
            port["baud"] = value
        return answer(port["baud"])
    if cmd in (2, 3, 4):
        if one is None:
            return None
        lo, hi = {2: (5, 8), 3: (1, 5), 4: (1, 3)}[cmd]
        if lo <= one <= hi:
            port[cmd] = one
        return answer(bytes([port[cmd]]))
    if cmd == 5:
        if one is None or one > 19:
            return None
        group = control_group(one)
        if one != group:
            port["control"][group] = one
        return answer(bytes([port["control"][group]]))
    if cmd in (6, 7):
        return answer(bytes([0 if cmd == 6 else MODEM_STATE])) if not value else None
    if cmd in (10, 11):
        return answer(value) if one is not None else None
    if cmd == 12:
        return answer(value) if one in (1, 2, 3) else None
    return None  # FLOWCONTROL-SUSPEND/RESUME (no answer defined), unknown


def expected_answers(client_items):
    """The Telnet items the gateway sends for a client's items, in order (RFC 1143's Q method): at the
    client's first command WILL BINARY and DO BINARY; BINARY, SUPPRESS-GO-AHEAD and COM-PORT-OPTION
    agreed when asked, every other option refused, no answer to what changes nothing (nor to answers to
    our own offers); once COM-PORT-OPTION is agreed one NOTIFY-MODEMSTATE; each COM-PORT request (once
    agreed) answered as com_port_answer() says; other commands (BRK, NOP, ...) unanswered."""
    out, us, him = [], {}, {}
    seen = notified = False
    port = new_port()

    def agreed():
        return us.get(COM_PORT) == "yes" or him.get(COM_PORT) == "yes"

    for _, kind, value in client_items:
        if not seen:
            seen = True
            out += [("WILL", BINARY), ("DO", BINARY)]
            us[BINARY] = him[BINARY] = "want"
        if kind in ("WILL", "WONT", "DO", "DONT"):
            client_side, enable = kind in ("WILL", "WONT"), kind in ("WILL", "DO")
            agree, refuse = ("DO", "DONT") if client_side else ("WILL", "WONT")
            if value not in (BINARY, SGA, COM_PORT):
                if enable:
                    out.append((refuse, value))
                continue
            side = him if client_side else us
            state = side.get(value, "no")
            if enable and state == "no":
                out.append((agree, value))
            if not enable and state == "yes":
                out.append((refuse, value))
            side[value] = "yes" if enable else "no"
            if not notified and agreed():
                notified = True
                out.append(("SB", bytes([COM_PORT, 107, MODEM_STATE])))
        elif kind == "SB" and agreed():
            a = com_port_answer(value, port)
            if a is not None:
                out.append(("SB", a))
    return out


def check_exchange(up, down, who):
    """Every Telnet request in `up` got exactly its answer in `down`, and nothing else came; returns the
    data of both directions."""
    up_data, up_items = telnet_items(up)
    down_data, down_items = telnet_items(down)
    got = [(k, v) for _, k, v in down_items]
    want = expected_answers(up_items)
    if got != want:
        lines = [f"{who}: the gateway's Telnet answers differ from RFC 2217's",
                 "client sent: " + "; ".join(describe(i) for i in up_items),
                 "expected:    " + "; ".join(describe(i) for i in want),
                 "got:         " + "; ".join(describe(i) for i in got),
                 f"raw client bytes: {up!r}", f"raw gateway bytes: {down!r}"]
        raise Failure("\n".join(lines))
    return up_data, down_data


def com_requests(up, start=0):
    """The client's COM-PORT requests (payloads) from byte offset `start` on."""
    return [v for off, k, v in telnet_items(up)[1] if k == "SB" and off >= start and len(v) >= 2 and v[0] == COM_PORT
            and v[1] < 100]


def predicted_answers(up, start=0):
    """(request, the answer com_port_answer() predicts or None) for the client's COM-PORT requests from
    byte offset `start` on, the port's settings followed from the connection's first request."""
    port, pairs = new_port(), []
    for off, kind, value in telnet_items(up)[1]:
        if kind == "SB" and len(value) >= 2 and value[0] == COM_PORT and value[1] < 100:
            answer = com_port_answer(value, port)
            if off >= start:
                pairs.append((value, answer))
    return pairs


def com_answers(down, start=0):
    return [v for off, k, v in telnet_items(down)[1] if k == "SB" and off >= start and len(v) >= 2 and v[1] >= 100]


# --------------------------------------------------------------------------------------------
# The relay between a client and the shared port


class Relay:
    """A loopback TCP listener that relays each connection to the gateway's shared port and keeps what
    went each way."""

    class Conn:
        def __init__(self, client, upstream):
            self.client, self.upstream = client, upstream
            self.up, self.down = bytearray(), bytearray()
            self.last = time.monotonic()
            self.local_port = upstream.getsockname()[1]  # the gateway lists "tcp 127.0.0.1:<this>"
            self.open = 2

    def __init__(self, target_port):
        self.target = target_port
        self.listener = socket.socket()
        self.listener.bind(("127.0.0.1", 0))
        self.listener.listen(8)
        self.port = self.listener.getsockname()[1]
        self.conns, self.lock, self.threads = [], threading.Lock(), []
        self.stopping = False
        self._spawn(self._accept)

    def _spawn(self, fn, *a):
        t = threading.Thread(target=fn, args=a, daemon=True)
        t.start()
        self.threads.append(t)

    def _accept(self):
        while not self.stopping:
            try:
                client, _ = self.listener.accept()
            except OSError:
                return
            upstream = socket.create_connection(("127.0.0.1", self.target), timeout=REPLY_WAIT)
            upstream.settimeout(None)
            conn = Relay.Conn(client, upstream)
            with self.lock:
                self.conns.append(conn)
            self._spawn(self._pump, conn, client, upstream, "up")
            self._spawn(self._pump, conn, upstream, client, "down")

    def _pump(self, conn, src, dst, way):
        try:
            while True:
                try:
                    data = src.recv(65536)
                except OSError:
                    data = b""
                if not data:
                    return
                with self.lock:
                    getattr(conn, way).extend(data)  # kept before it is passed on
                    conn.last = time.monotonic()
                dst.sendall(data)
        except OSError:
            pass
        finally:
            try:
                dst.shutdown(socket.SHUT_WR)
            except OSError:
                pass
            with self.lock:
                conn.open -= 1

    def only(self):
        """The one connection so far."""
        with self.lock:
            check(len(self.conns) == 1, f"{len(self.conns)} connections through the relay, expected 1")
            return self.conns[0]

    def snapshot(self, conn):
        with self.lock:
            return bytes(conn.up), bytes(conn.down)

    def wait_quiet(self, conn, seconds, timeout=30.0):
        """Until nothing went either way for `seconds`."""
        wait_until(f"{seconds} s without traffic", lambda: time.monotonic() - conn.last >= seconds, timeout)

    def wait_answered(self, conn, start, what, count=None):
        """Until the client's COM-PORT requests from `start` on (at least `count`) all have their
        answers; returns (requests, answers) of that part."""
        def done():
            up, down = self.snapshot(conn)
            reqs = com_requests(up, start[0])
            answers = com_answers(down, start[1])
            want = [a for _, a in predicted_answers(up, start[0]) if a is not None]
            if count is not None and len(reqs) < count:
                return None
            return (reqs, answers) if len(answers) >= len(want) else None
        return wait_until(what, done, timeout=REPLY_WAIT * 2)

    def mark(self, conn):
        with self.lock:
            return len(conn.up), len(conn.down)

    def stop(self):
        self.stopping = True
        try:
            self.listener.shutdown(socket.SHUT_RDWR)  # wakes accept()
        except OSError:
            pass
        self.listener.close()
        with self.lock:
            conns = list(self.conns)
        for c in conns:
            for sock in (c.client, c.upstream):
                try:
                    sock.shutdown(socket.SHUT_RDWR)
                except OSError:
                    pass
                sock.close()
        for t in self.threads:
            t.join(timeout=5)


# --------------------------------------------------------------------------------------------
# The scene


def controller(c, cid="s1"):
    r = c.request("GET", f"/api/v1/controllers/{cid}", token=VIEW)
    check(r.status == 200, f"GET controller {cid}: {r.status} {r.body[:300]}")
    return r.json()


def raw(c, line, cid="s1"):
    """The controller's reply to `line` through REST, as the controller sent it (with CR LF)."""
    r = c.request("POST", f"/api/v1/controllers/{cid}/command", {"command": line}, token=ADMIN)
    check(r.status == 200, f"raw {line!r}: {r.status} {r.body[:300]}")
    return r.json()["raw_reply"].encode() + b"\r\n"


class RestReader:
    """GET /api/v1/controllers/s1 over and over (validated against the OpenAPI document) while a client
    works; keeps the share clients each answer listed."""

    def __init__(self, c):
        self.c, self.stop_flag = c, threading.Event()
        self.count, self.errors, self.clients, self.states = 0, [], [], set()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self):
        while not self.stop_flag.is_set():
            try:
                r = self.c.request("GET", "/api/v1/controllers/s1", token=VIEW)
                if r.status != 200:
                    self.errors.append(f"status {r.status}")
                else:
                    body = r.json()
                    self.states.add(body["state"])
                    self.clients.append(body["share"]["clients"])
                self.count += 1
            except Exception as e:  # noqa: BLE001 - a failed GET is what this records
                self.errors.append(repr(e))
            time.sleep(0.05)

    def stop(self):
        self.stop_flag.set()
        self.thread.join(timeout=30)

    def check(self):
        check(self.count >= 3 and not self.errors,
              f"REST during the session: {self.count} GETs, errors {self.errors[:3]}")
        check(self.states == {"connected"}, f"the controller's state during the session: {self.states}")


class Scene:
    """The gateway with one external simulator, shared over TCP; the real link's termios."""

    def __init__(self, fx, args):
        self.fx = fx
        self.sim = fx.start_sim(args.sim, "s1", "full", time_scale=10)
        self.http_port, self.tcp = free_port(), free_port()
        fx.start_gateway(args.gateway, {
            "http": {"port": self.http_port},
            "auth": auth_tokens(),
            "controllers": [{"id": "s1", "port": self.sim.link, "baud": LINE_BAUD,
                             "share": {"tcp": f"127.0.0.1:{self.tcp}", "max_clients": 4}}],
            "simulate": {"count": 0},
        })
        with open(args.openapi) as f:
            self.c = Client(self.http_port, Contract(f.read()))
        wait_until("s1 connected", lambda: controller(self.c)["state"] == "connected")
        self.captures = {}  # client name -> (up, down), printed with --show-bytes or on a failure

    def link_settings(self):
        """(ispeed, ospeed, size, parity, two stop bits) of the real link (the simulator's pty, as the
        gateway set it)."""
        fd = os.open(self.sim.link, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        try:
            a = termios.tcgetattr(fd)
        finally:
            os.close(fd)
        return a[4], a[5], a[2] & termios.CSIZE, a[2] & (termios.PARENB | termios.PARODD), bool(a[2] & termios.CSTOPB)

    def check_link_unchanged(self, when):
        settings = self.link_settings()
        check(settings == (termios.B115200, termios.B115200, termios.CS8, 0, False),
              f"{when}: the real link's termios changed: {settings}")
        state = json.loads(self.sim.control("state"))
        check(state["baud"] == LINE_BAUD, f"{when}: the controller's BAUD is {state['baud']}")


def wait_still(s):
    """Until X has stopped; the controller's W X reply there."""
    wait_until("X stopped", lambda: not controller(s.c)["busy"])
    reply = raw(s.c, "W X")
    wait_until("X still", lambda: raw(s.c, "W X") == reply)
    return raw(s.c, "W X")


def check_client_listed(s, relay_conn, reader, lines):
    """The client is listed in GET /api/v1/controllers/s1 (as the relay's connection) while it works,
    and at the end with `lines` commands, nothing refused, dropped or late."""
    name = f"tcp 127.0.0.1:{relay_conn.local_port}"
    check(any(c["name"] == name for snapshot in reader.clients for c in snapshot),
          f"REST never listed the client {name} during the session: {reader.clients[-1:]}")

    def entry():
        return next((c for c in controller(s.c)["share"]["clients"] if c["name"] == name), None)

    wait_until(f"{name} listed with {lines} commands", lambda: (entry() or {}).get("commands") == lines)
    last = entry()
    check(last["refused"] == 0 and last["dropped_bytes"] == 0 and last["late"] == 0, f"the client's entry: {last}")
    return last


def check_halt_by(s, relay_conn, before):
    halted = controller(s.c)["halted"]
    by = f"shared-port/s1 (tcp 127.0.0.1:{relay_conn.local_port})"
    check(halted and halted["by"] == by and halted != before, f"halted: {halted}, expected by {by!r}")


# --------------------------------------------------------------------------------------------
# cyclades-ser-cli


def find_program(name):
    return shutil.which(name, path=os.environ.get("PATH", "") + ":/usr/sbin:/sbin")


def namespace_prefix():
    """The command prefix that runs a program in a mount namespace of its own where mount --bind
    works: unshare --mount as root, else with a user namespace; None when neither works here."""
    for prefix in (["unshare", "--mount"], ["unshare", "--user", "--map-root-user", "--mount"]):
        if prefix == ["unshare", "--mount"] and os.geteuid() != 0:
            continue
        probe = subprocess.run(prefix + ["sh", "-c", f"mount --bind {os.devnull} {os.devnull}"],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        if probe.returncode == 0:
            return prefix
    return None


class ClientRun:
    """One client's relay, process and tty agent, shared by its tests and the cleanup."""

    def __init__(self):
        self.relay = None
        self.proc = None
        self.agent = None


def test_cyclades_session(s, run):
    fx = s.fx
    program = find_program(CYCLADES)
    check(program and os.path.exists(CYCLADES_LIB),
          "cyclades-ser-cli or its libcyclades-ser-cli.so is not installed (Debian package cyclades-serial-client; "
          "scripts/install-deps --tests installs it)")
    prefix = namespace_prefix()
    check(prefix, "cannot make a mount namespace (unshare --mount as root, or unprivileged user namespaces): "
                  "cyclades' LD_PRELOAD library only knows devices listed in /etc/cyclades-devices, which the test "
                  "replaces by a private copy there")
    relay = run.relay = Relay(s.tcp)
    device = os.path.join(fx.tmp, "cyclades-tty")
    log = open(os.path.join(fx.tmp, "cyclades-ser-cli.log"), "w")
    # Physical port 1 of a "terminal server" at 127.0.0.1 whose base port is relay.port - 1: relay.port.
    run.proc = subprocess.Popen([program, "-x", "-r", "1", "-i", "1", "-p", str(relay.port - 1), device,
                                 "127.0.0.1", "1"], stdout=log, stderr=subprocess.STDOUT)
    fx.procs.append(run.proc)
    log.close()
    wait_until("cyclades-ser-cli's tty", lambda: os.path.islink(device) and os.path.exists(device + ".control"))
    wait_until("cyclades-ser-cli connected", lambda: relay.conns)
    conn = relay.only()
    # It speaks after 2 s (WILL COM-PORT-OPTION, DO SUPPRESS-GO-AHEAD), then asks the port's settings.
    wait_until("cyclades-ser-cli's first requests", lambda: com_requests(relay.snapshot(conn)[0]))
    relay.wait_quiet(conn, 1.0)

    devices = os.path.join(fx.tmp, "cyclades-devices")
    with open(devices, "w") as f:
        f.write(f"{device}:prts:127.0.0.1:1:rtelnet:\n")
    script = 'mount --bind "$1" "$2" && exec env LD_PRELOAD="$3" /usr/bin/python3 "$4" --tty-agent'
    agent = run.agent = AgentProcess(fx, prefix + ["sh", "-c", script, "sh", devices, CYCLADES_DEVICES,
                                                  CYCLADES_LIB, os.path.abspath(__file__)])
    session(s, run, conn, agent, device, cyclades=True)


def check_answers(s, run, who, at_least):
    """Once the client has stopped: every Telnet request of its whole connection (it sent at least
    `at_least` COM-PORT requests) had exactly its answer; the bytes are kept for the replay printout."""
    check(run.relay and run.relay.conns, f"no {who} connection was recorded")
    conn = run.relay.only()
    if run.proc and run.proc.poll() is None:
        run.proc.send_signal(signal.SIGTERM)
        run.proc.wait(timeout=30)
    wait_until(f"the {who} connection closed", lambda: conn.open == 0)
    up, down = run.relay.snapshot(conn)
    s.captures[who] = (up, down)
    check(len(com_requests(up)) >= at_least, f"{who} sent {len(com_requests(up))} COM-PORT requests")
    check_exchange(up, down, who)


def test_cyclades_answers(s, run):
    check_answers(s, run, "cyclades-ser-cli", 10)


# --------------------------------------------------------------------------------------------
# gensiot


def test_gensiot_session(s, run):
    fx = s.fx
    program = find_program(GENSIOT)
    check(program, "gensiot is not installed (Debian package gensio-bin; scripts/install-deps --tests installs it)")
    relay = run.relay = Relay(s.tcp)
    device = os.path.join(fx.tmp, "gensiot-tty")
    log = open(os.path.join(fx.tmp, "gensiot.log"), "w")
    run.proc = subprocess.Popen([program, "-e", "^]", "-i", f"pty(raw,link={device})",
                                 f"telnet(rfc2217),tcp,127.0.0.1,{relay.port}"],
                                stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT)
    fx.procs.append(run.proc)
    log.close()
    wait_until("gensiot's pty", lambda: os.path.islink(device))
    wait_until("gensiot connected", lambda: relay.conns)
    conn = relay.only()
    relay.wait_quiet(conn, 0.5)
    run.agent = LocalAgent()
    session(s, run, conn, run.agent, device, cyclades=False)


def test_gensiot_answers(s, run):
    check_answers(s, run, "gensiot", 8)


# --------------------------------------------------------------------------------------------
# The session, through either client's device


def session(s, run, conn, agent, device, cyclades):
    relay, who = run.relay, "cyclades-ser-cli" if cyclades else "gensiot"
    wrote, replies = bytearray(), bytearray()  # what went through the device, to compare with the relay

    def ask(line, expected=None, what=None):
        agent.call("write", data=line.hex())
        wrote.extend(line)
        reply = bytes.fromhex(agent.call("read_until", end="0d0a", within=REPLY_WAIT)["data"])
        replies.extend(reply)
        if expected is not None:
            check(reply == expected, f"{who}: {what or line!r}: {reply!r}, expected {expected!r}")
        return reply

    def setting(baud, bits, parity, stop=1, rtscts=False):
        """Through cyclades: tcsetattr() on its tty, which returns once the gateway answered. Tried
        three times while its library reports "no answer in time" (errno 0): at the first open its
        daemon cycles DTR for over a second before it takes a request, close to the library's 2 s; every
        attempt needs the gateway's answers."""
        start = relay.mark(conn)
        res = agent.call("set", baud=baud, bits=bits, parity=parity, stop=stop, rtscts=rtscts, tries=3)
        check(res["ok"], f"{who}: tcsetattr {baud} {bits}{parity}{stop} failed: {res['errors']}")
        if res["errors"]:
            print(f"       ({who}: tcsetattr {baud} {bits}{parity}{stop} took {res['took']:.1f} s, "
                  f"{len(res['errors'])} attempt(s) timed out in its library)")
        up, down = relay.snapshot(conn)
        return com_requests(up, start[0]), com_answers(down, start[1]), res

    def escape(keys, echo=b"", count=1, what="", typed=False):
        """Through gensiot: escape commands typed on its pty; `echo` what gensiot prints back there.
        `typed`: a value typed after ^] s, which gensiot echoes between < and >, in gensio 2.6.2 at times
        with a few stray bytes after each character (its own bug): only its frame is checked."""
        start = relay.mark(conn)
        agent.call("write", data=keys.hex())
        if echo:
            got = bytes.fromhex(agent.call("read_until", end=echo.hex(), within=REPLY_WAIT)["data"])
            check(got == echo, f"gensiot's answer to {what or keys!r}: {got!r}, expected {echo!r}")
        answered = relay.wait_answered(conn, start, f"gensiot's {what or keys!r} answered", count=count)
        if typed:
            # The echo came before the request went out; nothing else is on the pty now.
            got = bytes.fromhex(agent.call("read_for", seconds=0.3)["data"])
            check(got.startswith(b"<") and got.endswith(b">"), f"gensiot's echo of {what or keys!r}: {got!r}")
        return answered

    def expect_requests(got, wanted, what):
        reqs, answers = got[0], got[1]
        missing = [w for w in wanted if w not in reqs]
        check(not missing, f"{who}: {what}: the requests {[describe(('SB', m)) for m in missing]} were not sent "
                           f"(sent: {[describe(('SB', r)) for r in reqs]})")
        # The answer each request should get, the port's settings followed over the whole connection
        # (the latest occurrence of a request is this step's).
        predicted = dict(predicted_answers(relay.snapshot(conn)[0]))
        for w in wanted:
            a = predicted[w]
            check(a in answers, f"{who}: {what}: {describe(('SB', w))} got no answer {describe(('SB', a))} "
                                f"(got {[describe(('SB', x)) for x in answers]})")

    raw(s.c, "H X=0")
    start_reply = raw(s.c, "W X")
    reader = RestReader(s.c)
    try:
        agent.call("open", path=device)
        res = agent.call("raw")
        check("error" not in res and not res["lflag"] & (termios.ECHO | termios.ICANON), f"raw mode: {res}")
        if cyclades:
            setting(115200, 8, "N")
        else:
            # gensio's pty is no serial port: a local setting reaches nobody.
            start = relay.mark(conn)
            got = agent.call("set", baud=9600, bits=8, parity="N", stop=1)
            check(got["ok"], f"tcsetattr on gensiot's pty: {got}")
            got = agent.call("set", baud=115200, bits=8, parity="N", stop=1)
            check(got["ok"], f"tcsetattr on gensiot's pty: {got}")
            time.sleep(0.5)
            check(relay.mark(conn) == start, "a tcsetattr on gensiot's pty sent something to the gateway")

        ask(b"W X\r", start_reply)
        ask(b"M X=1000\r", b":A\r\n")
        build = ask(b"BU X\r", raw(s.c, "BU X"), "BU X")
        check(b"\r" in build[:-2], f"BU X has inner CRs: {build!r}")
        still = wait_still(s)
        check(still != start_reply, f"the move changed W X: {still!r}")

        # 9600 baud, then 7E1: acknowledged, the real link unchanged, the replies keep coming.
        baud_9600 = bytes([COM_PORT, 1]) + (9600).to_bytes(4, "big")
        if cyclades:
            expect_requests(setting(9600, 8, "N"), [baud_9600], "9600 baud")
        else:
            expect_requests(escape(ESC + b"s9600\n", typed=True, what="^] s 9600"), [baud_9600], "9600 baud")
        s.check_link_unchanged(f"{who}: after 9600 baud")
        ask(b"W X\r", still, "W X at 9600 baud")
        seven_even = [bytes([COM_PORT, 2, 7]), bytes([COM_PORT, 3, 2 + 1])]  # DATASIZE 7, PARITY EVEN (3)
        if cyclades:
            expect_requests(setting(9600, 7, "E"), seven_even, "7E1")
        else:
            expect_requests(escape(ESC + b"e" + ESC + b"7", count=2, what="^] e ^] 7"), seven_even, "7E1")
        s.check_link_unchanged(f"{who}: after 7E1")
        ask(b"W X\r", still, "W X at 7E1")
        flow_two = [bytes([COM_PORT, 5, 3]), bytes([COM_PORT, 4, 2])]  # RTS/CTS flow control, 2 stop bits
        if cyclades:
            expect_requests(setting(9600, 7, "E", stop=2, rtscts=True), flow_two, "RTS/CTS and 2 stop bits")
        else:
            expect_requests(escape(ESC + b"r" + ESC + b"2", count=2, what="^] r ^] 2"), flow_two,
                            "RTS/CTS and 2 stop bits")
        s.check_link_unchanged(f"{who}: after RTS/CTS and 2 stop bits")
        ask(b"W X\r", still, "W X with RTS/CTS and 2 stop bits")

        # A BREAK: RFC 2217's SET-CONTROL BREAK-ON/OFF (cyclades) or Telnet's BRK (gensiot); acknowledged
        # or consumed, never sent to the controller.
        if cyclades:
            start = relay.mark(conn)
            res = agent.call("break")
            check(res["ok"], f"tcsendbreak: {res}")
            up, down = relay.snapshot(conn)
            expect_requests((com_requests(up, start[0]), com_answers(down, start[1])),
                            [bytes([COM_PORT, 5, 5]), bytes([COM_PORT, 5, 6])], "BREAK")
        else:
            start = relay.mark(conn)
            agent.call("write", data=(ESC + b"b").hex())
            wait_until("gensiot's BRK", lambda: bytes([IAC, BRK]) in relay.snapshot(conn)[0][start[0]:])
        ask(b"W X\r", still, "W X after the BREAK")

        # HALT: the controller's answer, and the gateway's HALT by this client.
        before = controller(s.c)["halted"]
        ask(b"\\", b":A\r\n", "HALT")
        check_halt_by(s, conn, before)

        if not cyclades:
            # What gensiot reads back: the server's signature and the settings it made (9600, even parity,
            # 7 bits, 2 stop bits), as a serial port would keep them; the real link is unchanged.
            got = escape(ESC + b"d", echo=b"Signature: asi-gateway\r\nSpeed: 9600E72\r\n", count=5, what="^] d")
            expect_requests(got, [bytes([COM_PORT, 0]), bytes([COM_PORT, 1, 0, 0, 0, 0])], "^] d")

        # Back to 115200 8N1, no flow control. (cyclades asks for what differs from the pty's termios,
        # and its library hands the kernel a mangled c_cflag for 7E1 and for 2 stop bits with RTS/CTS,
        # B0|CS5|PARENB and B0|CS5|CRTSCTS, seen with strace: the pty never held 7E1 or 2 stop bits, so
        # only the baud rate and the flow control are asked again.)
        back = [bytes([COM_PORT, 1]) + LINE_BAUD.to_bytes(4, "big"), bytes([COM_PORT, 5, 1])]
        if cyclades:
            expect_requests(setting(115200, 8, "N"), back, "115200 8N1")
        else:
            got = escape(ESC + b"n" + ESC + b"8" + ESC + b"1" + ESC + b"f" + ESC + b"s115200\n", typed=True,
                         count=5, what="^] n 8 1 f s115200")
            expect_requests(got, back + [bytes([COM_PORT, 3, 1]), bytes([COM_PORT, 2, 8]), bytes([COM_PORT, 4, 1])],
                            "115200 8N1")
        ask(b"W X\r", still, "W X back at 115200 8N1")
        s.check_link_unchanged(f"{who}: at the end")

        listed = check_client_listed(s, conn, reader, wrote.count(b"\r") + wrote.count(b"\\"))
        print(f"       {who}: REST answered {reader.count} GETs meanwhile; the share lists "
              f"{listed['name']} with {listed['commands']} commands")
    finally:
        reader.stop()
        try:
            agent.call("close")
        except Failure:
            pass
        agent.close()
    reader.check()

    # The data streams carried exactly the session's commands and the controller's replies.
    if not cyclades:
        relay.wait_quiet(conn, 0.3)
    up, down = relay.snapshot(conn)
    up_data, down_data = telnet_items(up)[0], telnet_items(down)[0]
    check(up_data == bytes(wrote), f"{who}: the client sent {up_data!r} as data, the session wrote {bytes(wrote)!r}")
    check(down_data == bytes(replies), f"{who}: the gateway sent {down_data!r} as data, the session read "
                                       f"{bytes(replies)!r}")


# --------------------------------------------------------------------------------------------
# The recorded negotiations, replayed raw: (what the client sent, what the gateway must answer), in
# the client's own TCP segments. W X at the end shows the data path after them.

# cyclades-ser-cli 0.94: its start, the tty's first open, then what programs set through its library:
# tcsetattr (baud, CS7, PARENB, CRTSCTS, IXON, CSTOPB), tcsendbreak, and a flush (PURGE-DATA).
CYCLADES_REPLAY = [
    # Start: WILL COM-PORT, DO SGA -> our BINARY offers, DO COM-PORT, the modem lines, WILL SGA.
    (b"\xff\xfb\x2c\xff\xfd\x03",
     b"\xff\xfb\x00\xff\xfd\x00\xff\xfd\x2c\xff\xfa\x2c\x6b\xb0\xff\xf0\xff\xfb\x03"),
    (b"\xff\xfe\x00", b""),  # DONT BINARY: our offer refused, no answer
    # WONT BINARY (refused), then the queries: baud, data size, parity, stop size, flow control.
    (b"\xff\xfc\x00\xff\xfa\x2c\x01\x00\x00\x00\x00\xff\xf0", b"\xff\xfa\x2c\x65\x00\x01\xc2\x00\xff\xf0"),
    (b"\xff\xfa\x2c\x02\x00\xff\xf0", b"\xff\xfa\x2c\x66\x08\xff\xf0"),
    (b"\xff\xfa\x2c\x03\x00\xff\xf0", b"\xff\xfa\x2c\x67\x01\xff\xf0"),
    (b"\xff\xfa\x2c\x04\x00\xff\xf0", b"\xff\xfa\x2c\x68\x01\xff\xf0"),
    (b"\xff\xfa\x2c\x05\x00\xff\xf0", b"\xff\xfa\x2c\x69\x01\xff\xf0"),
    (b"\xff\xfa\x2c\x0b\x80\xff\xf0", b"\xff\xfa\x2c\x6f\x80\xff\xf0"),  # MODEMSTATE-MASK: CD
    (b"\xff\xfa\x2c\x0a\x14\xff\xf0", b"\xff\xfa\x2c\x6e\x14\xff\xf0"),  # LINESTATE-MASK: BREAK, parity error
    # The tty opened: DTR off, 115200, DTR on, no flow control.
    (b"\xff\xfa\x2c\x05\x09\xff\xf0", b"\xff\xfa\x2c\x69\x09\xff\xf0"),
    (b"\xff\xfa\x2c\x01\x00\x01\xc2\x00\xff\xf0", b"\xff\xfa\x2c\x65\x00\x01\xc2\x00\xff\xf0"),
    (b"\xff\xfa\x2c\x05\x08\xff\xf0", b"\xff\xfa\x2c\x69\x08\xff\xf0"),
    (b"\xff\xfa\x2c\x05\x01\xff\xf0", b"\xff\xfa\x2c\x69\x01\xff\xf0"),
    (b"\xff\xfa\x2c\x0c\x01\xff\xf0", b"\xff\xfa\x2c\x70\x01\xff\xf0"),  # PURGE-DATA receive buffer
    # 9600, 7 bits, even parity, hardware and XON/XOFF flow control, 2 stop bits, BREAK on and off.
    (b"\xff\xfa\x2c\x01\x00\x00\x25\x80\xff\xf0", b"\xff\xfa\x2c\x65\x00\x00\x25\x80\xff\xf0"),
    (b"\xff\xfa\x2c\x02\x07\xff\xf0", b"\xff\xfa\x2c\x66\x07\xff\xf0"),
    (b"\xff\xfa\x2c\x03\x03\xff\xf0", b"\xff\xfa\x2c\x67\x03\xff\xf0"),
    (b"\xff\xfa\x2c\x05\x03\xff\xf0", b"\xff\xfa\x2c\x69\x03\xff\xf0"),
    (b"\xff\xfa\x2c\x05\x02\xff\xf0", b"\xff\xfa\x2c\x69\x02\xff\xf0"),
    (b"\xff\xfa\x2c\x04\x02\xff\xf0", b"\xff\xfa\x2c\x68\x02\xff\xf0"),
    (b"\xff\xfa\x2c\x04\x01\xff\xf0", b"\xff\xfa\x2c\x68\x01\xff\xf0"),
    (b"\xff\xfa\x2c\x05\x05\xff\xf0", b"\xff\xfa\x2c\x69\x05\xff\xf0"),
    (b"\xff\xfa\x2c\x05\x06\xff\xf0", b"\xff\xfa\x2c\x69\x06\xff\xf0"),
    (b"\xff\xfa\x2c\x01\x00\x01\xc2\x00\xff\xf0", b"\xff\xfa\x2c\x65\x00\x01\xc2\x00\xff\xf0"),
]

# gensiot 2.6.2 (gensio's telnet(rfc2217) client): its start, then its escape commands.
GENSIOT_REPLAY = [
    # Start: WILL COM-PORT -> our BINARY offers, DO COM-PORT, the modem lines; then it takes BINARY.
    (b"\xff\xfb\x2c", b"\xff\xfb\x00\xff\xfd\x00\xff\xfd\x2c\xff\xfa\x2c\x6b\xb0\xff\xf0"),
    (b"\xff\xfd\x00\xff\xfb\x00", b""),
    # ^] s 9600; ^] e ^] 7 (two requests in one segment); ^] b (Telnet BRK, no answer).
    (b"\xff\xfa\x2c\x01\x00\x00\x25\x80\xff\xf0", b"\xff\xfa\x2c\x65\x00\x00\x25\x80\xff\xf0"),
    (b"\xff\xfa\x2c\x03\x03\xff\xf0\xff\xfa\x2c\x02\x07\xff\xf0",
     b"\xff\xfa\x2c\x67\x03\xff\xf0\xff\xfa\x2c\x66\x07\xff\xf0"),
    (b"\xff\xf3", b""),
    # ^] x, r, f (flow control), 2, 1 (stop bits), o, n (parity), 5, 6, 8 (data size).
    (b"\xff\xfa\x2c\x05\x02\xff\xf0", b"\xff\xfa\x2c\x69\x02\xff\xf0"),
    (b"\xff\xfa\x2c\x05\x03\xff\xf0", b"\xff\xfa\x2c\x69\x03\xff\xf0"),
    (b"\xff\xfa\x2c\x05\x01\xff\xf0", b"\xff\xfa\x2c\x69\x01\xff\xf0"),
    (b"\xff\xfa\x2c\x04\x02\xff\xf0", b"\xff\xfa\x2c\x68\x02\xff\xf0"),
    (b"\xff\xfa\x2c\x04\x01\xff\xf0", b"\xff\xfa\x2c\x68\x01\xff\xf0"),
    (b"\xff\xfa\x2c\x03\x02\xff\xf0", b"\xff\xfa\x2c\x67\x02\xff\xf0"),
    (b"\xff\xfa\x2c\x03\x01\xff\xf0", b"\xff\xfa\x2c\x67\x01\xff\xf0"),
    (b"\xff\xfa\x2c\x02\x05\xff\xf0", b"\xff\xfa\x2c\x66\x05\xff\xf0"),
    (b"\xff\xfa\x2c\x02\x06\xff\xf0", b"\xff\xfa\x2c\x66\x06\xff\xf0"),
    (b"\xff\xfa\x2c\x02\x08\xff\xf0", b"\xff\xfa\x2c\x66\x08\xff\xf0"),
    # ^] d: SIGNATURE, baud, parity, data size, stop size queried in one segment: what it set is told.
    (b"\xff\xfa\x2c\x00\xff\xf0\xff\xfa\x2c\x01\x00\x00\x00\x00\xff\xf0\xff\xfa\x2c\x03\x00\xff\xf0"
     b"\xff\xfa\x2c\x02\x00\xff\xf0\xff\xfa\x2c\x04\x00\xff\xf0",
     b"\xff\xfa\x2c\x64asi-gateway\xff\xf0\xff\xfa\x2c\x65\x00\x00\x25\x80\xff\xf0\xff\xfa\x2c\x67\x01\xff\xf0"
     b"\xff\xfa\x2c\x66\x08\xff\xf0\xff\xfa\x2c\x68\x01\xff\xf0"),
]


def replay(s, chunks, who):
    with socket.create_connection(("127.0.0.1", s.tcp), timeout=REPLY_WAIT) as sock:
        def read_exactly(n):
            data, deadline = b"", time.monotonic() + REPLY_WAIT
            while len(data) < n and time.monotonic() < deadline:
                sock.settimeout(max(0.01, deadline - time.monotonic()))
                try:
                    chunk = sock.recv(n - len(data))
                except socket.timeout:
                    break
                if not chunk:
                    break
                data += chunk
            return data

        for i, (sent, expected) in enumerate(chunks):
            sock.sendall(sent)
            got = read_exactly(len(expected))
            check(got == expected, f"{who} replay, chunk {i} {sent!r}: the gateway answered {got!r}, expected "
                                   f"{expected!r}")
        # Nothing more (a chunk without an answer got none), and then the data path works.
        sock.settimeout(0.5)
        try:
            extra = sock.recv(4096)
        except socket.timeout:
            extra = b""
        check(extra == b"", f"{who} replay: more than the answers: {extra!r}")
        expected = raw(s.c, "W X")
        sock.sendall(b"W X\r")
        got = read_exactly(len(expected))
        check(got == expected, f"{who} replay: W X after the negotiation: {got!r}, expected {expected!r}")
        # The constants agree with the RFC model the live sessions were checked with.
        check_exchange(b"".join(c for c, _ in chunks), b"".join(e for _, e in chunks), f"{who} (recorded)")


def test_replay_cyclades(s):
    replay(s, CYCLADES_REPLAY, "cyclades-ser-cli")


def test_replay_gensiot(s):
    replay(s, GENSIOT_REPLAY, "gensiot")


def test_the_real_link_at_the_end(s):
    s.check_link_unchanged("at the end")
    check(controller(s.c)["state"] == "connected", "the controller is connected")
    version = raw(s.c, "V")
    check(version.startswith(b":A ") and version.endswith(b"\r\n"), f"V: {version!r}")


def print_captures(s):
    for who, (up, down) in s.captures.items():
        print(f"---- {who}: client -> gateway\n{up!r}\n---- gateway -> client\n{down!r}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    ap.add_argument("--sim", required=True)
    ap.add_argument("--openapi", required=True)
    ap.add_argument("--show-bytes", action="store_true", help="print what each client and the gateway sent")
    args = ap.parse_args()
    fx = Fixture("rfc2217-clients-")
    runs = []
    try:
        s = Scene(fx, args)
        cyclades, gensiot = ClientRun(), ClientRun()
        runs = [cyclades, gensiot]
        for name, fn, *a in [
            ("cyclades-ser-cli: an MS-2000 session through its tty", test_cyclades_session, cyclades),
            ("cyclades-ser-cli: every Telnet request answered as RFC 2217 says", test_cyclades_answers, cyclades),
            ("gensiot: an MS-2000 session through its pty", test_gensiot_session, gensiot),
            ("gensiot: every Telnet request answered as RFC 2217 says", test_gensiot_answers, gensiot),
            ("cyclades-ser-cli's recorded negotiation replayed", test_replay_cyclades),
            ("gensiot's recorded negotiation replayed", test_replay_gensiot),
            ("the real link at the end", test_the_real_link_at_the_end),
        ]:
            fx.run(name, fn, s, *a)
        if args.show_bytes or fx.failures:
            print_captures(s)
        fx.finish_log(80)
        return fx.report()
    finally:
        for r in runs:
            if r.agent:
                try:
                    r.agent.close()
                except Exception:  # noqa: BLE001 - cleaning up after a failure
                    pass
            if r.proc and r.proc.poll() is None:
                r.proc.terminate()
                try:
                    r.proc.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    pass
            if r.relay:
                r.relay.stop()
        fx.cleanup()


if __name__ == "__main__":
    run_main(main)
