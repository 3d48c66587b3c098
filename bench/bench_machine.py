"""The machine a benchmark ran on, for bench/RESULTS.md: CPU model, cores, Debian version, architecture.
Standard library only (Debian's /usr/bin/python3)."""

import os
import platform
import subprocess


def machine_line():
    """'Intel(R) Xeon(R) ..., 2 cores, Debian 12.8, x86_64'"""
    model = "?"
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, check=False).stdout
        for line in out.splitlines():
            if line.startswith("Model name:"):
                model = line.split(":", 1)[1].strip()
    except OSError:
        pass
    try:
        with open("/etc/debian_version") as f:
            debian = f.read().strip()
    except OSError:
        debian = "?"
    return f"{model}, {os.cpu_count()} cores, Debian {debian}, {platform.machine()}"
