// The vectorised symplectic kernels (spring_kernel.h) against the portable scalar
// path: on a mesh after local edits (irregular valence, deleted faces, appended
// vertices, springs added since the last rebuild), with gravity, external forces and
// motion, every compiled path gives the scalar result to rounding with either force
// factor (rsqrt and Newton, or sqrt and div: detail::Factor), one and two threads agree
// bit for bit on each path, and the monitor's decisions are the same. The rsqrt
// factor's 1/l is checked against 1/√l² directly (within 2 ulp, and not with one
// Newton step fewer).
#include <cmath>
#include <limits>
#include <optional>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "sim/physics/mass_spring.h"
#include "sim/physics/scenes.h"
#include "sim/physics/spring_kernel.h"
#include "tests/sim/physics/physics_test_util.h"

namespace ld::physics {
namespace {

using Vec3 = Eigen::Vector3d;
using detail::Kernel;

// Restores automatic dispatch when a test ends.
struct ForcedKernel {
  explicit ForcedKernel(Kernel k) { ok = detail::forceKernel(k); }
  ~ForcedKernel() { detail::forceKernel(std::nullopt); }
  ForcedKernel(const ForcedKernel&) = delete;
  ForcedKernel& operator=(const ForcedKernel&) = delete;
  bool ok = false;
};

std::vector<Kernel> compiledKernels() {
  std::vector<Kernel> out;
  for (Kernel k : {Kernel::Scalar, Kernel::Avx2, Kernel::Avx512})
    if (detail::kernelSupported(k)) out.push_back(k);
  return out;
}

// Forces the vector paths' force factor (detail::Factor) while it lives.
struct ForcedFactor {
  explicit ForcedFactor(detail::Factor f) { detail::forceFactor(f); }
  ~ForcedFactor() { detail::forceFactor(std::nullopt); }
  ForcedFactor(const ForcedFactor&) = delete;
  ForcedFactor& operator=(const ForcedFactor&) = delete;
};

// Builds the per-spring lanes (20 bytes) while it lives, whatever the springs.
struct ForcedPerSpringLanes {
  ForcedPerSpringLanes() { detail::forcePerSpringLanes(true); }
  ~ForcedPerSpringLanes() { detail::forcePerSpringLanes(false); }
  ForcedPerSpringLanes(const ForcedPerSpringLanes&) = delete;
  ForcedPerSpringLanes& operator=(const ForcedPerSpringLanes&) = delete;
};

// A cells x cells grid (50: 2601 vertices, the two-thread split applies) cut up by
// local edits after its cache was built, pushed, moving, with gravity and a few
// external forces. Filled in place: moving a State is a new layout (its cache would be
// rebuilt). jitter: the grid's vertices moved at random before the tissue properties
// are attached (every rest length different).
void editedScene(Params& p, State& s, int cells = 50, bool jitter = false) {
  p.tissue.gravity = Vec3(0.0, -2.0, -9810.0);
  mesh::SurfaceMesh grid = makeGrid(cells, cells, 200.0 / cells);
  if (jitter) {
    std::mt19937 jr(11);
    std::uniform_real_distribution<double> u(-0.3, 0.3);
    for (Vec3& x : grid.positions()) x += (200.0 / cells) * Vec3(u(jr), u(jr), u(jr));
  }
  s = makeState(std::move(grid), p.tissue);
  s.mesh.position(nearestVertex(s.mesh, Vec3(100, 100, 0))).z() -= 5.0;
  step(p, s, 1e-4);  // the cache exists: the edits below go through the journal
  std::mt19937 rng(5);
  testutil::randomEdits(s.mesh, p.tissue, rng, 60);  // under the rebuild threshold
  auto& v = s.mesh.getVertexProperty<Vec3>(kVelocityProp).vector();
  auto& ext = s.mesh.getVertexProperty<Vec3>(kForceProp).vector();
  std::uniform_real_distribution<double> u(-20.0, 20.0);
  for (mesh::Vertex vx : s.mesh.vertices()) {
    v[vx.idx()] = Vec3(u(rng), u(rng), u(rng));
    if (vx.idx() % 97 == 0) ext[vx.idx()] = Vec3(u(rng), u(rng), 3.0 * u(rng));
  }
}

double maxNorm(const std::vector<Vec3>& a) {
  double m = 0.0;
  for (const Vec3& x : a) m = std::max(m, x.norm());
  return m;
}

const std::vector<Vec3>& velocities(const State& s) { return s.mesh.getVertexProperty<Vec3>(kVelocityProp).vector(); }

TEST(SpringKernel, ScalarAlwaysThereAndForcingWorks) {
  EXPECT_TRUE(detail::kernelSupported(Kernel::Scalar));
  const Kernel automatic = detail::activeKernel();
  {
    ForcedKernel f(Kernel::Scalar);
    ASSERT_TRUE(f.ok);
    EXPECT_EQ(detail::activeKernel(), Kernel::Scalar);
  }
  EXPECT_EQ(detail::activeKernel(), automatic);
  // The force factor: each path's default (measured: rsqrt on AVX-512 on Intel CPUs,
  // sqrt and div elsewhere), or the one forced.
  for (Kernel k : {Kernel::Scalar, Kernel::Avx2, Kernel::Avx512})
    EXPECT_EQ(detail::activeFactor(k), detail::defaultFactor(k));
  EXPECT_EQ(detail::defaultFactor(Kernel::Avx2), detail::Factor::SqrtDiv);
  EXPECT_EQ(detail::defaultFactor(Kernel::Scalar), detail::Factor::SqrtDiv);
  {
    ForcedFactor f(detail::Factor::SqrtDiv);
    EXPECT_EQ(detail::activeFactor(Kernel::Avx512), detail::Factor::SqrtDiv);
  }
  {
    ForcedFactor f(detail::Factor::Rsqrt);
    EXPECT_EQ(detail::activeFactor(Kernel::Avx2), detail::Factor::Rsqrt);
  }
  EXPECT_EQ(detail::activeFactor(Kernel::Avx512), detail::defaultFactor(Kernel::Avx512));
  for (Kernel k : {Kernel::Avx2, Kernel::Avx512})
    if (!detail::kernelSupported(k)) {
      EXPECT_FALSE(detail::forceKernel(k)) << detail::kernelName(k);
    }
}

// States are rebuilt (same seed) rather than copied: a copy is a new layout, so its
// cache would be rebuilt and the springs added through the journal not exercised.
TEST(SpringKernel, EveryPathMatchesTheScalarStepOnAnEditedMesh) {
  Params p;
  constexpr double dt = 1e-4;
  constexpr int kSteps = 10;
  // Reference: scalar, one thread.
  State ref;
  editedScene(p, ref);
  {
    ForcedKernel f(Kernel::Scalar);
    for (int i = 0; i < kSteps; ++i) ASSERT_TRUE(rawStep(p, ref, Method::SymplecticEuler, dt));
  }
  ASSERT_GT(ref.cache.localUpdates, 0u);
  ASSERT_GT(ref.cache.springs.size(), ref.cache.nCsr) << "the edits should leave added springs";
  const double xScale = maxNorm(ref.mesh.positions()), vScale = maxNorm(velocities(ref));
  ASSERT_GT(vScale, 1.0);
  for (Kernel k : compiledKernels())
    for (detail::Factor fac : {detail::Factor::Rsqrt, detail::Factor::SqrtDiv}) {
      SCOPED_TRACE(std::string(detail::kernelName(k)) + " " + std::string(detail::factorName(fac)));
      ForcedKernel f(k);
      ASSERT_TRUE(f.ok);
      ForcedFactor ff(fac);
      std::vector<Vec3> oneThread;
      for (int threads : {1, 2}) {
        SCOPED_TRACE(threads);
        Params pt = p;
        pt.threads = threads;
        State s;
        editedScene(pt, s);
        for (int i = 0; i < kSteps; ++i) ASSERT_TRUE(rawStep(pt, s, Method::SymplecticEuler, dt));
        EXPECT_EQ(s.cache.springs.size(), ref.cache.springs.size());
        EXPECT_LT(testutil::maxDiff(s.mesh.positions(), ref.mesh.positions()), 1e-13 * xScale);
        EXPECT_LT(testutil::maxDiff(velocities(s), velocities(ref)), 1e-11 * vScale);
        if (threads == 1)
          oneThread = s.mesh.positions();
        else
          EXPECT_EQ(s.mesh.positions(), oneThread) << "two threads must be bit-identical to one";
      }
    }
}

// One symplectic step of s against the force pass, which walks the CSR by lower
// vertex: v1 = v0 + dt·f(x0, v0)/m, x1 = x0 + dt·v1. Returns the largest velocity error
// relative to the largest dt·|f|/m.
double oneStepAgainstForcePass(const Params& p, State& s) {
  constexpr double dt = 1e-4;
  const std::vector<Vec3> f = forces(p, s);
  const std::vector<Vec3> x0 = s.mesh.positions(), v0 = velocities(s);
  const auto& mass = s.mesh.getVertexProperty<double>(kMassProp).vector();
  EXPECT_TRUE(rawStep(p, s, Method::SymplecticEuler, dt));
  const auto& x1 = s.mesh.positions();
  const auto& v1 = velocities(s);
  double vErr = 0.0, xErr = 0.0, fMax = 0.0;
  for (std::size_t i = 0; i < x0.size(); ++i) {
    const bool live = !s.mesh.isDeleted(mesh::Vertex(static_cast<int>(i))) && mass[i] > 0.0;
    const Vec3 v = live ? Vec3(v0[i] + (dt / mass[i]) * f[i]) : Vec3::Zero();
    vErr = std::max(vErr, (v1[i] - v).norm());
    xErr = std::max(xErr, (x1[i] - (x0[i] + dt * v1[i])).norm());
    if (live) fMax = std::max(fMax, (dt / mass[i]) * f[i].norm());
  }
  EXPECT_GT(fMax, 1.0) << "the forces should change the velocities noticeably";
  EXPECT_LT(xErr, 1e-12);
  return vErr / fMax;
}

// The symplectic step's own layout (vertex groups, lanes sorted by degree, each spring
// at both ends, springs added through the journal in f4) against the force pass on
// every path, one and two threads, with new vertices past the last full group of 16,
// in both lane layouts.
void expectStepMatchesForcePass(int cells) {
  for (Kernel k : compiledKernels())
    for (detail::Factor fac : {detail::Factor::Rsqrt, detail::Factor::SqrtDiv}) {
      SCOPED_TRACE(std::string(detail::kernelName(k)) + " " + std::string(detail::factorName(fac)));
      ForcedKernel fk(k);
      ForcedFactor ff(fac);
      for (bool perSpring : {false, true}) {
        SCOPED_TRACE(perSpring ? "per-spring lanes" : "shared-K lanes");
        std::optional<ForcedPerSpringLanes> forced;
        if (perSpring) forced.emplace();
        for (int threads : {1, 2}) {
          SCOPED_TRACE(threads);
          Params p;
          p.threads = threads;
          State s;
          editedScene(p, s, cells);
          ASSERT_NE(s.mesh.verticesSize() % detail::kGroup, 0u) << "want a partial last group";
          EXPECT_LT(oneStepAgainstForcePass(p, s), 1e-9);
          EXPECT_GT(s.cache.springs.size(), s.cache.nCsr);
          EXPECT_EQ(s.cache.laneLayout, perSpring ? detail::LaneLayout::PerSpring : detail::LaneLayout::SharedK);
        }
      }
    }
}

TEST(SpringKernel, SymplecticStepMatchesTheForcePassOnEveryPath) { expectStepMatchesForcePass(50); }

// A mesh large enough for the kernels' prefetching (detail::kPrefetchFrom vertices).
TEST(SpringKernel, SymplecticStepMatchesTheForcePassOnALargeMesh) {
  ASSERT_GE(131u * 131u, detail::kPrefetchFrom);
  expectStepMatchesForcePass(130);
}

// A grid whose vertices at `hubs` (the middle one by default) get `extra` more springs
// each (the edges across from them split, as a cut's groove bottom fans out), pushed
// and moving. Built before the tissue is attached: the step's layout is made once, from
// the whole mesh.
void fanScene(Params& p, State& s, int extra, std::initializer_list<Vec3> hubs = {Vec3(100, 100, 0)}) {
  mesh::SurfaceMesh grid = makeGrid(50, 50, 4.0);
  std::vector<mesh::Vertex> hubVertices;
  for (const Vec3& at : hubs) {
    const mesh::Vertex hub = nearestVertex(grid, at);
    hubVertices.push_back(hub);
    for (int i = 0; i < extra; ++i) {
      const mesh::Face f = grid.faces(hub)[static_cast<std::size_t>(i) % grid.faces(hub).size()];
      mesh::Vertex a, b;
      for (mesh::Vertex v : grid.vertices(f))
        if (v != hub) (a.isValid() ? b : a) = v;
      const Vec3 mid = 0.5 * (grid.position(a) + grid.position(b)) + Vec3(0, 0, 0.1 * (i % 3));
      ASSERT_TRUE(grid.splitEdge(grid.findEdge(a, b), mid).isValid());
    }
  }
  p.tissue.gravity = Vec3(0.0, -2.0, -9810.0);
  s = makeState(std::move(grid), p.tissue);
  for (mesh::Vertex hub : hubVertices) s.mesh.position(hub).z() -= 3.0;
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-20.0, 20.0);
  auto& v = s.mesh.getVertexProperty<Vec3>(kVelocityProp).vector();
  for (Vec3& x : v) x = Vec3(u(rng), u(rng), u(rng));
}

// fanScene with `hubs` on every path, both factors, each lane layout, one and two
// threads: the step matches the force pass and two threads match one bit for bit;
// check(state, hub vertices) looks at the layout after the step.
template <class Check>
void expectFanStepsMatchForcePass(std::initializer_list<Vec3> hubs, Check&& check) {
  for (Kernel k : compiledKernels())
    for (detail::Factor fac : {detail::Factor::Rsqrt, detail::Factor::SqrtDiv})
      for (bool perSpring : {false, true}) {
        SCOPED_TRACE(std::string(detail::kernelName(k)) + " " + std::string(detail::factorName(fac)) +
                     (perSpring ? " per-spring" : " shared-K"));
        ForcedKernel fk(k);
        ForcedFactor ff(fac);
        std::optional<ForcedPerSpringLanes> forced;
        if (perSpring) forced.emplace();
        std::vector<Vec3> oneThread;
        for (int threads : {1, 2}) {
          Params p;
          p.threads = threads;
          State s;
          fanScene(p, s, 24, hubs);
          std::vector<mesh::Vertex> hubVertices;
          for (const Vec3& at : hubs) hubVertices.push_back(nearestVertex(s.mesh, at + Vec3(0, 0, -3)));
          EXPECT_LT(oneStepAgainstForcePass(p, s), 1e-9);
          check(s, hubVertices);
          if (threads == 1)
            oneThread = s.mesh.positions();
          else
            EXPECT_EQ(s.mesh.positions(), oneThread) << "two threads must be bit-identical to one";
        }
      }
}

// A vertex of far higher degree than the rest of its block keeps the springs past the
// block's rank count in tail ranks of its own (instead of padding all 8 lanes to its
// degree): its group has fewer ranks than it has springs, and on every path, one or two
// threads, each lane layout, the step still matches the force pass.
TEST(SpringKernel, AFanVertexSumsItsExtraSpringsInTailRanks) {
  expectFanStepsMatchForcePass({Vec3(100, 100, 0)}, [](const State& s, const std::vector<mesh::Vertex>& hubs) {
    const mesh::Vertex hub = hubs[0];
    ASSERT_EQ(s.mesh.edges(hub).size(), 30u);
    const auto& c = s.cache;
    ASSERT_EQ(c.springs.size(), c.nCsr) << "one layout from the whole mesh";
    const std::size_t g = hub.idx() / detail::kGroup;
    const std::uint32_t ranks = c.rankStart[2 * g + 2] - c.rankStart[2 * g] + c.tailStart[g + 1] - c.tailStart[g];
    EXPECT_LT(ranks, 16u) << "padding both blocks to 30 springs would take 36 ranks";
    EXPECT_GT(c.tailStart[g + 1], c.tailStart[g]);
    EXPECT_EQ(c.tailSlot[c.tailStart[g]], c.vertexSlot[hub.idx()]);
    EXPECT_LT(c.rankX.size(), 11 * 2 * c.nCsr / 10) << "lanes: at most 10 % padding";
  });
}

// Two fan vertices in one group, both in its high-degree block, each with tail ranks
// (the AVX-512 path folds their tails from one store of the block's sums: each vertex
// must get its own lane's sum back, and their folds must not mix).
TEST(SpringKernel, TwoFanVerticesOfOneBlockSumTheirOwnTails) {
  expectFanStepsMatchForcePass({Vec3(100, 100, 0), Vec3(104, 100, 0)}, [](const State& s,
                                                                          const std::vector<mesh::Vertex>& hubs) {
    const auto& c = s.cache;
    const std::size_t a = hubs[0].idx(), b = hubs[1].idx(), g = a / detail::kGroup;
    ASSERT_EQ(b / detail::kGroup, g) << "both hubs in one group";
    ASSERT_EQ(c.vertexSlot[a] / detail::kLanes, c.vertexSlot[b] / detail::kLanes) << "one block";
    const std::set<std::uint8_t> tailed(c.tailSlot.begin() + c.tailStart[g], c.tailSlot.begin() + c.tailStart[g + 1]);
    EXPECT_EQ(tailed, (std::set<std::uint8_t>{c.vertexSlot[a], c.vertexSlot[b]}));
  });
}

TEST(SpringKernel, ForcesAndMonitoredStepsAgreeAcrossPaths) {
  Params p;
  std::vector<Vec3> refForces;
  State ref;
  editedScene(p, ref);
  std::vector<StepInfo> refInfo;
  {
    ForcedKernel f(Kernel::Scalar);
    refForces = forces(p, ref);
    for (int i = 0; i < 5; ++i) refInfo.push_back(step(p, ref, 1e-4));
  }
  const double fScale = maxNorm(refForces);
  for (Kernel k : compiledKernels()) {
    SCOPED_TRACE(std::string(detail::kernelName(k)));
    ForcedKernel f(k);
    State s;
    editedScene(p, s);
    EXPECT_LT(testutil::maxDiff(forces(p, s), refForces), 1e-12 * fScale);
    for (int i = 0; i < 5; ++i) {
      const StepInfo info = step(p, s, 1e-4);
      EXPECT_EQ(info.accepted, refInfo[static_cast<std::size_t>(i)].accepted);
      EXPECT_EQ(info.substeps, refInfo[static_cast<std::size_t>(i)].substeps);
    }
    EXPECT_EQ(s.stability.warnings, ref.stability.warnings);
    EXPECT_LT(testutil::maxDiff(s.mesh.positions(), ref.mesh.positions()), 1e-9);
  }
}

// Tissue springs (k = K / rest at load and on every edge a cut makes) share one K: the
// step's lanes carry the far end and k only, and stay so through edits in place and a
// rebuild after cuts.
TEST(SpringKernel, TissueSpringsGetTheSharedKLanes) {
  Params p;
  State s;
  editedScene(p, s, 50, true);
  EXPECT_EQ(s.cache.laneLayout, detail::LaneLayout::SharedK) << "after edits in place";
  EXPECT_TRUE(s.cache.rankRest.empty());
  EXPECT_NEAR(s.cache.springK, p.tissue.K, 4e-16 * p.tissue.K);
  ASSERT_TRUE(rawStep(p, s, Method::SymplecticEuler, 1e-4));
  s.invalidate();  // a rebuild: the cut edges join the ranks
  ASSERT_TRUE(rawStep(p, s, Method::SymplecticEuler, 1e-4));
  EXPECT_EQ(s.cache.springs.size(), s.cache.nCsr) << "rebuilt";
  EXPECT_EQ(s.cache.laneLayout, detail::LaneLayout::SharedK) << "after a rebuild with cut edges";
  EXPECT_NEAR(s.cache.springK, p.tissue.K, 4e-16 * p.tissue.K);
  {
    ForcedPerSpringLanes forced;
    s.invalidate();
    ASSERT_TRUE(rawStep(p, s, Method::SymplecticEuler, 1e-4));
    EXPECT_EQ(s.cache.laneLayout, detail::LaneLayout::PerSpring);
    EXPECT_EQ(s.cache.rankRest.size(), s.cache.rankK.size());
  }
}

// The two lane layouts on a mesh whose rest lengths all differ (jittered grid, cut up,
// moving): 10 steps agree to rounding on every path, one and two threads (two threads
// bit-identical to one in each layout), and so does the monitor's energy (its budget
// after a monitored step: the shared-K lanes sum the energy without its constant part).
TEST(SpringKernel, SharedKLanesMatchPerSpringLanes) {
  constexpr double dt = 1e-4;
  constexpr int kSteps = 10;
  for (Kernel k : compiledKernels()) {
    SCOPED_TRACE(std::string(detail::kernelName(k)));
    ForcedKernel fk(k);
    std::vector<Vec3> oneThread[2];
    for (int threads : {1, 2}) {
      SCOPED_TRACE(threads);
      Params p;
      p.threads = threads;
      State shared, perSpring;
      editedScene(p, shared, 50, true);
      {
        ForcedPerSpringLanes forced;
        editedScene(p, perSpring, 50, true);
      }
      ASSERT_EQ(shared.cache.laneLayout, detail::LaneLayout::SharedK);
      ASSERT_EQ(perSpring.cache.laneLayout, detail::LaneLayout::PerSpring);
      for (int i = 0; i < kSteps; ++i) {
        ASSERT_TRUE(rawStep(p, shared, Method::SymplecticEuler, dt));
        ASSERT_TRUE(rawStep(p, perSpring, Method::SymplecticEuler, dt));
      }
      ASSERT_GT(shared.cache.springs.size(), shared.cache.nCsr) << "springs added through the journal";
      const double xScale = maxNorm(perSpring.mesh.positions()), vScale = maxNorm(velocities(perSpring));
      ASSERT_GT(vScale, 1.0);
      EXPECT_LT(testutil::maxDiff(shared.mesh.positions(), perSpring.mesh.positions()), 1e-14 * xScale);
      EXPECT_LT(testutil::maxDiff(velocities(shared), velocities(perSpring)), 1e-12 * vScale);
      EXPECT_NE(shared.mesh.positions(), perSpring.mesh.positions()) << "not the same arithmetic";
      for (int layout = 0; layout < 2; ++layout) {
        const State& st = layout ? perSpring : shared;
        if (threads == 1)
          oneThread[layout] = st.mesh.positions();
        else
          EXPECT_EQ(st.mesh.positions(), oneThread[layout]) << "two threads must be bit-identical to one";
      }
      // The energy: the budget a monitored step derives from the sweep's sums.
      step(p, shared, dt);
      step(p, perSpring, dt);
      ASSERT_TRUE(std::isfinite(shared.energyBudget));
      EXPECT_NEAR(shared.energyBudget, perSpring.energyBudget, 1e-12 * perSpring.energyBudget);
      const Energy e = energy(p, perSpring);
      EXPECT_GT(e.spring, 0.1 * perSpring.energyBudget) << "the springs' share is large enough to test";
    }
  }
}

// rawStep leaves out the sums only the monitor reads (spring energy, Σ K_i|v1_i|²):
// the motion is bit-identical to a monitored step's, in both lane layouts.
TEST(SpringKernel, SkippingTheMonitorsSumsChangesNoBit) {
  for (Kernel k : compiledKernels())
    for (detail::Factor fac : {detail::Factor::Rsqrt, detail::Factor::SqrtDiv}) {
      SCOPED_TRACE(std::string(detail::kernelName(k)) + " " + std::string(detail::factorName(fac)));
      ForcedKernel fk(k);
      ForcedFactor ff(fac);
      for (bool perSpring : {false, true}) {
        std::optional<ForcedPerSpringLanes> forced;
        if (perSpring) forced.emplace();
        Params p;
        State raw, monitored;
        editedScene(p, raw, 50, true);
        editedScene(p, monitored, 50, true);
        for (int i = 0; i < 3; ++i) {
          ASSERT_TRUE(rawStep(p, raw, Method::SymplecticEuler, 1e-5));
          const StepInfo info = step(p, monitored, 1e-5);
          ASSERT_TRUE(info.accepted);
          ASSERT_EQ(info.substeps, 1);
        }
        EXPECT_EQ(raw.mesh.positions(), monitored.mesh.positions());
        EXPECT_EQ(velocities(raw), velocities(monitored));
      }
    }
}

// A mesh whose springs do not share one K (one spring set by hand; edges a cut
// initialised with another K) gets the per-spring lanes at its next rebuild, and the
// step still agrees with the force pass.
TEST(SpringKernel, PerSpringLanesWhenKIsNotShared) {
  for (Kernel k : compiledKernels()) {
    SCOPED_TRACE(std::string(detail::kernelName(k)));
    ForcedKernel fk(k);
    {
      Params p;
      State s;
      editedScene(p, s, 50, true);
      auto kp = s.mesh.getEdgeProperty<double>(kStiffnessProp);
      const mesh::Edge e = *s.mesh.edges().begin();
      kp[e] *= 1.5;
      s.invalidate();
      EXPECT_LT(oneStepAgainstForcePass(p, s), 1e-9);
      EXPECT_EQ(s.cache.laneLayout, detail::LaneLayout::PerSpring) << "one spring set by hand";
      kp[e] /= 1.5;
      s.invalidate();
      EXPECT_LT(oneStepAgainstForcePass(p, s), 1e-9);
      EXPECT_EQ(s.cache.laneLayout, detail::LaneLayout::SharedK) << "restored";
    }
    {
      Params p;
      State s;
      editedScene(p, s, 50, true);
      TissueParams other = p.tissue;
      other.K = 2.0 * p.tissue.K;
      std::mt19937 rng(3);
      testutil::randomEdits(s.mesh, other, rng, 10);  // new edges with k = 2K / rest
      EXPECT_LT(oneStepAgainstForcePass(p, s), 1e-9);
      EXPECT_EQ(s.cache.laneLayout, detail::LaneLayout::SharedK) << "edits in place: added springs are not lanes";
      s.invalidate();
      EXPECT_LT(oneStepAgainstForcePass(p, s), 1e-9);
      EXPECT_EQ(s.cache.laneLayout, detail::LaneLayout::PerSpring) << "rebuilt with two Ks";
    }
  }
}

// The speed check takes the largest velocity component from the sweep and does the
// exact pass only when 3 × its square passes the limit: a fast vertex along an axis is
// within the limit, the same speed split over three axes is past it.
TEST(SpringKernel, SpeedLimitIsExactOnEveryPath) {
  for (Kernel k : compiledKernels()) {
    SCOPED_TRACE(std::string(detail::kernelName(k)));
    ForcedKernel f(k);
    for (const auto& [v0, rejected] : {std::pair{Vec3(9.0, 0.0, 0.0), false}, std::pair{Vec3(6.0, 6.0, 6.0), true}}) {
      testutil::Oscillator osc(0.0);
      osc.params.stability.maxSpeed = 10.0;
      osc.params.stability.maxSubsteps = 1;
      osc.state.mesh.positions()[0] = Vec3::Zero();  // at home: the spring does nothing at first
      osc.state.mesh.getVertexProperty<Vec3>(kVelocityProp).vector()[0] = v0;
      const StepInfo info = step(osc.params, osc.state, 1e-6);
      EXPECT_EQ(info.accepted, !rejected) << v0.transpose();
      if (rejected) {
        EXPECT_EQ(osc.state.stability.lastReason, "speed");
      }
    }
  }
}

TEST(SpringKernel, NonFiniteIsReportedOnEveryPath) {
  Params p;
  State start;
  editedScene(p, start);
  for (Kernel k : compiledKernels()) {
    SCOPED_TRACE(std::string(detail::kernelName(k)));
    ForcedKernel f(k);
    for (int threads : {1, 2}) {
      Params pt = p;
      pt.threads = threads;
      State s = start;  // a NaN position near the end (second thread's half, a chunk tail)
      s.mesh.positions()[s.mesh.verticesSize() - 3].x() = std::numeric_limits<double>::quiet_NaN();
      EXPECT_FALSE(rawStep(pt, s, Method::SymplecticEuler, 1e-4));
      State t = start;  // an infinite external force at the start
      t.mesh.getVertexProperty<Vec3>(kForceProp).vector()[7].y() = std::numeric_limits<double>::infinity();
      EXPECT_FALSE(rawStep(pt, t, Method::SymplecticEuler, 1e-4));
      State u = start;
      EXPECT_TRUE(rawStep(pt, u, Method::SymplecticEuler, 1e-4));
    }
  }
}

// Largest relative error of path k's 1/√l² (detail::invSqrt, `steps` Newton steps)
// against a long double reference, over log-uniform random l² in [2^-1021, 2^1023]
// (every exponent the step can meet above the flushed denormals), the tissue's range
// (l from 1e-3 to 1e3 mm) and edge cases (powers of two and their neighbours, where
// the estimates' errors peak, the ends of the range).
double invSqrtError(Kernel k, int steps) {
  FlushDenormals ftz;
  std::vector<double> l2;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> e(-1021.0, 1023.0), t(-6.0, 6.0);
  for (int i = 0; i < 200000; ++i) l2.push_back(std::exp2(e(rng)));
  for (int i = 0; i < 200000; ++i) l2.push_back(std::pow(10.0, t(rng)));
  for (int p = -1021; p <= 1023; ++p) {
    const double x = std::ldexp(1.0, p);
    l2.insert(l2.end(), {x, std::nextafter(x, 0.0), std::nextafter(x, 2.0 * x), 1.5 * x, 1.25 * x, 1.75 * x});
  }
  l2.push_back(std::numeric_limits<double>::max());
  std::vector<double> y(l2.size());
  detail::invSqrt(k, l2.data(), y.data(), l2.size(), steps);
  double worst = 0.0;
  for (std::size_t i = 0; i < l2.size(); ++i) {
    if (!(l2[i] >= std::ldexp(1.0, -1021)) || !std::isfinite(l2[i])) continue;  // (the nextafter below 2^-1021)
    const long double ref = 1.0L / std::sqrt(static_cast<long double>(l2[i]));
    const double err = static_cast<double>(std::fabs((static_cast<long double>(y[i]) - ref) / ref));
    worst = std::isfinite(y[i]) ? std::max(worst, err) : std::numeric_limits<double>::infinity();
  }
  return worst;
}

// The vector paths' 1/l (Factor::Rsqrt: an estimate and Newton steps, no divider) is
// within 2 ulp-equivalent (2·2^-52 relative) of 1/√l² over every exponent, and one
// Newton step fewer would not be (the test can fail). The force factor k − K·(1/l)
// then differs from (k·l − K)/l by about that relative error times K/(k·l − K)
// (~2.3 at the tissue's pre-stretch 0.7): the step's tolerances against the scalar path
// (1e-13 of the positions, 1e-11 of the velocities after 10 steps) hold it easily.
TEST(SpringKernel, RsqrtFactorIsWithinTwoUlpOfOneOverSqrt) {
  constexpr double kTol = 2.0 * std::numeric_limits<double>::epsilon();
  for (Kernel k : compiledKernels()) {
    if (k == Kernel::Scalar) continue;
    SCOPED_TRACE(std::string(detail::kernelName(k)));
    const int steps = detail::newtonSteps(k);
    ASSERT_GT(steps, 0);
    const double err = invSqrtError(k, steps);
    EXPECT_LE(err, kTol);
    RecordProperty(std::string(detail::kernelName(k)) + "_ulp", std::to_string(err / kTol * 2.0));
    EXPECT_GT(invSqrtError(k, steps - 1), 1e3 * kTol) << "one Newton step fewer should not be enough";
  }
  EXPECT_EQ(detail::newtonSteps(Kernel::Scalar), 0);
}

// Coinciding ends (l = 0) give a factor of exactly 0 on every path and factor, never
// NaN or ∞: a vertex moved onto its neighbour, and the step still agrees with the
// force pass (which skips l = 0 too).
TEST(SpringKernel, ZeroLengthSpringsAddNothingWithEitherFactor) {
  for (Kernel k : compiledKernels()) {
    SCOPED_TRACE(std::string(detail::kernelName(k)));
    ForcedKernel fk(k);
    for (detail::Factor fac : {detail::Factor::Rsqrt, detail::Factor::SqrtDiv}) {
      SCOPED_TRACE(std::string(detail::factorName(fac)));
      ForcedFactor ff(fac);
      for (bool perSpring : {false, true}) {
        std::optional<ForcedPerSpringLanes> forced;
        if (perSpring) forced.emplace();
        Params p;
        State s;
        editedScene(p, s, 50, true);
        const mesh::Vertex a = nearestVertex(s.mesh, Vec3(60, 60, 0));
        const mesh::Vertex b = s.mesh.otherVertex(s.mesh.edges(a).front(), a);
        s.mesh.position(a) = s.mesh.position(b);
        EXPECT_LT(oneStepAgainstForcePass(p, s), 1e-9);
        for (const Vec3& x : s.mesh.positions()) ASSERT_TRUE(x.allFinite());
      }
    }
  }
}

// The AVX-512 step loads each far end as 4 doubles (x, y, z and one it drops), so at
// the last vertex it reads one double past the positions: the step keeps one more
// vertex allocated in every position array it reads (padPositions). Here the mesh's
// positions and the step's other buffer start exactly sized (as after a copy): the step
// must pad them (checked through the capacity, which is what the loads rely on), and
// the motion must be the same as from padded arrays. Under AddressSanitizer
// (LD_SANITIZE) an unpadded array is a heap-buffer-overflow at the last vertex.
TEST(SpringKernel, StepReadsNoPositionPastTheArrays) {
  for (Kernel k : compiledKernels()) {
    SCOPED_TRACE(std::string(detail::kernelName(k)));
    ForcedKernel fk(k);
    for (int threads : {1, 2}) {
      for (bool monitor : {false, true}) {
        SCOPED_TRACE("threads " + std::to_string(threads) + (monitor ? " monitored" : ""));
        Params p;
        p.threads = threads;
        p.stability.enabled = monitor;
        State a, b;
        editedScene(p, a);
        editedScene(p, b);
        for (State* s : {&a, &b}) {
          s->invalidate();  // rebuilt: the last vertex (an edit's) is a far end in the ranks
          auto& x = s->mesh.positions();
          std::vector<Vec3> tight(x.begin(), x.end());
          x.swap(tight);
          s->cache.xb.shrink_to_fit();
        }
        ASSERT_EQ(a.mesh.positions().capacity(), a.mesh.positions().size());
        for (int i = 0; i < 3; ++i) {
          if (monitor)
            step(p, a, 1e-4);
          else
            rawStep(p, a, Method::SymplecticEuler, 1e-4);
          EXPECT_GT(a.mesh.positions().capacity(), a.mesh.positions().size());
          EXPECT_GT(a.cache.xb.capacity(), a.cache.xb.size());
        }
        // The same steps from arrays that were padded before the first one.
        b.mesh.positions().reserve(b.mesh.positions().size() + 8);
        for (int i = 0; i < 3; ++i) {
          if (monitor)
            step(p, b, 1e-4);
          else
            rawStep(p, b, Method::SymplecticEuler, 1e-4);
        }
        EXPECT_EQ(a.mesh.positions(), b.mesh.positions());
        EXPECT_EQ(velocities(a), velocities(b));
      }
    }
  }
}

}  // namespace
}  // namespace ld::physics
