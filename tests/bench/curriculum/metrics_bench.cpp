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

// One more cut point after `prior` points: the live cost must not grow with prior
// (the drawn path is the same for every prior: a task's path does not grow with
// the attempt). Case 0, a normal cut: along the path at 8 µm steps (8 mm/s at 1 kHz).
// Case 1, back and forth: 20 mm along the path at 0.25 mm steps, then back and forth
// over those 20 mm, as a trainee working one place would (the cells there collect a
// piece of cut per pass).
struct LiveFixture {
  static constexpr double kLength = 100.0;
  explicit LiveFixture(int c) : mode(c) {}
  int mode;
  Polyline d = drawnLine(50, kLength);
  std::mt19937 rng{2};
  int k = 0;
  V next() {
    double x = 0.008 * k;
    if (mode == 1) {
      const double step = 0.25, span = 20.0;
      const double u = std::fmod(step * k, 2 * span);
      x = u < span ? u : 2 * span - u;
    }
    ++k;
    return cutPoint(x, rng);
  }
};

void BM_LiveDeviationPerPoint(benchmark::State& state) {
  const int prior = static_cast<int>(state.range(0));
  LiveFixture f(static_cast<int>(state.range(1)));
  LiveDeviation live(f.d);
  for (int i = 0; i < prior; ++i) live.addCutPoint(f.next());
  for (auto _ : state) live.addCutPoint(f.next());
  state.counters["prior"] = prior;
  state.counters["refined_cells"] = static_cast<double>(live.refinedCells());
}
BENCHMARK(BM_LiveDeviationPerPoint)
    ->ArgsProduct({{100, 1000, 10000}, {0, 1}})
    ->ArgNames({"prior", "backforth"})
    ->Iterations(2000)
    ->Unit(benchmark::kMicrosecond);

void BM_LiveMetricsPerPoint(benchmark::State& state) {
  const int prior = static_cast<int>(state.range(0));
  LiveFixture f(static_cast<int>(state.range(1)));
  LiveMetrics live(f.d);
  live.start(0);
  for (int i = 0; i < prior; ++i) live.addCutPoint(f.k * 1e-3, f.next());
  for (auto _ : state) live.addCutPoint(f.k * 1e-3, f.next());
  state.counters["prior"] = prior;
}
BENCHMARK(BM_LiveMetricsPerPoint)
    ->ArgsProduct({{100, 1000, 10000}, {0, 1}})
    ->ArgNames({"prior", "backforth"})
    ->Iterations(2000)
    ->Unit(benchmark::kMicrosecond);

void BM_HeadlessRun(benchmark::State& state) {
  const std::string file = std::string(LD_RESOURCES_DIR) + "/tasks/slab-s-curve.json";
  const Task task = loadTask(file);
  const auto mesh = ld::io::readMesh(resolveModel(task, file));
  const auto tr = scriptedAttempt(task, mesh, traineeProfile(2), static_cast<double>(state.range(0)));
  RunOptions o;
  o.physics = state.range(1) != 0;  // the tissue stepped at <= 1 ms and the grasper's force from it
  for (auto _ : state) benchmark::DoNotOptimize(runTask(task, mesh, tr, o));
  state.counters["samples"] = static_cast<double>(tr.samples.size());
  state.counters["us_per_sample"] =
      benchmark::Counter(static_cast<double>(tr.samples.size()),
                         benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_HeadlessRun)
    ->Args({250, 0})
    ->Args({1000, 0})
    ->Args({250, 1})
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime();

}  // namespace

BENCHMARK_MAIN();
