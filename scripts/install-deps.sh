#!/usr/bin/env bash
# Installs the Debian 12 packages lapdissect needs. Idempotent and quick when all is present.
set -euo pipefail
pkgs=(
  build-essential cmake ninja-build pkg-config ccache
  qt6-base-dev qt6-charts-dev libqt6opengl6-dev libqt6openglwidgets6
  libqt6sql6-sqlite libqt6sql6-psql qt6-svg-dev libgl-dev
  libeigen3-dev libsodium-dev libassimp-dev nlohmann-json3-dev
  libgtest-dev libgmock-dev libbenchmark-dev libcgal-dev libgmp-dev libmpfr-dev
  postgresql xvfb xauth libgl1-mesa-dri clang libclang-rt-14-dev sqlite3 libsqlite3-dev zlib1g-dev
)
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "install-deps: installing ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
