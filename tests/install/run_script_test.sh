#!/usr/bin/env bash
# scripts/run (the README's command that runs the service) execs the gateway from the build tree: the
# path it names under build/ must be the file the build makes for the asi-gateway target.
#   run_script_test.sh SOURCE_DIR BINARY_DIR TARGET_FILE
set -euo pipefail
src=$1 bin_dir=$2 target=$3
path=$(sed -n 's|^exec build/\([^ "]*\).*|\1|p' "$src/scripts/run")
if [ -z "$path" ]; then
  echo "FAIL: scripts/run execs nothing under build/"
  exit 1
fi
if ! [ "$bin_dir/$path" -ef "$target" ]; then
  echo "FAIL: scripts/run runs build/$path, but the build makes $target"
  exit 1
fi
echo "ok: scripts/run runs build/$path, the gateway the build makes"
