// Costs of the assessment: exact deviation against path size, the live metrics per
// cut point at growing attempt lengths (should stay flat), a headless task run.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include "curriculum/metrics/deviation.h"
#include "curriculum/metrics/live.h"
#include "curriculum/scripted_trainee.h"
#include "curriculum/task_runner.h"
#include "sim/io/mesh_io.h"

namespace {

using namespace ld::curriculum;
using V = Eigen::Vector3d;

Polyline drawnLine(int n, double length) {
  std::vector<V> pts;
  for (int i = 0; i <= n; ++i) {
    const double x = length * i / n;
    pts.emplace_back(x, 5 * std::sin(x / 15), 2.5);
  }
  return makePolyline(pts);
}

V cutPoint(double x, std::mt19937& rng) {
  std::normal_distribution<double> g(0, 0.05);
  return V(x, 5 * std::sin(x / 15) + 1.2 * std::sin(x / 7) + g(rng), 2.5 + 0.2 * std::sin(x / 5));
}

void BM_DeviationBatch(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const Polyline d = drawnLine(100, 100.0);
  std::mt19937 rng(1);
  std::vector<V> a;
  for (int i = 0; i <= n; ++i) a.push_back(cutPoint(100.0 * i / n, rng));
  const Polyline cut = makePolyline(a);
  for (auto _ : state) benchmark::DoNotOptimize(deviation(d, cut));
  state.SetComplexityN(n);
}
BENCHMARK(BM_DeviationBatch)->RangeMultiplier(4)->Range(64, 4096)->Complexity();

// One more cut point after `prior` points: the live cost must not grow with prior.
void BM_LiveMetricsPerPoint(benchmark::State& state) {
  const int prior = static_cast<int>(state.range(0));
  const double step = 0.25;  // mm between cut points
  const double length = step * (prior + 2000);
  const Polyline d = drawnLine(static_cast<int>(length / 2), length);
  std::mt19937 rng(2);
  LiveMetrics live(d);
  live.start(0);
  int k = 0;
  for (; k < prior; ++k) live.addCutPoint(k * 1e-3, cutPoint(k * step, rng));
  for (auto _ : state) {
    live.addCutPoint(k * 1e-3, cutPoint(k * step, rng));
    ++k;
    if (k >= prior + 1990) state.SkipWithError("ran past the prepared path");
  }
}
BENCHMARK(BM_LiveMetricsPerPoint)->Arg(100)->Arg(1000)->Arg(4000)->Iterations(500);

void BM_HeadlessRun(benchmark::State& state) {
  const std::string file = std::string(LD_RESOURCES_DIR) + "/tasks/slab-s-curve.json";
  const Task task = loadTask(file);
  const auto mesh = ld::io::readMesh(resolveModel(task, file));
  const auto tr = scriptedAttempt(task, mesh, traineeProfile(2), static_cast<double>(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(runTask(task, mesh, tr));
  state.counters["samples"] = static_cast<double>(tr.samples.size());
  state.counters["us_per_sample"] =
      benchmark::Counter(static_cast<double>(tr.samples.size()),
                         benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_HeadlessRun)->Arg(250)->Arg(1000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
