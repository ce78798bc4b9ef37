#!/usr/bin/env bash
# Speed and memory figures: builds the Release benchmarks and runs every Google
# Benchmark program (build-bench/bench/*) plus the CLI's `sim bench` on the built-in
# scenes and the CLI's `cut` on the scripted slab tasks (the default slab and a
# 100k-triangle one, physics off and on), writing JSON to build-bench/results/. Run it
# on a quiet machine; nothing here is asserted (the tests never time anything).
#   scripts/bench.sh [program-regex [benchmark args...]]
#   e.g. scripts/bench.sh physics --benchmark_filter=Symplectic
set -euo pipefail
cd "$(dirname "$0")/.."
filter=${1:-.}
shift || true
# The same configuration and ccache settings as the test script's Release build, so the
# objects come from the cache after a test run.
export CCACHE_BASEDIR="$(pwd)" CCACHE_MAXSIZE=${CCACHE_MAXSIZE:-5G} CCACHE_NOHASHDIR=1
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
cmake -S . -B build-bench -G Ninja -DCMAKE_BUILD_TYPE=Release -DLD_WERROR=ON -DLD_BUILD_BENCHMARKS=ON \
  "${launcher[@]}" >/dev/null
cmake --build build-bench -j"$(nproc)" --target physics_bench collision_bench cutting_bench curriculum_bench \
  database_bench lapdissect-cli
out=build-bench/results
mkdir -p "$out"
echo "machine: $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg)" | tee "$out/machine.txt"
for b in build-bench/bench/*; do
  name=$(basename "$b")
  [[ "$name" =~ $filter ]] || continue
  echo "== $name"
  "$b" --benchmark_out="$out/$name.json" --benchmark_out_format=json --benchmark_counters_tabular=true "$@"
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
# The CLI's cut figures: each slab task's expert stroke at 1 kHz on the default slab
# (about 10k triangles) and on the same box at 100k triangles (`mesh slab`).
if [[ "cut" =~ $filter ]] || [ "$filter" = . ]; then
  cli=build-bench/bin/lapdissect-cli
  "$cli" mesh slab --triangles 100000 --out "$out/slab100k.obj" >/dev/null
  for task in slab-straight-line slab-gentle-curve slab-s-curve slab-circle-cutout; do
    "$cli" task script --task "resources/tasks/$task.json" --level 0 --rate 1000 --out "$out/$task.csv" >/dev/null
    for mesh in resources/models/tissue_slab.obj "$out/slab100k.obj"; do
      size=$(basename "$mesh" .obj)
      for physics in off on; do
        "$cli" cut --mesh "$mesh" --trajectory "$out/$task.csv" --physics "$physics" \
          > "$out/cut_${task}_${size}_${physics}.json" || true
        echo "cut $task $size physics $physics: $(cat "$out/cut_${task}_${size}_${physics}.json")"
      done
    done
  done
fi
