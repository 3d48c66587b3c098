"""A TCP link on loopback that a test can cut and mend, to take a network path away the way a
cable or a router does: cut() closes every connection through it and refuses new ones (each is
accepted and closed at once), mend() lets them through again. Between two real programs, such as a
mosquitto bridge and the broker it bridges to, which cannot be told to lose their link on demand.
Standard library only (Debian's python3).
"""

import socket
import threading


class LinkCutter:
    def __init__(self, target_port, host="127.0.0.1"):
        self.target = (host, target_port)
        self.listener = socket.create_server((host, 0))
        self.port = self.listener.getsockname()[1]
        self.lock = threading.Lock()
        self.sockets = set()
        self.up = True
        self.closed = False
        threading.Thread(target=self._accept, name="link-cutter", daemon=True).start()

    def _accept(self):
        while True:
            try:
                client, _ = self.listener.accept()
            except OSError:
                return  # closed
            with self.lock:
                up = self.up and not self.closed
            if not up:
                client.close()
                continue
            try:
                upstream = socket.create_connection(self.target, timeout=5)
            except OSError:
                client.close()
                continue
            upstream.settimeout(None)
            with self.lock:
                self.sockets.update((client, upstream))
            for a, b in ((client, upstream), (upstream, client)):
                threading.Thread(target=self._pipe, args=(a, b), daemon=True).start()

    def _pipe(self, src, dst):
        try:
            while data := src.recv(65536):
                dst.sendall(data)
        except OSError:
            pass
        for s in (src, dst):
            self._close(s)

    def _close(self, s):
        with self.lock:
            self.sockets.discard(s)
        try:
            s.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        s.close()

    def cut(self):
        """Closes every connection through the link and refuses new ones until mend()."""
        with self.lock:
            self.up = False
            live = list(self.sockets)
        for s in live:
            self._close(s)

    def mend(self):
        with self.lock:
            self.up = True

    def close(self):
        with self.lock:
            self.closed = True
        self.cut()
        self.listener.close()
