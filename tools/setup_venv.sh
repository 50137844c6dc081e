#!/usr/bin/env bash
# setup_venv.sh - build or refresh the project-local ROS 2 Kilted venv, idempotently.
#
# usage: tools/setup_venv.sh          # .venv: ROS wheels + deps, bike_rig_msgs, bike_rig
#        tools/setup_venv.sh --bench  # the above, plus .bench-deps/ (bicycleparameters)
#
# The venv is the ROS prefix (share/, lib/, share/ament_index): bike_rig_msgs is built with
# cmake and installed into it, and bike_rig is installed with `pip install .` so that its
# data_files land in .venv/share. Recipe and numbers: ../shared/notes/ros2-setup.md.
#
# Each step keeps a stamp in .venv/.stamps/<step> holding the hash of its inputs (and of the
# step before it); a step whose stamp matches is skipped, so a run with nothing changed takes
# well under a second. Delete .venv (make clean) to start afresh.
#
# env: PYTHON  interpreter to create the venv with (default python3; measured with 3.11.7)
#      JOBS    parallel cmake build jobs (default: nproc)
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
VENV="$ROOT/.venv"
STAMPS="$VENV/.stamps"
BUILD="$VENV/.build"
BENCH_DEPS="$ROOT/.bench-deps"
PYTHON=${PYTHON:-python3}
JOBS=${JOBS:-$(nproc 2>/dev/null || echo 2)}
REQ=tools/requirements.txt
CONSTRAINTS=tools/constraints.txt
WANT_BENCH=0
case "${1:-}" in
  "") ;;
  --bench) WANT_BENCH=1 ;;
  *) echo "usage: $0 [--bench]" >&2; exit 2 ;;
esac

t0=$(date +%s)
log() { printf '[setup_venv %4ss] %s\n' "$(( $(date +%s) - t0 ))" "$*"; }

# hash of the named files' paths and contents (directories: every file below them, except
# caches); missing paths hash as absent, so adding one later changes the hash.
hash_inputs() {
  local p
  {
    for p in "$@"; do
      if [ -d "$p" ]; then
        find "$p" -type f ! -path '*/__pycache__/*' ! -name '*.pyc' ! -path '*.egg-info/*' \
          -print0 | LC_ALL=C sort -z | xargs -0 -r sha256sum
      elif [ -e "$p" ]; then
        sha256sum "$p"
      else
        echo "absent $p"
      fi
    done
  } | sha256sum | cut -c1-32
}
stamp_ok() { [ -f "$STAMPS/$1" ] && [ "$(cat "$STAMPS/$1")" = "$2" ]; }
stamp_set() { mkdir -p "$STAMPS"; printf '%s\n' "$2" > "$STAMPS/$1"; }

# ---------------------------------------------------------------- 1. the venv itself
# A venv is tied to its absolute path (script shebangs) and to its interpreter: recreate it
# when either changed or when its python no longer runs.
if [ -d "$VENV" ]; then
  if [ "$(cat "$STAMPS/path" 2>/dev/null)" != "$VENV" ] || ! "$VENV/bin/python" -c '' 2>/dev/null; then
    log "removing unusable venv $VENV (moved, or its python is gone)"
    rm -rf "$VENV"
  fi
fi
if [ ! -x "$VENV/bin/python" ]; then
  log "creating venv $VENV with $("$PYTHON" --version 2>&1)"
  timeout 300 "$PYTHON" -m venv "$VENV"
  "$VENV/bin/python" -c 'import sys; sys.version_info[:2] == (3, 11) or print("WARNING: tools/constraints.txt was resolved and tested on CPython 3.11 only", file=sys.stderr)'
  stamp_set path "$VENV"
fi
PIP=("$VENV/bin/python" -m pip --no-input --disable-pip-version-check)

