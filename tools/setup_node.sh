#!/usr/bin/env bash
# setup_node.sh - install the official Foxglove WebSocket client for the tests, idempotently.
#
# usage: tools/setup_node.sh
#
# test/nodes/test_foxglove_relay.py drives `bike-rig view`'s server with @foxglove/ws-protocol
# (the client the Foxglove app's older releases and Lichtblick are built on), run by Node from
# test/support/js. This script runs `npm ci` there (the versions of its package-lock.json) when
# node_modules is missing or older than the lock file, and does nothing otherwise. Without node
# and npm it says so and exits 0: those tests are then skipped with the reason.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../test/support/js"
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
  echo "setup_node: node/npm not found: the official Foxglove client's tests will be skipped" >&2
  exit 0
fi
stamp=node_modules/.package-lock.json
if [[ -f $stamp && $stamp -nt package-lock.json ]]; then
  exit 0
fi
echo "[setup_node] npm ci in test/support/js (@foxglove/ws-protocol, ws)"
npm ci --no-audit --no-fund --loglevel=error
