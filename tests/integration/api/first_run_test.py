#!/usr/bin/env python3
"""First run: the flags people change most, where the jobs go by default, and the start-up line.

The real asi-gateway started as a user would (no config file, or a small one), each time with its own
environment and working directory:
  --version            prints the version that GET /api/v1/health reports;
  --listen/--port/--storage   override the config, and the start-up line names the URL, the absolute
                       storage directory and every controller's port;
  default storage      $STATE_DIRECTORY, else $XDG_STATE_HOME/asi-gateway, else
                       ~/.local/state/asi-gateway; never the working directory;
  config storage.path  relative to the config file, not to the working directory;
  bad flags            a clear message and exit code 2, nothing served.
Debian's /usr/bin/python3, standard library only.
"""

import argparse
import json
import os
import re
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gateway_fixture import WAIT, Failure, Fixture, check, free_port, http_request, wait_until  # noqa: E402


def start(fx, gateway, args, env, cwd):
    """Starts the gateway with `args` in `cwd` with exactly `env`; waits for health; returns (proc, log)."""
    log_path = os.path.join(fx.tmp, f"gateway-{len(fx.procs)}.log")
    log = open(log_path, "w")
    proc = subprocess.Popen([gateway, *args], env=env, cwd=cwd, stdout=log, stderr=subprocess.STDOUT)
    fx.procs.append(proc)
    port = int(args[args.index("--port") + 1])

    def healthy():
        if proc.poll() is not None:
            raise Failure(f"exited with {proc.returncode}: {open(log_path).read()[-1500:]}")
        return http_request(port, "GET", "/api/v1/health", token=None)[0] == 200

    wait_until("health", healthy)
    return proc, log_path


def stop(proc):
    proc.terminate()
    check(proc.wait(timeout=WAIT) == 0, f"SIGTERM exit code {proc.returncode}")


def base_env(**extra):
    env = {"PATH": "/usr/bin:/bin"}
    env.update(extra)
    return env


def serving_line(log_path):
    """The start-up line's URL, storage and controllers, once it is written."""
    def find():
        m = re.search(r"asi-gateway (\S+) serving (\S+) \(storage (.+?); controllers: (.+?)\)\s*$",
                      open(log_path).read(), re.M)
        return m.groups() if m else None
    return wait_until("the start-up line", find)


def test_version(gateway):
    out = subprocess.run([gateway, "--version"], capture_output=True, text=True, timeout=WAIT)
    check(out.returncode == 0, f"--version exit {out.returncode}: {out.stderr}")
    m = re.fullmatch(r"asi-gateway (\d+\.\d+\.\d+)\n", out.stdout)
    check(m, f"--version printed {out.stdout!r}")
    return m.group(1)


def test_flags_and_startup_line(fx, gateway, version):
    port = free_port()
    store = os.path.join(fx.tmp, "flag-store")
    cwd = os.path.join(fx.tmp, "cwd1")
    os.makedirs(cwd)
    # --storage is relative to the working directory, like every path on a command line.
    proc, log = start(fx, gateway, ["--simulate", "2", "--listen", "127.0.0.1", "--port", str(port),
                                    "--storage", "../flag-store", "--sim-dir", os.path.join(fx.tmp, "sims1")],
                      base_env(HOME=os.path.join(fx.tmp, "home-unused")), cwd)
    status, body = http_request(port, "GET", "/api/v1/health", token=None)
    check(status == 200 and json.loads(body) == {"status": "ok", "version": version, "mqtt": None},
          f"health (MQTT off): {status} {body}")
    v, url, storage, controllers = serving_line(log)
    check(v == version, f"start-up line version {v}")
    check(url == f"http://127.0.0.1:{port}/", f"URL {url}")
    check(storage == store, f"storage {storage} (expected {store})")
    check(controllers == f"sim1 on {fx.tmp}/sims1/sim1/port shared at pty {fx.tmp}/sims1/sim1/share, "
          f"sim2 on {fx.tmp}/sims1/sim2/port shared at pty {fx.tmp}/sims1/sim2/share", f"controllers {controllers}")
    check(os.path.exists(os.path.join(store, "jobs.sqlite3")), "no jobs.sqlite3 in --storage")
    stop(proc)
    check(not os.path.exists(os.path.join(fx.tmp, "home-unused")), "--storage given, yet HOME was used")