# ---------------------------------------------------------------- 2. pinned wheels
deps_hash=$(hash_inputs "$REQ" "$CONSTRAINTS" tools/setup_venv.sh)
if ! stamp_ok deps "$deps_hash"; then
  log "pip install -r $REQ (ROS 2 Kilted wheels and project deps)"
  timeout 1800 "${PIP[@]}" install -q -c "$CONSTRAINTS" -r "$REQ"

  # The ROS message wheels' *__rosidl_generator_pyExport.cmake files hard-code the manylinux
  # build container's /opt/python/... include dirs; cmake's generate step then fails. Point
  # them at this venv's interpreter and numpy (idempotent; must follow every ros-* install).
  PYINC=$("$VENV/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')
  NPINC=$("$VENV/bin/python" -c 'import numpy; print(numpy.get_include())')
  mapfile -t bad < <(grep -rlE '/opt/python/cp3[0-9]+-cp3[0-9]+' "$VENV/share" --include='*.cmake' || true)
  if [ "${#bad[@]}" -gt 0 ]; then
    log "patching ${#bad[@]} cmake export files: /opt/python/... -> $PYINC, $NPINC"
    sed -i -E \
      -e "s#/opt/python/cp3[0-9]+-cp3[0-9]+/lib/python3\.[0-9]+/site-packages/numpy/_core/include#${NPINC}#g" \
      -e "s#/opt/python/cp3[0-9]+-cp3[0-9]+/include/python3\.[0-9]+#${PYINC}#g" \
      "${bad[@]}"
  fi
  "${PIP[@]}" check
  stamp_set deps "$deps_hash"
fi

export AMENT_PREFIX_PATH="$VENV" CMAKE_PREFIX_PATH="$VENV"

# ---------------------------------------------------------------- 3. bike_rig_msgs (cmake)
msgs_hash=$(printf '%s\n' "$deps_hash" "$(hash_inputs bike_rig_msgs)" | sha256sum | cut -c1-32)
if ! stamp_ok msgs "$msgs_hash"; then
  MSGS_BUILD="$BUILD/bike_rig_msgs"
  mkdir -p "$MSGS_BUILD"
  # Remove what the previous build installed, so that a deleted .msg does not linger.
  if [ -f "$MSGS_BUILD/install_manifest.txt" ]; then
    xargs -r -d '\n' rm -f < "$MSGS_BUILD/install_manifest.txt"
  fi
  log "cmake configure bike_rig_msgs"
  timeout 600 cmake -S bike_rig_msgs -B "$MSGS_BUILD" \
    -DCMAKE_INSTALL_PREFIX="$VENV" \
    -DPython3_EXECUTABLE="$VENV/bin/python" \
    -DBUILD_TESTING=OFF > "$MSGS_BUILD/configure.log" 2>&1 \
    || { tail -40 "$MSGS_BUILD/configure.log"; echo "cmake configure failed: $MSGS_BUILD/configure.log" >&2; exit 1; }
  log "cmake build bike_rig_msgs -j$JOBS"
  timeout 1800 cmake --build "$MSGS_BUILD" -j"$JOBS" > "$MSGS_BUILD/build.log" 2>&1 \
    || { tail -40 "$MSGS_BUILD/build.log"; echo "cmake build failed: $MSGS_BUILD/build.log" >&2; exit 1; }
  timeout 600 cmake --install "$MSGS_BUILD" > "$MSGS_BUILD/install.log" 2>&1 \
    || { tail -40 "$MSGS_BUILD/install.log"; echo "cmake install failed: $MSGS_BUILD/install.log" >&2; exit 1; }
  "$VENV/bin/python" -c 'import bike_rig_msgs.msg'
  log "installed bike_rig_msgs into $VENV"
  stamp_set msgs "$msgs_hash"
fi

# ---------------------------------------------------------------- 4. bike_rig (pip install .)
pkg_hash=$(printf '%s\n' "$msgs_hash" \
  "$(hash_inputs setup.py setup.cfg package.xml resource config bike_rig)" | sha256sum | cut -c1-32)
if ! stamp_ok pkg "$pkg_hash"; then
  log "pip install . (bike_rig)"
  # setuptools builds in the source tree; a stale build/lib would put deleted modules back
  # into the wheel, so build from a clean slate and leave no egg-info behind.
  rm -rf build/lib build/bdist.* bike_rig.egg-info
  timeout 600 "${PIP[@]}" install -q --no-deps --no-build-isolation --force-reinstall . \
    || { rm -rf build/lib build/bdist.* bike_rig.egg-info; exit 1; }
  rm -rf build/lib build/bdist.* bike_rig.egg-info
  rmdir build 2>/dev/null || true
  stamp_set pkg "$pkg_hash"
fi

# ---------------------------------------------------------------- 5. benchmark-only deps
if [ "$WANT_BENCH" = 1 ]; then
  bench_hash=$(printf '%s\n' "$deps_hash" "$(hash_inputs tools/requirements-bench.txt)" | sha256sum | cut -c1-32)
  if ! stamp_ok bench "$bench_hash" || [ ! -d "$BENCH_DEPS" ]; then
    log "pip install --target .bench-deps -r tools/requirements-bench.txt"
    rm -rf "$BENCH_DEPS"
    timeout 900 "${PIP[@]}" install -q --no-deps --target "$BENCH_DEPS" \
      -c "$CONSTRAINTS" -r tools/requirements-bench.txt
    # their other requirements must be met by .venv: check the combined environment
    PYTHONPATH="$BENCH_DEPS" "${PIP[@]}" check
    PYTHONPATH="$BENCH_DEPS" MPLBACKEND=Agg "$VENV/bin/python" -c 'import bicycleparameters'
    stamp_set bench "$bench_hash"
  fi
fi
log "venv up to date: $VENV"
