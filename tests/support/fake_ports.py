"""Pseudo-terminals that are not MS-2000s, for the port probe and the unreachable-controller tests:
a silent one (reads everything, never answers) and a garbage one (answers every write with bytes no
controller sends, the way a device at another baud rate or another kind of device does). Each keeps
its own slave descriptor open (as ms2000-sim does), so its master never sees EIO when a client closes
the port, and puts a symlink to the slave where a test wants it. Standard library only.
"""

import os
import threading
import tty


class FakePort:
    """A pty whose master side is served by a thread; `answer(bytes) -> bytes` decides the reply."""

    def __init__(self, link, answer):
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        self.device = os.ttyname(self.slave)
        self.link = link
        os.makedirs(os.path.dirname(link), exist_ok=True)
        if os.path.lexists(link):
            os.unlink(link)
        os.symlink(self.device, link)
        self.received = bytearray()
        self._answer = answer
        self._stop = False
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _serve(self):
        while not self._stop:
            try:
                data = os.read(self.master, 4096)
            except OSError:
                return
            if not data:
                return
            self.received += data
            reply = self._answer(data)
            if reply:
                try:
                    os.write(self.master, reply)
                except OSError:
                    return

    def close(self):
        self._stop = True
        for fd in (self.slave, self.master):
            try:
                os.close(fd)
            except OSError:
                pass
        if os.path.islink(self.link):
            os.unlink(self.link)


def silent_port(link):
    return FakePort(link, lambda data: b"")


def garbage_port(link):
    # High bytes, a NUL and a CR LF: not ASCII, not an MS-2000 reply, but "an answer".
    return FakePort(link, lambda data: b"\x8f\xfe\x00\xe0\x81garbage\xff\r\n")


def other_device_port(link):
    # A printable answer of another kind of device (a modem's OK).
    return FakePort(link, lambda data: b"OK\r\n" if b"\r" in data else b"")
