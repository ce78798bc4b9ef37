#include "sim/physics/tissue_properties.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "sim/physics/mass_spring.h"
#include "sim/physics/physics_error.h"
#include "sim/physics/scenes.h"
#include "tests/support/test_support.h"

namespace ld::physics {
namespace {

using Vec3 = Eigen::Vector3d;

double totalMass(const mesh::SurfaceMesh& m) {
  auto mass = m.getVertexProperty<double>(kMassProp);
  double s = 0;
  for (auto v : m.vertices()) s += mass[v];
  return s;
}

TEST(TissueProperties, AttachSetsHomeRestStiffnessAndLumpedMass) {
  auto m = makeGrid(2, 2, 3.0);  // 8 triangles of area 4.5
  TissueParams p;
  attachTissueProperties(m, p);
  ASSERT_TRUE(hasTissueProperties(m));
  auto home = m.getVertexProperty<Vec3>(kHomeProp);
  auto rest = m.getEdgeProperty<double>(kRestProp);
  auto k = m.getEdgeProperty<double>(kStiffnessProp);
  for (auto v : m.vertices()) EXPECT_TRUE(ld::test::nearVec(home[v], m.position(v), 0.0));
  for (auto e : m.edges()) {
    EXPECT_TRUE(ld::test::near(rest[e], 0.7 * m.edgeLength(e), 1e-12));
    EXPECT_TRUE(ld::test::near(k[e], p.K / rest[e], 1e-12));
  }
  EXPECT_TRUE(ld::test::near(totalMass(m), p.density * 36.0, 1e-15));
  // The centre vertex touches 6 of the 8 triangles (alternating diagonals are not
  // used by the flat grid), a corner vertex 1 or 2.
  auto mass = m.getVertexProperty<double>(kMassProp);
  const auto centre = nearestVertex(m, Vec3(3, 3, 0));
  EXPECT_TRUE(ld::test::near(mass[centre], p.density * 4.5 * 6 / 3.0, 1e-15));
}

TEST(TissueProperties, UniformMassOption) {
  auto m = makeGrid(2, 1, 1.0);
  TissueParams p;
  p.uniformMass = true;
  p.vertexMass = 0.25;
  attachTissueProperties(m, p);
  auto mass = m.getVertexProperty<double>(kMassProp);
  for (auto v : m.vertices()) EXPECT_EQ(mass[v], 0.25);
}

TEST(TissueProperties, SplitEdgeHooksInterpolateAndConserveMass) {
  auto m = makeGrid(2, 2, 2.0);
  TissueParams p;
  attachTissueProperties(m, p);
  const double before = totalMass(m);
  // Deform, then split an interior edge: the new home is interpolated from the
  // parents' homes, not taken from the deformed position.
  for (auto v : m.vertices()) m.position(v).z() += 1.0;
  const auto a = nearestVertex(m, Vec3(0, 2, 1)), b = nearestVertex(m, Vec3(2, 2, 1));
  const auto e = m.findEdge(a, b);
  ASSERT_TRUE(e.isValid());
  const double parentRest = m.getEdgeProperty<double>(kRestProp)[e];
  const auto v = m.splitEdge(e, 0.75 * m.position(a) + 0.25 * m.position(b));
  ASSERT_TRUE(v.isValid());
  ASSERT_TRUE(m.validate().ok()) << m.validate().message();
  initVertexOnEdge(m, v, a, b, 0.25, p);
  auto home = m.getVertexProperty<Vec3>(kHomeProp);
  EXPECT_TRUE(ld::test::nearVec(home[v], Vec3(0.5, 2, 0), 1e-12));
  auto rest = m.getEdgeProperty<double>(kRestProp);
  const auto ea = m.findEdge(a, v), eb = m.findEdge(v, b);
  EXPECT_TRUE(ld::test::near(rest[ea], 0.25 * parentRest, 1e-12));
  EXPECT_TRUE(ld::test::near(rest[eb], 0.75 * parentRest, 1e-12));
  EXPECT_TRUE(ld::test::near(m.getEdgeProperty<double>(kStiffnessProp)[ea], p.K / rest[ea], 1e-9));
  EXPECT_TRUE(ld::test::near(totalMass(m), before, 1e-15));
  EXPECT_GT(m.getVertexProperty<double>(kMassProp)[v], 0.0);
}

TEST(TissueProperties, SplitFaceAndThesisHomeRule) {
  auto m = makeGrid(1, 1, 3.0);
  TissueParams p;
  attachTissueProperties(m, p);
  const double before = totalMass(m);
  const auto f = *m.faces().begin();
  const auto vs = m.vertices(f);
  const Vec3 bary(0.2, 0.3, 0.5);
  const Vec3 at = bary[0] * m.position(vs[0]) + bary[1] * m.position(vs[1]) + bary[2] * m.position(vs[2]);
  const Vec3 moved = at + Vec3(0, 0, 2.0);
  const auto v = m.splitFace(f, moved);
  ASSERT_TRUE(v.isValid());
  TissueParams thesis = p;
  thesis.newVertexHome = NewVertexHome::Current;
  initVertexInFace(m, v, vs[0], vs[1], vs[2], bary, thesis);
  EXPECT_TRUE(ld::test::nearVec(m.getVertexProperty<Vec3>(kHomeProp)[v], moved, 1e-12));
  initVertexInFace(m, v, vs[0], vs[1], vs[2], bary, p);
  EXPECT_TRUE(ld::test::nearVec(m.getVertexProperty<Vec3>(kHomeProp)[v], at, 1e-12));
  EXPECT_TRUE(ld::test::near(totalMass(m), before, 1e-15));
}

TEST(TissueProperties, HooksNeedTheProperties) {
  auto m = makeGrid(1, 1, 1.0);
  const auto e = *m.edges().begin();
  EXPECT_THROW(initEdge(m, e, TissueParams{}), MissingPropertyError);
}

// initEdgesAround (the cutter's batch hook) gives bit for bit what initEdge on every
// edge of a vertex followed by redistributeMass of it, vertex by vertex, gives: with
// the mass floor on (a mass reads its springs), after homes moved (every spring around
// them stale), with neighbouring vertices in the list and an invalid one among them.
TEST(TissueProperties, BatchEdgeHookEqualsPerVertexHooks) {
  auto base = makeGrid(6, 6, 2.0);
  TissueParams p;
  p.massFloorDt = 2e-3;  // heavy floor: the masses depend on k
  attachTissueProperties(base, p);
  {
    auto home = base.getVertexProperty<Vec3>(kHomeProp);
    for (auto v : base.vertices()) home[v] += Vec3(0.1 * std::sin(v.idx()), 0.2 * std::cos(3.0 * v.idx()), 0.0);
  }
  const std::vector<mesh::Vertex> list = {mesh::Vertex(8u), mesh::Vertex(9u), mesh::Vertex(16u),
                                          mesh::Vertex(),   mesh::Vertex(9u), mesh::Vertex(30u)};
  auto perVertex = base, batch = base;
  for (mesh::Vertex v : list) {
    if (!perVertex.isValid(v)) continue;
    for (mesh::Edge e : perVertex.edges(v)) initEdge(perVertex, e, p);
    const mesh::Vertex one[1] = {v};
    redistributeMass(perVertex, one, p);
  }
  initEdgesAround(batch, list, p);
  auto rest = [](const mesh::SurfaceMesh& m) { return m.getEdgeProperty<double>(kRestProp).vector(); };
  auto k = [](const mesh::SurfaceMesh& m) { return m.getEdgeProperty<double>(kStiffnessProp).vector(); };
  auto mass = [](const mesh::SurfaceMesh& m) { return m.getVertexProperty<double>(kMassProp).vector(); };
  EXPECT_EQ(rest(batch), rest(perVertex));
  EXPECT_EQ(k(batch), k(perVertex));
  EXPECT_EQ(mass(batch), mass(perVertex));
  EXPECT_NE(rest(batch), rest(base)) << "the springs around the listed vertices were stale";
  EXPECT_NE(mass(batch), mass(base));
  mesh::SurfaceMesh bare = makeGrid(2, 2, 1.0);
  EXPECT_THROW(initEdgesAround(bare, list, p), MissingPropertyError);
}

// copyVertexState then initEdgesAround of the copy and the original (what the cutter
// does once its edit is complete) gives bit for bit what initVertexCopy then the same
// initEdgesAround gives: home and velocity copied, force zeroed, springs and masses from
// the final faces.
TEST(TissueProperties, CopyStateThenBatchHookEqualsInitVertexCopy) {
  auto base = makeGrid(6, 6, 2.0);
  TissueParams p;
  p.massFloorDt = 2e-3;
  attachTissueProperties(base, p);
  const mesh::Vertex v(17u);
  {
    auto vel = base.getVertexProperty<Vec3>(kVelocityProp);
    auto force = base.getVertexProperty<Vec3>(kForceProp);
    vel[v] = Vec3(1.0, -2.0, 0.5);
    force[v] = Vec3(3.0, 0.0, 0.0);
  }
  // Split v: the faces on one side of a line through it go to a copy.
  std::vector<mesh::Face> fan;
  for (mesh::Face f : base.faces(v))
    if (base.centroid(f).y() > base.position(v).y()) fan.push_back(f);
  ASSERT_FALSE(fan.empty());
  auto full = base, light = base;
  const mesh::Vertex a = full.splitVertex(v, fan), b = light.splitVertex(v, fan);
  ASSERT_TRUE(a.isValid());
  ASSERT_EQ(a, b);
  initVertexCopy(full, a, v, p);
  copyVertexState(light, b, v);
  const std::vector<mesh::Vertex> both = {v, a};
  initEdgesAround(full, both, p);
  initEdgesAround(light, both, p);
  EXPECT_EQ(light.getVertexProperty<Vec3>(kHomeProp)[b], full.getVertexProperty<Vec3>(kHomeProp)[a]);
  EXPECT_EQ(light.getVertexProperty<Vec3>(kVelocityProp)[b], Vec3(1.0, -2.0, 0.5));
  EXPECT_EQ(light.getVertexProperty<Vec3>(kForceProp)[b], Vec3::Zero());
  EXPECT_EQ(light.getEdgeProperty<double>(kRestProp).vector(), full.getEdgeProperty<double>(kRestProp).vector());
  EXPECT_EQ(light.getEdgeProperty<double>(kStiffnessProp).vector(),
            full.getEdgeProperty<double>(kStiffnessProp).vector());
  EXPECT_EQ(light.getVertexProperty<double>(kMassProp).vector(), full.getVertexProperty<double>(kMassProp).vector());
  EXPECT_LT(light.getVertexProperty<double>(kMassProp)[v], base.getVertexProperty<double>(kMassProp)[v])
      << "the original lost the copy's faces";
  mesh::SurfaceMesh bare = makeGrid(2, 2, 1.0);
  EXPECT_THROW(copyVertexState(bare, mesh::Vertex(1u), mesh::Vertex(0u)), MissingPropertyError);
}

// One TissueHandles kept across many hooks and edits (as the cutter keeps it) gives bit
// for bit what the hooks that look the properties up each time give; it follows its
// mesh when a property is removed and added back (new arrays: the old views would
// dangle), and a hook on a mesh without the properties still throws.
TEST(TissueProperties, KeptHandlesEqualLookupsAndFollowPropertyChanges) {
  auto base = makeGrid(6, 6, 2.0);
  TissueParams p;
  p.massFloorDt = 2e-3;
  attachTissueProperties(base, p);
  auto plain = base, kept = base;
  TissueHandles handles;
  // Splits the edge x-(x+1) and a face at x+7.
  auto edit = [&](mesh::SurfaceMesh& m, bool useKept, std::uint32_t x) {
    const mesh::Edge e = m.findEdge(mesh::Vertex(x), mesh::Vertex(x + 1));
    ASSERT_TRUE(e.isValid());
    const mesh::Vertex a = m.vertex(e, 0), b = m.vertex(e, 1);
    const mesh::Vertex v = m.splitEdge(e, 0.5 * (m.position(a) + m.position(b)));
    const mesh::Face f = *m.faces(mesh::Vertex(x + 7)).begin();
    const auto corners = m.vertices(f);
    const Vec3 bary(0.2, 0.3, 0.5);
    const mesh::Vertex w = m.splitFace(
        f, bary[0] * m.position(corners[0]) + bary[1] * m.position(corners[1]) + bary[2] * m.position(corners[2]));
    if (useKept) {
      initVertexOnEdge(m, handles.of(m), v, a, b, 0.5, p);
      initVertexInFace(m, handles.of(m), w, corners[0], corners[1], corners[2], bary, p);
      const std::vector<mesh::Vertex> around = {a, b, w};
      initEdgesAround(m, handles.of(m), around, p);
    } else {
      initVertexOnEdge(m, v, a, b, 0.5, p);
      initVertexInFace(m, w, corners[0], corners[1], corners[2], bary, p);
      const std::vector<mesh::Vertex> around = {a, b, w};
      initEdgesAround(m, around, p);
    }
  };
  auto expectSame = [&](const char* when) {
    EXPECT_EQ(kept.getVertexProperty<Vec3>(kHomeProp).vector(), plain.getVertexProperty<Vec3>(kHomeProp).vector())
        << when;
    EXPECT_EQ(kept.getVertexProperty<double>(kMassProp).vector(), plain.getVertexProperty<double>(kMassProp).vector())
        << when;
    EXPECT_EQ(kept.getEdgeProperty<double>(kRestProp).vector(), plain.getEdgeProperty<double>(kRestProp).vector())
        << when;
    EXPECT_EQ(kept.getEdgeProperty<double>(kStiffnessProp).vector(),
              plain.getEdgeProperty<double>(kStiffnessProp).vector())
        << when;
  };
  edit(plain, false, 15);
  edit(kept, true, 15);
  expectSame("first edit");
  // The masses as they were, the array replaced: kept handles must look it up again.
  for (auto* m : {&plain, &kept}) {
    const auto masses = m->getVertexProperty<double>(kMassProp).vector();
    m->removeVertexProperty(kMassProp);
    m->addVertexProperty<double>(kMassProp, 0.0).vector() = masses;
  }
  edit(plain, false, 8);
  edit(kept, true, 8);
  expectSame("after the mass array was replaced");
  EXPECT_GT(kept.getVertexProperty<double>(kMassProp)[mesh::Vertex(15u)], 0.0);
  kept.removeEdgeProperty(kRestProp);
  EXPECT_THROW(initEdge(kept, handles.of(kept), *kept.edges().begin(), p), MissingPropertyError);
  mesh::SurfaceMesh bare = makeGrid(2, 2, 1.0);
  EXPECT_THROW(initEdge(bare, handles.of(bare), *bare.edges().begin(), p), MissingPropertyError);
}

// Spring and home forces on v (no damping, no external force) [mN].
Vec3 balanceForce(const mesh::SurfaceMesh& m, mesh::Vertex v, const TissueParams& p) {
  auto home = m.getVertexProperty<Vec3>(kHomeProp);
  auto rest = m.getEdgeProperty<double>(kRestProp);
  auto k = m.getEdgeProperty<double>(kStiffnessProp);
  Vec3 f = p.homeK * (home[v] - m.position(v));
  for (auto e : m.edges(v)) {
    const Vec3 d = m.position(m.otherVertex(e, v)) - m.position(v);
    f += k[e] * (d.norm() - rest[e]) * d.normalized();
  }
  return f;
}

// A pre-stretched grid brought to rest; returns its vertex nearest (4, 4), moved off
// its balance (0.3 mm in the sheet, 0.2 mm out of it) and no longer flagged settled,
// as a cut leaves a vertex it adds; `rest` gets where it balances.
mesh::Vertex offBalance(mesh::SurfaceMesh& m, const TissueParams& p, Vec3& rest) {
  attachTissueProperties(m, p);
  Params pp;
  pp.tissue = p;
  Dynamics d;
  // A 1 mm grid is too stiff for the default 1 ms: the monitor rejects steps, it never
  // settles, and `rest` would only be where it stopped (rounding then moves it).
  SettleOptions so;
  so.dt = 1e-4;
  EXPECT_TRUE(settle(pp, d, m, so).converged);
  EXPECT_TRUE(unsettledVertices(m).empty());  // (the first call marks every vertex settled)
  const auto v = nearestVertex(m, Vec3(4, 4, 0));
  rest = m.position(v);
  m.position(v) += Vec3(0.3, 0.0, 0.2);
  m.getVertexProperty<std::uint8_t>(kSettledProp)[v] = 0;
  return v;
}

// The scan finds every unsettled vertex, in index order: the first, a run of them, the
// last, and none kept on the blade.
TEST(TissueProperties, UnsettledVerticesAreFoundAnywhere) {
  auto m = makeGrid(8, 8, 1.0);
  EXPECT_TRUE(unsettledVertices(m).empty());  // marks all settled
  auto flag = m.getVertexProperty<std::uint8_t>(kSettledProp);
  const std::uint32_t n = static_cast<std::uint32_t>(m.verticesSize());
  std::vector<mesh::Vertex> want;
  for (std::uint32_t i : {0u, 17u, 18u, 19u, 40u, n - 2, n - 1}) {
    flag[mesh::Vertex(i)] = 0;
    want.emplace_back(i);
  }
  EXPECT_EQ(unsettledVertices(m), want);
  // Kept: a point on vertex 18.
  const std::vector<Vec3> keep{m.position(mesh::Vertex(18u))};
  std::vector<mesh::Vertex> less = want;
  less.erase(less.begin() + 2);
  EXPECT_EQ(unsettledVertices(m, keep), less);
  for (mesh::Vertex v : want) flag[v] = 1;
  EXPECT_TRUE(unsettledVertices(m).empty());
}

TEST(TissueProperties, SettlingPutsACutVertexWhereItsSpringsBalance) {
  TissueParams p;
  auto m = makeGrid(8, 8, 1.0);
  Vec3 rest;
  const auto v = offBalance(m, p, rest);
  EXPECT_EQ(unsettledVertices(m), std::vector<mesh::Vertex>{v});
  const Vec3 at = m.position(v);
  EXPECT_TRUE(unsettledVertices(m, std::vector<Vec3>{at}).empty());  // a tip on the blade is left
  EXPECT_EQ(unsettledVertices(m, std::vector<Vec3>{rest}), std::vector<mesh::Vertex>{v});
  auto vel = m.getVertexProperty<Vec3>(kVelocityProp);
  Vec3 mean = Vec3::Zero();
  int n = 0;
  for (auto e : m.edges(v)) {
    const auto w = m.otherVertex(e, v);
    vel[w] = Vec3(1.0 * w.idx(), -2.0, 0.5);
    mean += vel[w];
    ++n;
  }
  vel[v] = Vec3(100, 100, 100);
  const std::vector<Vec3> before = m.positions();
  const double f0 = balanceForce(m, v, p).norm();
  ASSERT_GT(f0, 5.0);  // mN: well off its balance

  TissueParams none = p;
  none.settleSweeps = 0;  // only marks it
  auto copy = m;
  settleVertices(copy, std::vector<mesh::Vertex>{v}, none);
  EXPECT_TRUE(ld::test::nearVec(copy.position(v), at, 0.0));
  EXPECT_TRUE(unsettledVertices(copy).empty());

  settleVertices(m, std::vector<mesh::Vertex>{v}, p);
  EXPECT_LT(balanceForce(m, v, p).norm(), 1e-2 * f0);  // (10 passes)
  EXPECT_TRUE(ld::test::nearVec(m.position(v), rest, 0.01)) << (m.position(v) - rest).norm();
  for (auto w : m.vertices()) {
    if (w == v) continue;
    EXPECT_TRUE(ld::test::nearVec(m.position(w), before[w.idx()], 0.0)) << w.idx();
  }
  EXPECT_TRUE(ld::test::nearVec(vel[v], mean / n, 1e-12));
  EXPECT_TRUE(unsettledVertices(m).empty());
  // More passes, closer to the balance.
  auto more = copy, fewer = copy;
  TissueParams many = p, few = p;
  many.settleSweeps = 40;
  few.settleSweeps = 2;
  settleVertices(more, std::vector<mesh::Vertex>{v}, many);
  settleVertices(fewer, std::vector<mesh::Vertex>{v}, few);
  EXPECT_LT(balanceForce(more, v, p).norm(), balanceForce(fewer, v, p).norm());
}

TEST(TissueProperties, SettlingDoesNotFoldTheSurface) {
  // A vertex split into a face near one corner of a pre-stretched sheet at rest: its
  // springs' balance (directions frozen) lies past that corner's edge, where its small
  // face would turn over. Settling stops short: no face of it turns by 60° or more.
  TissueParams p;
  auto m = makeGrid(4, 4, 2.0);
  attachTissueProperties(m, p);
  Params pp;
  pp.tissue = p;
  Dynamics d;
  (void)settle(pp, d, m);
  (void)unsettledVertices(m);
  const auto c = nearestVertex(m, Vec3(4, 4, 0));
  const mesh::Face f = m.faces(c).front();
  const Vec3 bary(0.8, 0.1, 0.1);
  Vec3 at = Vec3::Zero();
  for (int i = 0; i < 3; ++i) at += bary[i] * m.position(m.vertices(f)[static_cast<std::size_t>(i)]);
  const auto v = m.splitFace(f, at);
  ASSERT_TRUE(v.isValid());
  initVertexInFace(m, v, f, bary, p);
  std::vector<std::pair<mesh::Face, Vec3>> normals;
  for (auto g : m.faces(v)) normals.emplace_back(g, m.faceNormal(g));
  // Unguarded, the balance turns a face over (the case the guard is for).
  auto free = m;
  {
    auto home = free.getVertexProperty<Vec3>(kHomeProp);
    auto rest = free.getEdgeProperty<double>(kRestProp);
    auto k = free.getEdgeProperty<double>(kStiffnessProp);
    for (int sweep = 0; sweep < p.settleSweeps; ++sweep) {
      const Vec3 x = free.position(v);
      Vec3 num = p.homeK * home[v];
      double den = p.homeK;
      for (auto e : free.edges(v)) {
        const Vec3 y = free.position(free.otherVertex(e, v));
        num += k[e] * (y + rest[e] / (x - y).norm() * (x - y));
        den += k[e];
      }
      free.position(v) = num / den;
    }
    double worst = 1.0;
    for (const auto& [g, n0] : normals) worst = std::min(worst, free.faceNormal(g).dot(n0));
    ASSERT_LT(worst, 0.5);
  }
  const double f0 = balanceForce(m, v, p).norm();
  settleVertices(m, unsettledVertices(m), p);
  for (const auto& [g, n0] : normals) EXPECT_GE(m.faceNormal(g).dot(n0), 0.5);
  EXPECT_LT(balanceForce(m, v, p).norm(), f0);  // still nearer its balance
  EXPECT_TRUE(m.validate().ok());
}

TEST(TissueProperties, SettledCutVertexDoesNotRing) {
  // Stepped from where it was left, the vertex springs toward its balance and rings
  // under a tissue's light damping; settled, it stays nearly still.
  TissueParams p;
  p.damping = 2.0;  // the bundled tasks' tissue
  p.massFloorDt = 1e-3;
  auto ringing = makeGrid(8, 8, 1.0);
  Vec3 rest;
  const auto v = offBalance(ringing, p, rest);
  auto settled = ringing;
  settleVertices(settled, unsettledVertices(settled), p);
  Params pp;
  pp.tissue = p;
  // The vertex's fastest speed over 0.2 s [mm/s].
  auto fastest = [&](mesh::SurfaceMesh& m) {
    Dynamics d;
    double top = 0.0;
    for (int i = 0; i < 200; ++i) {
      (void)step(pp, d, m, 1e-3);
      top = std::max(top, m.getVertexProperty<Vec3>(kVelocityProp)[v].norm());
    }
    return top;
  };
  const double rings = fastest(ringing), stays = fastest(settled);
  EXPECT_GT(rings, 50.0);  // mm/s
  EXPECT_LT(stays, 0.1 * rings);
}

TEST(TissueProperties, SettlingNeedsTheProperties) {
  auto m = makeGrid(2, 2, 2.0);
  const std::vector<mesh::Vertex> one{nearestVertex(m, Vec3(2, 2, 0))};
  EXPECT_THROW(settleVertices(m, one, TissueParams{}), MissingPropertyError);
  EXPECT_NO_THROW(settleVertices(m, std::vector<mesh::Vertex>{}, TissueParams{}));
}

}  // namespace
}  // namespace ld::physics
