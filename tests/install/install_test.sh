#!/usr/bin/env bash
# cmake --install into temporary DESTDIRs: every file in its place, the systemd unit pointing at the
# installed binary and config, the installed binaries running, an edited config kept on reinstall, the
# "gateway" component alone (what docker/Dockerfile installs) without the unit, and, where
# systemd-analyze exists, the unit verified and its hardening kept.
#   install_test.sh CMAKE BUILD_DIR SOURCE_DIR
set -euo pipefail
cmake=$1 build=$2 src=$3

failures=0 passes=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }
pass() { echo "ok: $*"; passes=$((passes + 1)); }
check() {  # check DESCRIPTION COMMAND...: passes when the command succeeds
  local what=$1; shift
  if "$@"; then pass "$what"; else fail "$what"; fi
}

scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT

install_to() {  # install_to DESTDIR PREFIX [cmake --install options]
  local dest=$1 prefix=$2; shift 2
  DESTDIR=$dest "$cmake" --install "$build" --prefix "$prefix" "$@" >"$scratch/install.log" 2>&1 \
    || { cat "$scratch/install.log" >&2; fail "cmake --install --prefix $prefix $*"; return 1; }
}

# A key's value in the unit: the last assignment wins, as in systemd.
unit_value() { sed -n "s/^$2=//p" "$1" | tail -n 1; }

json_value() {  # json_value FILE KEY.SUBKEY: the value, with Debian's python3
  /usr/bin/python3 -c 'import json, sys
v = json.load(open(sys.argv[1]))
for k in sys.argv[2].split("."): v = v[k]
print(v)' "$1" "$2"
}

stores_in_state_directory() {  # stores_in_state_directory GATEWAY CONFIG: runs it as systemd would
  local state="$scratch/state" log="$scratch/run.log" pid ok=1
  rm -rf "$state"
  STATE_DIRECTORY=$state "$1" --config "$2" --port 0 >"$log" 2>&1 &
  pid=$!
  for _ in $(seq 100); do  # the start-up line names the storage; the store file follows it
    if grep -q "serving .*(storage $state;" "$log" && [ -f "$state/jobs.sqlite3" ]; then ok=0; break; fi
    sleep 0.1
  done
  kill "$pid" 2>/dev/null; wait "$pid" 2>/dev/null || true
  [ $ok -eq 0 ] || { echo "  the gateway's log:"; sed 's/^/    /' "$log" | tail -5; }
  return $ok
}

