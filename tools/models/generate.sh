#!/bin/sh
# Regenerates resources/models with the project's generator, without CMake:
#   tools/models/generate.sh [OUTDIR]
# (The CMake target `models` does the same from a build folder.)
set -eu
root=$(cd "$(dirname "$0")/../.." && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
${CXX:-c++} -std=c++20 -O2 -I"$root" "$root/tools/models/model_shapes.cpp" "$root/tools/models/generate_models.cpp" -o "$tmp/generate_models"
"$tmp/generate_models" "${1:-$root/resources/models}"
