#!/usr/bin/env bash
# README command 1: install what is missing, build in Release, start lapdissect on the
# bundled default curriculum with an embedded SQLite database in the user's data folder.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
export CCACHE_BASEDIR="$(pwd)" CCACHE_NOHASHDIR=1
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DLD_BUILD_TESTS=OFF -DLD_BUILD_BENCHMARKS=OFF "${launcher[@]}" >/dev/null
cmake --build build -j"$(nproc)" --target lapdissect lapdissect-cli
if [ -z "${DISPLAY:-}" ] && [ -z "${WAYLAND_DISPLAY:-}" ]; then
  echo "run.sh: no display; starting lapdissect under Xvfb and saving a screenshot to build/first-start.png"
  exec xvfb-run -a -s "-screen 0 1920x1080x24" build/bin/lapdissect --screenshot build/first-start.png "$@"
fi
exec build/bin/lapdissect "$@"