def default_storage_case(fx, gateway, name, env, expected):
    port = free_port()
    cwd = os.path.join(fx.tmp, "cwd-" + name)
    os.makedirs(cwd)
    proc, log = start(fx, gateway, ["--simulate", "1", "--port", str(port), "--sim-dir",
                                    os.path.join(fx.tmp, "sims-" + name)], env, cwd)
    _, _, storage, _ = serving_line(log)
    check(storage == expected, f"{name}: storage {storage} (expected {expected})")
    check(os.path.exists(os.path.join(expected, "jobs.sqlite3")), f"{name}: no jobs.sqlite3 in {expected}")
    stop(proc)
    check(os.listdir(cwd) == [], f"{name}: the working directory got {os.listdir(cwd)}")


def test_default_storage(fx, gateway):
    home = os.path.join(fx.tmp, "home")
    default_storage_case(fx, gateway, "home", base_env(HOME=home),
                         os.path.join(home, ".local", "state", "asi-gateway"))
    xdg = os.path.join(fx.tmp, "xdg")
    default_storage_case(fx, gateway, "xdg", base_env(HOME=home, XDG_STATE_HOME=xdg),
                         os.path.join(xdg, "asi-gateway"))
    state = os.path.join(fx.tmp, "systemd-state")
    default_storage_case(fx, gateway, "systemd", base_env(HOME=home, XDG_STATE_HOME=xdg, STATE_DIRECTORY=state),
                         state)


def test_config_storage_is_relative_to_the_file(fx, gateway):
    conf_dir = os.path.join(fx.tmp, "etc")
    os.makedirs(conf_dir)
    port = free_port()
    cfg = os.path.join(conf_dir, "gateway.json")
    with open(cfg, "w") as f:
        json.dump({"http": {"port": port}, "simulate": {"count": 1, "directory": os.path.join(fx.tmp, "sims-c")},
                   "storage": {"path": "jobs"}}, f)
    cwd = os.path.join(fx.tmp, "cwd-config")
    os.makedirs(cwd)
    # --port repeats the file's port so start() knows it; the file decides the storage.
    proc, log = start(fx, gateway, ["--config", cfg, "--port", str(port)], base_env(HOME=fx.tmp), cwd)
    _, _, storage, _ = serving_line(log)
    check(storage == os.path.join(conf_dir, "jobs"), f"storage {storage}")
    stop(proc)


def test_bad_flags(fx, gateway):
    cases = [
        (["--listen", "not-an-address"], "is not an IPv4 or IPv6 address"),
        (["--listen", "0.0.0.0"], "is not a loopback address, which needs auth.tokens"),
        (["--port", "70000"], "--port"),
    ]
    for args, message in cases:
        out = subprocess.run([gateway, "--simulate", "1", *args, "--storage", os.path.join(fx.tmp, "bad")],
                             capture_output=True, text=True, timeout=WAIT, env=base_env(HOME=fx.tmp))
        check(out.returncode == 2 and message in out.stderr + out.stdout,
              f"{args}: exit {out.returncode}, {out.stderr.strip()!r}")
    out = subprocess.run([gateway, "--simulate", "1", "--port", "0"], capture_output=True, text=True,
                         timeout=WAIT, env={"PATH": "/usr/bin:/bin"}, cwd=fx.tmp)
    check(out.returncode == 2 and "give --storage DIR" in out.stderr,
          f"no HOME: exit {out.returncode}, {out.stderr.strip()!r}")


