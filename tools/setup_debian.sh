#!/usr/bin/env bash
# setup_debian.sh - install the Debian packages the tests drive, idempotently.
#
# usage: tools/setup_debian.sh
#
# * chromium (/usr/bin/chromium): test/report/test_report_chromium.py opens the HTML report in
#   headless Chromium and checks that every figure loads;
# * tmux (/usr/bin/tmux): the operator console (`bike-rig session`) is tested as a person uses
#   it, under tmux (send-keys, capture-pane).
#
# With every binary present this script does nothing. Otherwise it runs
# `apt-get install -y --no-install-recommends <the missing packages>` (as root, or through sudo
# when not root), and `apt-get update` first only when the install fails because the package
# lists are missing or stale.
#
# env: CHROMIUM  the chromium binary to check for (default /usr/bin/chromium)
#      TMUX_BIN  the tmux binary to check for (default /usr/bin/tmux)
set -euo pipefail

CHROMIUM=${CHROMIUM:-/usr/bin/chromium}
TMUX_BIN=${TMUX_BIN:-/usr/bin/tmux}
t0=$(date +%s)
log() { printf '[setup_debian %4ss] %s\n' "$(( $(date +%s) - t0 ))" "$*"; }
fail() { echo "setup_debian: error: $*" >&2; exit 1; }

declare -A WANT=([chromium]="$CHROMIUM" [tmux]="$TMUX_BIN")
MISSING=()
for pkg in chromium tmux; do
  [[ -x "${WANT[$pkg]}" ]] || MISSING+=("$pkg")
done
if [[ ${#MISSING[@]} -eq 0 ]]; then
  exit 0
fi

command -v apt-get >/dev/null 2>&1 \
  || fail "${MISSING[*]} missing and apt-get is not available; install the Debian packages by hand: ${MISSING[*]}"

SUDO=()
if [[ $(id -u) -ne 0 ]]; then
  if command -v sudo >/dev/null 2>&1; then
    SUDO=(sudo)
  else
    fail "${MISSING[*]} missing; installing needs root, and sudo is not available (run: apt-get install ${MISSING[*]} as root)"
  fi
fi

export DEBIAN_FRONTEND=noninteractive
# wait (up to 5 min) for another apt/dpkg run to release its lock instead of failing at once
APT=(apt-get -o DPkg::Lock::Timeout=300)
install() { "${SUDO[@]}" "${APT[@]}" install -y --no-install-recommends "${MISSING[@]}"; }

log "installing Debian's ${MISSING[*]} (apt-get install --no-install-recommends)"
out=$(mktemp)
trap 'rm -f "$out"' EXIT
if ! install >"$out" 2>&1; then
  if grep -qE "Unable to locate package|has no installation candidate|Failed to fetch|404 +Not Found" "$out"; then
    log "package lists missing or stale: apt-get update, then install again"
    "${SUDO[@]}" "${APT[@]}" update >"$out" 2>&1 || { tail -n 20 "$out" >&2; fail "apt-get update failed"; }
    install >"$out" 2>&1 || { tail -n 20 "$out" >&2; fail "apt-get install ${MISSING[*]} failed"; }
  else
    tail -n 20 "$out" >&2
    fail "apt-get install ${MISSING[*]} failed"
  fi
fi

for pkg in "${MISSING[@]}"; do
  [[ -x "${WANT[$pkg]}" ]] || fail "apt-get installed $pkg but ${WANT[$pkg]} is not there"
done
log "installed ${MISSING[*]}"
