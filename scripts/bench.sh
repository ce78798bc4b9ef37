#!/usr/bin/env bash
# Speed and memory figures: builds the Release benchmarks and runs every Google
# Benchmark program (build-bench/bench/*) plus the CLI's `sim bench` on the built-in
# scenes, writing JSON to build-bench/results/. Run it on a quiet machine; nothing
# here is asserted (the tests never time anything).
#   scripts/bench.sh [benchmark-name-regex]      e.g. scripts/bench.sh physics
set -euo pipefail
cd "$(dirname "$0")/.."
filter=${1:-.}
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
cmake -S . -B build-bench -G Ninja -DCMAKE_BUILD_TYPE=Release -DLD_BUILD_BENCHMARKS=ON "${launcher[@]}" >/dev/null
cmake --build build-bench -j"$(nproc)"
out=build-bench/results
mkdir -p "$out"
echo "machine: $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg)" | tee "$out/machine.txt"
for b in build-bench/bench/*; do
  name=$(basename "$b")
  [[ "$name" =~ $filter ]] || continue
  echo "== $name"
  "$b" --benchmark_out="$out/$name.json" --benchmark_out_format=json --benchmark_counters_tabular=true
done
if [[ "sim" =~ $filter ]] || [ "$filter" = . ]; then
  for scene in oscillator patch-release sliver; do
    for method in explicit_euler symplectic_euler verlet rk4 implicit_euler; do
      build-bench/bin/lapdissect-cli sim bench --scene "$scene" --method "$method" --dt 0.001 --duration 0.5 \
        > "$out/sim_${scene}_${method}.json" || true
      echo "sim bench $scene $method: $(cat "$out/sim_${scene}_${method}.json")"
    done
  done
fi
