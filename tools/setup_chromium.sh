#!/usr/bin/env bash
# setup_chromium.sh - install Debian's `chromium` package for the report's render test, idempotently.
#
# usage: tools/setup_chromium.sh
#
# test/report/test_report_chromium.py opens the HTML report in headless Chromium
# (/usr/bin/chromium) and checks that every figure loads. With /usr/bin/chromium present this
# script does nothing. Otherwise it runs `apt-get install -y --no-install-recommends chromium`
# (as root, or through sudo when not root), and `apt-get update` first only when the install
# fails because the package lists are missing or stale.
#
# env: CHROMIUM  the binary to check for (default /usr/bin/chromium)
set -euo pipefail

CHROMIUM=${CHROMIUM:-/usr/bin/chromium}
t0=$(date +%s)
log() { printf '[setup_chromium %4ss] %s\n' "$(( $(date +%s) - t0 ))" "$*"; }
fail() { echo "setup_chromium: error: $*" >&2; exit 1; }

if [[ -x "$CHROMIUM" ]]; then
  exit 0
fi

command -v apt-get >/dev/null 2>&1 \
  || fail "$CHROMIUM is missing and apt-get is not available; install Chromium by hand (Debian package 'chromium')"

SUDO=()
if [[ $(id -u) -ne 0 ]]; then
  if command -v sudo >/dev/null 2>&1; then
    SUDO=(sudo)
  else
    fail "$CHROMIUM is missing; installing it needs root, and sudo is not available (run: apt-get install chromium as root)"
  fi
fi

export DEBIAN_FRONTEND=noninteractive
# wait (up to 5 min) for another apt/dpkg run to release its lock instead of failing at once
APT=(apt-get -o DPkg::Lock::Timeout=300)
install() { "${SUDO[@]}" "${APT[@]}" install -y --no-install-recommends chromium; }

log "installing Debian's chromium (apt-get install --no-install-recommends chromium)"
out=$(mktemp)
trap 'rm -f "$out"' EXIT
if ! install >"$out" 2>&1; then
  if grep -qE "Unable to locate package|has no installation candidate|Failed to fetch|404 +Not Found" "$out"; then
    log "package lists missing or stale: apt-get update, then install again"
    "${SUDO[@]}" "${APT[@]}" update >"$out" 2>&1 || { tail -n 20 "$out" >&2; fail "apt-get update failed"; }
    install >"$out" 2>&1 || { tail -n 20 "$out" >&2; fail "apt-get install chromium failed"; }
  else
    tail -n 20 "$out" >&2
    fail "apt-get install chromium failed"
  fi
fi

[[ -x "$CHROMIUM" ]] || fail "apt-get installed chromium but $CHROMIUM is not there"
log "installed $("$CHROMIUM" --version 2>/dev/null || echo "$CHROMIUM")"