def test_tokens(fx, gateway):
    # `token new` makes a token and the entry with its hash; a gateway with only that entry takes the
    # token, and nothing in its config is the token.
    made = {}
    for name, role in (("scheduler", "operator"), ("dash", "viewer")):
        out = subprocess.run([gateway, "token", "new", "--name", name, "--role", role, "--json"],
                             capture_output=True, text=True, timeout=WAIT, env=base_env(HOME=fx.tmp))
        check(out.returncode == 0, f"token new: exit {out.returncode}, {out.stderr.strip()!r}")
        made[name] = json.loads(out.stdout)
        check(len(made[name]["token"]) == 43 and len(made[name]["token_sha256"]) == 64, f"token new: {out.stdout}")
    check(made["scheduler"]["token"] != made["dash"]["token"], "two tokens alike")
    text = subprocess.run([gateway, "token", "new", "--name", "expert", "--role", "admin"], capture_output=True,
                          text=True, timeout=WAIT).stdout
    check('"token_sha256": "' in text and '"role": "admin"' in text, f"token new without --json: {text!r}")
    port = free_port()
    cfg = os.path.join(fx.tmp, "tokens.json")
    entries = [{k: m[k] for k in ("name", "role", "token_sha256")} for m in made.values()]
    with open(cfg, "w") as f:
        json.dump({"http": {"port": port}, "simulate": {"count": 1, "directory": os.path.join(fx.tmp, "sims-t")},
                   "storage": {"path": "jobs-t"}, "auth": {"tokens": entries}}, f)
    with open(cfg) as f:
        check(made["scheduler"]["token"] not in f.read(), "the config holds the token")
    proc, _ = start(fx, gateway, ["--config", cfg, "--port", str(port)], base_env(HOME=fx.tmp), fx.tmp)
    status, body = http_request(port, "GET", "/api/v1/whoami", token=made["scheduler"]["token"])
    check(status == 200 and json.loads(body)["role"] == "operator", f"whoami: {status} {body}")
    status, _ = http_request(port, "GET", "/api/v1/whoami", token=made["scheduler"]["token_sha256"])
    check(status == 401, f"the hash is not a token: {status}")
    stop(proc)
    # The documentation's placeholders and guessable tokens are refused before anything starts.
    for token, message in (("change-me-operator-token", "is a placeholder"),
                           ("0123456789abcdef", "is too easy to guess")):
        with open(cfg, "w") as f:
            json.dump({"auth": {"tokens": [{"name": "x", "token": token, "role": "operator"}]}}, f)
        out = subprocess.run([gateway, "--check-config", cfg], capture_output=True, text=True, timeout=WAIT)
        check(out.returncode == 2 and "auth.tokens[0].token: " + message in out.stdout + out.stderr,
              f"{token}: exit {out.returncode}, {(out.stdout + out.stderr).strip()!r}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gateway", required=True)
    args = ap.parse_args()
    args.gateway = os.path.abspath(args.gateway)  # the tests start it from other working directories
    fx = Fixture("gw-first-run-")
    try:
        found = []
        fx.run("--version prints the version", lambda: found.append(test_version(args.gateway)))
        version = found[0] if found else "?"
        fx.run("--listen, --port, --storage and the start-up line", test_flags_and_startup_line, fx, args.gateway,
               version)
        fx.run("default storage: HOME, XDG_STATE_HOME, STATE_DIRECTORY", test_default_storage, fx, args.gateway)
        fx.run("a config's storage.path is relative to the file", test_config_storage_is_relative_to_the_file, fx,
               args.gateway)
        fx.run("bad flags: a message and exit 2", test_bad_flags, fx, args.gateway)
        fx.run("token new: a token that works, a config that keeps only its hash; weak ones refused", test_tokens,
               fx, args.gateway)
    finally:
        fx.cleanup()
    return fx.report()


if __name__ == "__main__":
    sys.exit(main())
