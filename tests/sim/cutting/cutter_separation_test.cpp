// Separation by a local search from the cut (the pieces equal the full labelling's),
// the kept mesh's deferred compaction, and collision refits limited to the vertices
// that moved (CutEngine::verticesMoved, physics::movedVertices).
#include <algorithm>
#include <array>
#include <set>

#include <gtest/gtest.h>

#include "sim/collision/segment_triangle.h"
#include "sim/cutting/cutter.h"
#include "sim/physics/mass_spring.h"
#include "sim/physics/tissue_properties.h"
#include "tests/sim/cutting/cut_test_meshes.h"
#include "tests/support/test_support.h"

#define EXPECT_VALID(m) EXPECT_TRUE((m).validate().ok()) << (m).validate().message()

namespace ld::cutting {
namespace {
using test::Vec3;

mesh::SurfaceMesh smallSlab() { return test::makeBox(Vec3(-20, -15, -2.5), Vec3(20, 15, 2.5), {27, 20, 3}); }

// Through-cuts across the slab, one strip freed per stroke (the cutting bench's strokes).
template <class Check>
void stripStrokes(CutEngine& e, int strokes, Check&& check) {
  for (int s = 0; s < strokes; ++s) {
    const double y = -12.0 + 24.0 * (s + 0.37) / strokes;
    test::stroke(e, Vec3(-25, y, -4), Vec3(25, y + 1.3, -4), Vec3(0, 0, -1), 100.0, 500.0, check);
  }
}

struct Shape {
  std::size_t faces = 0, vertices = 0;
  double area = 0.0;
  int parent = -1;
  bool operator==(const Shape& o) const {
    return faces == o.faces && vertices == o.vertices && std::abs(area - o.area) < 1e-9 && parent == o.parent;
  }
};

std::vector<Shape> shapes(const CutEngine& e) {
  std::vector<Shape> out;
  for (const auto& o : e.objects()) out.push_back({o.mesh.nFaces(), o.mesh.nVertices(), o.mesh.area(), o.parent});
  return out;
}

// The engine finds the pieces from the edits since the object was last one piece. The
// reference engine's mesh gets a new layout after every sample (a copy assigned to
// itself: same elements, same numbering), which makes it fall back to the full
// labelling of every face at each check: both must free the same pieces.
TEST(CutterSeparation, LocalSearchFreesTheSamePiecesAsTheFullLabelling) {
  CutEngine local, full;
  local.addObject(smallSlab());
  full.addObject(smallSlab());
  std::vector<std::size_t> objectsAfterStroke;
  stripStrokes(local, 4, [](CutEngine&) {});
  stripStrokes(full, 4, [](CutEngine& e) {
    for (const auto& o : e.objects()) {
      mesh::SurfaceMesh& m = e.object(o.id).mesh;
      m = mesh::SurfaceMesh(m);
    }
  });
  ASSERT_EQ(local.stats().separations, 4) << "each through-cut frees its strip";
  EXPECT_EQ(full.stats().separations, 4);
  const auto a = shapes(local), b = shapes(full);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i)
    EXPECT_TRUE(a[i] == b[i]) << "object " << i << ": faces " << a[i].faces << " vs " << b[i].faces;
  for (const auto& o : local.objects()) {
    EXPECT_VALID(o.mesh);
    EXPECT_TRUE(o.mesh.isClosed());
    EXPECT_EQ(o.mesh.connectedComponents().count, 1) << "object " << o.id;
  }
  // The kept object is the largest one.
  for (const auto& o : local.objects()) EXPECT_GE(local.objects()[0].mesh.nFaces(), o.mesh.nFaces());
}

// The kept mesh is not compacted at every separation: the freed strip's faces stay as
// dead slots until they outnumber half the live faces, and the mesh cuts on.
TEST(CutterSeparation, KeptMeshIsCompactedOnlyWhenMostlyGarbage) {
  CutEngine e;
  e.addObject(smallSlab());
  bool sawGarbage = false;
  stripStrokes(e, 4, [&](CutEngine& eng) {
    const auto& m = eng.objects()[0].mesh;
    const double dead = static_cast<double>(m.facesSize() - m.nFaces());
    if (eng.objects().size() > 1 && dead > 0) sawGarbage = true;
    ASSERT_LE(dead, 0.5 * static_cast<double>(m.nFaces()) + 1e-9);
  });
  EXPECT_TRUE(sawGarbage) << "the first separation left the strip's faces as garbage";
  ASSERT_EQ(e.objects().size(), 5u);
  // Cut across every piece and the garbage-carrying kept mesh again.
  test::stroke(e, Vec3(3.1, -20, -4), Vec3(3.6, 20, -4), Vec3(0, 0, -1), 100.0, 1000.0);
  for (const auto& o : e.objects()) {
    EXPECT_VALID(o.mesh);
    EXPECT_TRUE(o.mesh.isClosed());
    EXPECT_EQ(o.mesh.connectedComponents().count, 1);
  }
  EXPECT_GT(e.objects().size(), 5u) << "the cross cut frees halves of the strips";
}

// The blade's contacts equal the brute-force crossings of its segment with the mesh.
void expectContactsAsBruteForce(CutEngine& e, int id, const instruments::Pose& pose) {
  const StepResult r = e.step(instruments::Hand::Left, instruments::Tool::Grasper, pose);
  const auto segs = instruments::segments(instruments::Tool::Grasper, pose, e.params().tool);
  std::size_t expected = 0;
  for (const auto& s : segs)
    for (const auto& h : collision::intersectSegment(e.objects()[static_cast<std::size_t>(id)].mesh, s.a, s.b))
      if (h.kind != collision::HitKind::Coplanar && h.direction != 0) ++expected;
  std::size_t got = 0;
  for (const auto& c : r.contacts)
    if (c.object == id) ++got;
  EXPECT_GT(expected, 0u);
  EXPECT_EQ(got, expected);
  e.endStroke(instruments::Hand::Left);
}

// The top vertices within 4 mm of (10, 10) raised by 3 mm (the slab of 20 x 20 x 2
// mm below); returns them.
std::vector<std::uint32_t> raisePatch(mesh::SurfaceMesh& m) {
  std::vector<std::uint32_t> moved;
  for (mesh::Vertex v : m.vertices()) {
    const Vec3 p = m.position(v);
    if (p.z() > 1.9 && (p.head<2>() - Eigen::Vector2d(10, 10)).norm() < 4.0) {
      m.position(v).z() += 3.0;
      moved.push_back(v.idx());
    }
  }
  return moved;
}

// Vertices moved and named: only the tree around them is refitted, and queries see
// the new surface (the raised patch is far outside its old boxes).
TEST(CutterMotion, VerticesMovedRefitsOnlyThemAndQueriesSeeTheMotion) {
  CutEngine e;
  const int id = e.addObject(test::makeBox(Vec3(0, 0, 0), Vec3(20, 20, 2), {16, 16, 2}));
  mesh::SurfaceMesh& m = e.meshToMove(id);
  const std::vector<std::uint32_t> moved = raisePatch(m);
  ASSERT_GT(moved.size(), 10u);
  e.verticesMoved(id, moved);
  // The grasper's (closed) jaws at z = 3.6 from x = 0 to 10: above the old top, into
  // the raised patch through its side.
  const instruments::Pose pose = test::scalpel(Vec3(10, 10, 3.6), Vec3(1, 0, 0), Vec3(0, 0, 1));
  expectContactsAsBruteForce(e, id, pose);
  EXPECT_EQ(e.stats().fullRefits, 0);
  EXPECT_EQ(e.stats().regionRefits, 1);
  EXPECT_EQ(e.stats().verticesRefitted, static_cast<long>(moved.size()));
  // Nothing named: nothing refitted.
  expectContactsAsBruteForce(e, id, pose);
  EXPECT_EQ(e.stats().regionRefits, 1);
  // "Everything may have moved": one full refit.
  for (mesh::Vertex v : m.vertices()) m.position(v).z() -= 1.0;
  e.verticesMoved(id);
  expectContactsAsBruteForce(e, id, pose);
  EXPECT_EQ(e.stats().fullRefits, 1);
}

TEST(CutterMotion, VerticesMovedRejectsMisuse) {
  CutEngine e;
  const int id = e.addObject(test::makeBox(Vec3(0, 0, 0), Vec3(2, 2, 2), {2, 2, 2}));
  const std::vector<std::uint32_t> bad{100000};
  EXPECT_THROW(e.verticesMoved(id, bad), CutError);
  EXPECT_THROW(e.verticesMoved(id + 7, {}), CutError);
  EXPECT_THROW((void)e.meshToMove(id + 7), CutError);
}

// Physics in active-region mode names what its step moved; the engine refits only that.
TEST(CutterMotion, ActiveRegionPhysicsNamesTheMovedVertices) {
  physics::TissueParams tissue;
  tissue.massFloorDt = 1e-3;  // stable 1 ms steps (as the cut command runs them)
  mesh::SurfaceMesh slab = test::makeBox(Vec3(0, 0, 0), Vec3(20, 20, 2), {16, 16, 2});
  physics::attachTissueProperties(slab, tissue);
  CutEngine e;
  const int id = e.addObject(std::move(slab));
  mesh::SurfaceMesh& m = e.meshToMove(id);
  physics::Params pp;
  pp.tissue = tissue;
  physics::Dynamics dyn;
  ASSERT_GT(m.nVertices(), 100u);
  physics::step(pp, dyn, m, 1e-3);
  ASSERT_GT(m.nVertices(), 100u);
  EXPECT_FALSE(physics::movedVertices(dyn).has_value()) << "a full step moves everything";
  pp.active.enabled = true;
  // Settles and falls asleep (the pre-stretch pulls for a while).
  for (int i = 0; i < 20000; ++i) {
    physics::step(pp, dyn, m, 1e-3);
    if (physics::movedVertices(dyn)->empty()) break;
  }
  ASSERT_TRUE(physics::movedVertices(dyn)->empty()) << "the slab fell asleep";
  // Push one top vertex down: a region wakes around it.
  {
    std::size_t live = 0, finite = 0;
    for (mesh::Vertex v : m.vertices()) {
      ++live;
      finite += m.position(v).cwiseAbs().maxCoeff() < 100.0 ? 1 : 0;
    }
    ASSERT_EQ(live, m.nVertices());
    ASSERT_EQ(finite, live) << "the settled slab stays in place";
  }
  mesh::Vertex pushed;
  double best = 1e9;
  for (mesh::Vertex v : m.vertices())
    if (const double d = (m.position(v) - Vec3(10, 10, 3)).norm(); d < best) {
      best = d;
      pushed = v;
    }
  ASSERT_TRUE(pushed.isValid());
  const double z0 = m.position(pushed).z();
  m.vertexProperty<Eigen::Vector3d>(physics::kForceProp, Eigen::Vector3d::Zero())[pushed] = Vec3(0, 0, -5);
  long regionSteps = 0;
  std::set<std::uint32_t> all;
  for (int i = 0; i < 10; ++i) {
    const std::vector<Eigen::Vector3d> before = m.positions();
    physics::step(pp, dyn, m, 1e-3);
    const auto moved = physics::movedVertices(dyn);
    ASSERT_TRUE(moved.has_value());
    const std::set<std::uint32_t> listed(moved->begin(), moved->end());
    for (mesh::Vertex v : m.vertices())
      if (m.position(v) != before[v.idx()]) {
        ASSERT_TRUE(listed.count(v.idx())) << v << " moved, not listed";
      }
    if (moved->size() < m.nVertices()) ++regionSteps;
    all.insert(moved->begin(), moved->end());
    e.verticesMoved(id, *moved);
  }
  EXPECT_GT(regionSteps, 0) << "some steps moved only a region";
  ASSERT_LT(2 * all.size(), m.nVertices()) << "a region, not most of the slab";
  EXPECT_LT(m.position(pushed).z(), z0 - 1e-3);
  // Jaws level through the dip, from inside the tissue into it.
  const Vec3 at = m.position(pushed);
  const instruments::Pose pose =
      test::scalpel(Vec3(at.x() + 3, at.y() + 0.05, 0.5 * (at.z() + z0)), Vec3(1, 0, 0), Vec3(0, 0, 1));
  expectContactsAsBruteForce(e, id, pose);
  EXPECT_EQ(e.stats().fullRefits, 0);
}

// What a run of the engine ended with, to compare runs to the bit.
struct CutOutcome {
  std::vector<Eigen::Vector3d> x;
  std::vector<std::array<std::uint32_t, 3>> faces;
  CutStats stats;
  explicit CutOutcome(const CutEngine& e) : stats(e.stats()) {
    for (const auto& obj : e.objects()) {
      x.insert(x.end(), obj.mesh.positions().begin(), obj.mesh.positions().end());
      for (mesh::Face f : obj.mesh.faces()) {
        const auto& vs = obj.mesh.vertices(f);
        faces.push_back({vs[0].idx(), vs[1].idx(), vs[2].idx()});
      }
    }
  }
};

// Fat collision boxes (CutParams::collisionMargin) change only the pruning: with the
// tissue moving under physics every sample (a pre-stretched slab that gapes as it is
// cut), cuts with them end with exactly the mesh that full refits give, with or
// without the physics' bound on the moves, and no full refit is done.
TEST(CutterMotion, FatCollisionBoxesCutExactlyAsFullRefits) {
  auto run = [](double margin, bool bound) {
    physics::TissueParams tissue;
    CutParams params;
    params.tissue = tissue;
    params.collisionMargin = margin;
    mesh::SurfaceMesh m = test::makeBox(Vec3(0, 0, 0), Vec3(20, 20, 2), {16, 16, 2});
    physics::attachTissueProperties(m, tissue);
    CutEngine e(params);
    const int id = e.addObject(std::move(m));
    physics::Params pp;
    physics::Dynamics dyn;
    auto stepPhysics = [&](CutEngine& eng) {
      physics::step(pp, dyn, eng.meshToMove(id), 1e-3);
      if (bound)
        eng.verticesMovedWithin(id, dyn.maxMove);
      else
        eng.verticesMoved(id);
    };
    test::stroke(e, Vec3(5, 10.3, -1), Vec3(15, 10.3, -1), Vec3(0, 0, -1), 50.0, 1000.0, stepPhysics);
    for (int i = 0; i < 100; ++i) stepPhysics(e);  // the cut gapes
    test::stroke(e, Vec3(10.2, 4, -1), Vec3(10.2, 16, -1), Vec3(0, 0, -1), 50.0, 1000.0, stepPhysics);
    return CutOutcome(e);
  };
  const CutOutcome full = run(0.0, false);
  ASSERT_GT(full.stats.trianglesCut, 10);
  EXPECT_GT(full.stats.fullRefits, 100);
  for (const bool bound : {false, true}) {
    const CutOutcome fat = run(0.25, bound);
    EXPECT_EQ(fat.stats.fullRefits, 0) << "bound " << bound;
    EXPECT_GT(fat.stats.marginRefits, 100) << "bound " << bound;
    EXPECT_EQ(fat.stats.trianglesCut, full.stats.trianglesCut) << "bound " << bound;
    EXPECT_EQ(fat.faces, full.faces) << "bound " << bound;
    EXPECT_EQ(fat.x, full.x) << "bound " << bound;
  }
}

// Vertices named as moved (settled by the cutter, or an active region's step) and
// then a bound for the whole tissue that fits in the boxes' slack: the named ones
// were not under that bound and are refitted all the same.
TEST(CutterMotion, NamedMovesAreKeptUnderAMoveBound) {
  CutParams params;
  params.collisionMargin = 0.25;
  CutEngine e(params);
  const int id = e.addObject(test::makeBox(Vec3(0, 0, 0), Vec3(20, 20, 2), {16, 16, 2}));
  mesh::SurfaceMesh& m = e.meshToMove(id);
  const std::vector<std::uint32_t> moved = raisePatch(m);
  ASSERT_GT(moved.size(), 10u);
  e.verticesMoved(id, moved);
  e.verticesMovedWithin(id, 1e-4);  // the rest moved by at most 0.1 µm
  const instruments::Pose pose = test::scalpel(Vec3(10, 10, 3.6), Vec3(1, 0, 0), Vec3(0, 0, 1));
  expectContactsAsBruteForce(e, id, pose);
  EXPECT_EQ(e.stats().regionRefits, 1);
  EXPECT_EQ(e.stats().fullRefits, 0);
  // The other order: the bound first, then the names.
  for (std::uint32_t v : moved) m.position(mesh::Vertex(v)).z() += 1.0;
  e.verticesMovedWithin(id, 1e-4);
  e.verticesMoved(id, moved);
  expectContactsAsBruteForce(e, id, pose);
  EXPECT_EQ(e.stats().regionRefits, 2);
}

// Physics in active-region mode on a slab asleep (balanced), a groove cut into it:
// the engine is told each step's awake list. With fat boxes only the listed vertices
// that left half the margin are refitted, and the cut is the one tight boxes give.
TEST(CutterMotion, ActiveRegionListsWithFatBoxesCutAsTightBoxes) {
  auto run = [](double margin) {
    physics::TissueParams tissue;
    tissue.massFloorDt = 1e-3;
    CutParams params;
    params.tissue = tissue;
    params.collisionMargin = margin;
    mesh::SurfaceMesh m = test::makeBox(Vec3(0, 0, 0), Vec3(40, 40, 2), {32, 32, 2});
    physics::attachTissueProperties(m, tissue);
    CutEngine e(params);
    const int id = e.addObject(std::move(m));
    physics::Params pp;
    pp.tissue = tissue;
    pp.active.enabled = true;
    physics::Dynamics dyn;
    auto stepPhysics = [&](CutEngine& eng) {
      physics::step(pp, dyn, eng.meshToMove(id), 1e-3);
      if (const auto listed = physics::movedVertices(dyn))
        eng.verticesMoved(id, *listed);
      else
        eng.verticesMoved(id);
    };
    for (int i = 0; i < 20000; ++i) {
      stepPhysics(e);
      if (physics::movedVertices(dyn)->empty()) break;
    }
    EXPECT_TRUE(physics::movedVertices(dyn)->empty()) << "the slab fell asleep";
    test::stroke(e, Vec3(16, 20.3, 1.0), Vec3(24, 20.3, 1.0), Vec3(0, 0, -1), 50.0, 1000.0, stepPhysics);
    for (int i = 0; i < 100; ++i) stepPhysics(e);  // the groove opens
    return CutOutcome(e);
  };
  const CutOutcome tight = run(0.0);
  const CutOutcome fat = run(0.25);
  ASSERT_GT(tight.stats.trianglesCut, 10);
  EXPECT_GT(fat.stats.regionRefits, 50) << "the stroke's steps moved a region, not most of the slab";
  EXPECT_GT(fat.stats.verticesRefitted, 20 * fat.stats.regionRefits) << "regions of some size";
  EXPECT_GT(fat.stats.verticesReanchored, 0) << "those past half the margin are refitted";
  EXPECT_LT(10 * fat.stats.verticesReanchored, fat.stats.verticesRefitted) << "most listed moves stay in the margin";
  EXPECT_EQ(fat.stats.trianglesCut, tight.stats.trianglesCut);
  EXPECT_EQ(fat.faces, tight.faces);
  EXPECT_EQ(fat.x, tight.x);
}

}  // namespace
}  // namespace ld::cutting