check_prefix() {  # check_prefix PREFIX SYSCONFDIR
  local prefix=$1 etc=$2 dest="$scratch/root${1//\//_}"
  install_to "$dest" "$prefix" || return 0
  local bin="$prefix/bin" share="$prefix/share/asi-gateway" unit="$dest$prefix/lib/systemd/system/asi-gateway.service"
  for f in "$bin/asi-gateway" "$bin/ms2000-sim"; do
    check "$prefix: $f is executable" test -x "$dest$f"
  done
  check "$prefix: openapi.yaml installed unchanged" cmp -s "$src/openapi/openapi.yaml" "$dest$share/openapi.yaml"
  check "$prefix: asyncapi.yaml installed unchanged" cmp -s "$src/openapi/asyncapi.yaml" "$dest$share/asyncapi.yaml"
  check "$prefix: example config in $share" \
    cmp -s "$src/scripts/systemd/asi-gateway.example.json" "$dest$share/asi-gateway.example.json"
  check "$prefix: config in $etc/asi-gateway" \
    cmp -s "$src/scripts/systemd/asi-gateway.example.json" "$dest$etc/asi-gateway/asi-gateway.json"
  check "$prefix: config readable by owner and group only (0640)" \
    test "$(stat -c %a "$dest$etc/asi-gateway/asi-gateway.json")" = 640
  check "$prefix: sysusers.d entry for user asi-gateway" \
    grep -q '^u asi-gateway ' "$dest$prefix/lib/sysusers.d/asi-gateway.conf"
  check "$prefix: unit installed" test -f "$unit"
  [ -f "$unit" ] || return 0

  # The unit runs the installed binary on the installed config.
  local exec
  exec=$(unit_value "$unit" ExecStart)
  check "$prefix: ExecStart=$exec" \
    test "$exec" = "$bin/asi-gateway --config $etc/asi-gateway/asi-gateway.json"
  check "$prefix: unit has no placeholder left" bash -c '! grep -q "@GW_[A-Z]*@" "$1"' _ "$unit"
  check "$prefix: SupplementaryGroups=dialout" test "$(unit_value "$unit" SupplementaryGroups)" = dialout
  check "$prefix: StateDirectory=asi-gateway" test "$(unit_value "$unit" StateDirectory)" = asi-gateway
  check "$prefix: RuntimeDirectory=asi-gateway (shared pty links)" \
    test "$(unit_value "$unit" RuntimeDirectory)" = asi-gateway
  check "$prefix: Restart=on-failure" test "$(unit_value "$unit" Restart)" = on-failure
  check "$prefix: User=asi-gateway, the sysusers.d user" test "$(unit_value "$unit" User)" = asi-gateway
  # The job store is the state directory systemd creates and exports as $STATE_DIRECTORY: the config
  # names none, and the installed gateway on the installed config stores its jobs there.
  check "$prefix: the config leaves the storage to systemd" \
    bash -c '! grep -q "\"storage\"" "$1"' _ "$dest$etc/asi-gateway/asi-gateway.json"
  check "$prefix: the installed gateway stores its jobs in \$STATE_DIRECTORY" \
    stores_in_state_directory "$dest$bin/asi-gateway" "$dest$etc/asi-gateway/asi-gateway.json"
  # The installed gateway accepts the installed config.
  check "$prefix: installed asi-gateway --check-config on the installed config" \
    test "$("$dest$bin/asi-gateway" --check-config "$dest$etc/asi-gateway/asi-gateway.json" 2>"$scratch/check.err")" = ok
  # Its example controller is not plugged in here: a warning, not an error (it may be plugged in later).
  check "$prefix: --check-config warns that the example's serial port is not there now" \
    grep -q "controllers\[0\].port: .* does not exist now" "$scratch/check.err"
  check "$prefix: installed ms2000-sim --help" "$dest$bin/ms2000-sim" --help >/dev/null

  # An admin's edit survives a reinstall; the pristine example stays in share/.
  echo '{"http": {"port": 8181}}' >"$dest$etc/asi-gateway/asi-gateway.json"
  install_to "$dest" "$prefix" || return 0
  check "$prefix: reinstall keeps the edited config" \
    test "$(json_value "$dest$etc/asi-gateway/asi-gateway.json" http.port)" = 8181
  check "$prefix: reinstall reports the kept config" grep -q "Kept: .*asi-gateway.json" "$scratch/install.log"

  if command -v systemd-analyze >/dev/null; then
    # verify checks that ExecStart is executable, so a copy points into DESTDIR; any warning
    # (an unknown key, a bad DeviceAllow=) fails too, though systemd-analyze exits 0 on them.
    local copy="$scratch/asi-gateway.service" out
    sed "s#=$bin/#=$dest$bin/#; s# $etc/# $dest$etc/#" "$unit" >"$copy"
    if out=$(systemd-analyze verify --man=no "$copy" 2>&1) && [ -z "$out" ]; then
      pass "$prefix: systemd-analyze verify"
    else
      fail "$prefix: systemd-analyze verify: $out"
    fi
    # The hardening stays: the exposure score (0 best, 10 worst) of the offline security review.
    local exposure
    exposure=$(systemd-analyze security --offline=yes --man=no "$copy" 2>/dev/null |
      sed -n 's/.*Overall exposure level for asi-gateway.service: \([0-9.]*\).*/\1/p')
    check "$prefix: systemd-analyze security exposure ${exposure:-?} <= 2.0" \
      awk -v e="${exposure:-99}" 'BEGIN { exit !(e <= 2.0) }'
  else
    echo "skipped: systemd-analyze not installed"
  fi
}

check_prefix /usr /etc
check_prefix /usr/local /usr/local/etc

# The "gateway" component alone: binaries and API documents, nothing of systemd's.
dest="$scratch/component"
if install_to "$dest" /usr --component gateway; then
  check "component gateway: asi-gateway" test -x "$dest/usr/bin/asi-gateway"
  check "component gateway: openapi.yaml" test -f "$dest/usr/share/asi-gateway/openapi.yaml"
  check "component gateway: no unit" test ! -e "$dest/usr/lib/systemd/system/asi-gateway.service"
  check "component gateway: no config" test ! -e "$dest/etc"
fi

echo "install test: $passes passed, $failures failed"
[ "$failures" -eq 0 ]
