"""An ms2000-sim process for the benchmarks: one simulated controller on a pty, its symlink at
WORKDIR/NAME/port. Standard library only (Debian's /usr/bin/python3)."""

import os
import subprocess
import time


def wait_for_path(path, proc, what, timeout=10):
    deadline = time.monotonic() + timeout
    while not os.path.exists(path):
        if proc.poll() is not None or time.monotonic() > deadline:
            raise RuntimeError(f"{what} did not start")
        time.sleep(0.05)


class Sim:
    def __init__(self, binary, workdir, name, baud):
        self.link = os.path.join(workdir, name, "port")
        self.proc = subprocess.Popen([binary, "--preset", "plain", "--name", name, "--link", self.link,
                                      "--baud", str(baud)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        wait_for_path(self.link, self.proc, f"ms2000-sim {name}")

    def stop(self):
        self.proc.terminate()
        self.proc.wait(10)
