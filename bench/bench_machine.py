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


def publish_section(title, script, details, load_before, load_after, text, met, results_path, verdict=None):
    """Prints a RESULTS.md section (title with the run's time, machine and load, the details line,
    the tables, the verdict: "Goals met." or not, or `verdict` for a measurement without goals) and
    appends it to `results_path` when given. Returns the exit code: 0 when the goals were met."""
    import datetime

    when = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    section = (f"## {title} ({script}, run of {when})\n\n"
               f"{machine_line()}; load average {load_before[0]:.1f} before, {load_after[0]:.1f} after. "
               f"{details}\n\n{text}\n\n{verdict or ('Goals met.' if met else 'Goals NOT met.')}\n")
    print()
    print(section)
    if results_path:
        with open(results_path, "a") as f:
            f.write("\n" + section)
        print(f"appended the section to {results_path}")
    return 0 if met else 1
