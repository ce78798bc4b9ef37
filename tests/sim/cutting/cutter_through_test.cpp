// Grooves that go through the bottom layer turn into cut-throughs (issue #4: "the
// state changes between them with depth"): pierce-in, slide-in and a groove that gets
// deeper mid-stroke, on the slab, the cube and the bundled organ.
#include <gtest/gtest.h>

#include "sim/cutting/cutter.h"
#include "sim/cutting/mesh_checks.h"
#include "sim/io/mesh_io.h"
#include "tests/sim/cutting/cut_test_meshes.h"
#include "tests/support/test_support.h"

namespace ld::cutting {
namespace {
using instruments::Tool;
using test::Vec3;

mesh::SurfaceMesh slab() { return test::makeBox(Vec3(0, 0, 0), Vec3(10, 10, 2), {10, 10, 2}); }
constexpr double kSlabArea = 2 * 100 + 4 * 20;

// Valid, manifold, closed, finite and without a membrane after every sample (every
// `every`-th on a big mesh).
auto soundEverySample(int every = 1) {
  return [every, n = 0](CutEngine& e) mutable {
    if (++n % every != 0) return;
    for (const auto& o : e.objects()) {
      const auto rep = o.mesh.validate();
      ASSERT_TRUE(rep.ok()) << "sample " << n << ": " << rep.message();
      const auto q = measureQuality(o.mesh);
      ASSERT_TRUE(q.manifoldVertices) << "sample " << n;
      ASSERT_TRUE(q.closed) << "sample " << n;
      ASSERT_TRUE(q.finite);
      ASSERT_EQ(q.components, 1) << "sample " << n;
      ASSERT_EQ(test::coincidentTrianglePairs(o.mesh), 0) << "sample " << n;
    }
    ASSERT_EQ(e.stats().fillFailures, 0) << "sample " << n;
  };
}

bool m0Sound(const CutEngine& e) {
  const auto& m = e.objects()[0].mesh;
  const auto q = measureQuality(m);
  return m.validate().ok() && q.closed && q.manifoldVertices && q.finite;
}

// The cut's area in its plane y = 5.3 of the slab for a tip at height z(x) (linear
// between the points; the cut reaches from the top z = 2 down to max(z, 0)).
double cutPlaneArea(const std::vector<Vec3>& pts) {
  double a = 0.0;
  for (std::size_t k = 0; k + 1 < pts.size(); ++k) {
    const int n = 2000;
    for (int i = 0; i < n; ++i) {
      const double s = (i + 0.5) / n;
      const Vec3 p = pts[k] + s * (pts[k + 1] - pts[k]);
      if (p.x() < 0.0 || p.x() > 10.0) continue;
      a += (2.0 - std::clamp(p.z(), 0.0, 2.0)) * std::abs(pts[k + 1].x() - pts[k].x()) / n;
    }
  }
  return a;
}

struct Case {
  const char* name;
  Tool tool;
  std::vector<Vec3> path;  // of the scalpel's tip (the hook's is 4 mm ahead of its foot)
};

std::vector<Vec3> shifted(std::vector<Vec3> p, double dx) {
  for (auto& x : p) x.x() += dx;
  return p;
}

// Pierce-in at the groove depth, deeper mid-stroke until the blade leaves the bottom,
// then on through: one piece with a hole, a groove behind the point where the blade
// went through and side walls after it.
const std::vector<Vec3> kDeepen{Vec3(2, 5.3, 1), Vec3(4, 5.3, 1), Vec3(6, 5.3, -1.1), Vec3(8, 5.3, -1.1)};

class CutterDeepen : public ::testing::TestWithParam<Tool> {};

TEST_P(CutterDeepen, GrooveThatGoesThroughTheBottomBecomesACutThrough) {
  const Tool tool = GetParam();
  CutEngine e;
  e.addObject(slab());
  test::polyStroke(e, tool == Tool::Hook ? shifted(kDeepen, 4.0) : kDeepen, Vec3(0, 0, -1), 20.0, 1000.0,
                   soundEverySample(), tool);
  ASSERT_EQ(e.objects().size(), 1u);
  const auto& m = e.objects()[0].mesh;
  EXPECT_EQ(test::eulerCharacteristic(m), 0) << "the blade went through: the slab has a hole";
  EXPECT_EQ(test::coincidentTrianglePairs(m), 0);
  EXPECT_GT(test::areaOfKind(m, kGrooveWall), 1.0) << "the groove before the blade went through stays";
  EXPECT_GT(test::areaOfKind(m, kSideWall), 6.0);
  EXPECT_GT(test::bottomEdgesOnSideWalls(m), 2) << "the bottom layer is open where the blade went through";
  EXPECT_TRUE(ld::test::near(test::areaOfKind(m, kSurface), kSlabArea, 1e-9));
  // Both walls together: twice the cut's area in its plane (the groove bottom is a
  // polyline through the blade's depths: a little less).
  const double walls = test::areaOfKind(m, kGrooveWall) + test::areaOfKind(m, kSideWall);
  EXPECT_TRUE(ld::test::near(walls, 2.0 * cutPlaneArea(kDeepen), 0.0, 0.08)) << walls;
  EXPECT_EQ(e.stats().walkFailures, 0);
}

INSTANTIATE_TEST_SUITE_P(Tools, CutterDeepen, ::testing::Values(Tool::Scalpel, Tool::Hook),
                         [](const ::testing::TestParamInfo<Tool>& p) {
                           return std::string(p.param == Tool::Scalpel ? "Scalpel" : "Hook");
                         });

TEST(CutterThrough, PierceThroughBothLayersCutsASlot) {
  CutEngine e;
  e.addObject(slab());
  test::polyStroke(e, {Vec3(3, 5.3, -1), Vec3(7, 5.3, -1)}, Vec3(0, 0, -1), 20.0, 1000.0, soundEverySample());
  ASSERT_EQ(e.objects().size(), 1u);
  const auto& m = e.objects()[0].mesh;
  EXPECT_EQ(test::eulerCharacteristic(m), 0);
  EXPECT_EQ(test::areaOfKind(m, kGrooveWall), 0.0) << "no membrane, no groove: side walls only";

  // Two walls of 4 x 2 in the plane y = 5.3.
  EXPECT_TRUE(ld::test::near(test::areaOfKind(m, kSideWall), 16.0, 1e-9));
  EXPECT_TRUE(ld::test::near(test::areaOfKind(m, kSurface), kSlabArea, 1e-9));
  EXPECT_GT(test::bottomEdgesOnSideWalls(m), 2);
  // Every side-wall corner is on the blade's plane.
  const auto kind = m.getFaceProperty<int>(kFaceKindProp);
  for (auto f : m.faces()) {
    if (kind[f] != kSideWall) continue;
    for (auto v : m.vertices(f)) {
      EXPECT_TRUE(ld::test::near(m.position(v).y(), 5.3, 1e-9));
    }
  }
}

// A groove coming in over the side at the groove depth goes through the bottom and
// leaves at the far side: one piece (the groove's floor still holds the two sides
// together), no hole, the bottom open from where the blade went through.
TEST(CutterThrough, SlideInGrooveThatGoesThroughOutOfTheFarSide) {
  for (const Tool tool : {Tool::Scalpel, Tool::Hook}) {
    SCOPED_TRACE(tool == Tool::Hook ? "hook" : "scalpel");
    const std::vector<Vec3> path{Vec3(-1, 5.3, 1), Vec3(3, 5.3, 1), Vec3(5, 5.3, -1.1), Vec3(11, 5.3, -1.1)};
    CutEngine e;
    e.addObject(slab());
    test::polyStroke(e, tool == Tool::Hook ? shifted(path, 4.0) : path, Vec3(0, 0, -1), 20.0, 1000.0,
                     soundEverySample(3), tool);
    ASSERT_TRUE(m0Sound(e));
    ASSERT_EQ(e.objects().size(), 1u);
    const auto& m = e.objects()[0].mesh;
    EXPECT_EQ(test::eulerCharacteristic(m), 2);
    EXPECT_GT(test::bottomEdgesOnSideWalls(m), 2);
    EXPECT_TRUE(ld::test::near(test::areaOfKind(m, kSurface), kSlabArea, 1e-9));
    const double walls = test::areaOfKind(m, kGrooveWall) + test::areaOfKind(m, kSideWall);
    EXPECT_TRUE(ld::test::near(walls, 2.0 * cutPlaneArea(path), 0.0, 0.08)) << walls;
  }
}

struct Topology {
  std::vector<std::pair<std::size_t, std::size_t>> pieces;
  bool operator==(const Topology&) const = default;
};

// (The blade's end does not touch the bottom exactly at a sample here: whether a
// segment ending on a surface crosses it is decided by the collision tolerances.)
TEST(CutterThrough, SameDeepeningStrokeAt100HzAnd1kHzGivesTheSameTopology) {
  for (const auto& [path, tool] :
       {std::pair{kDeepen, Tool::Scalpel}, std::pair{shifted(kDeepen, 4.0), Tool::Hook},
        std::pair{std::vector<Vec3>{Vec3(-1, 5.3, 1), Vec3(3, 5.3, 1), Vec3(5, 5.3, -1.1), Vec3(11, 5.3, -1.1)},
                  Tool::Scalpel}}) {
    Topology t[2];
    for (int k = 0; k < 2; ++k) {
      CutEngine e;
      e.addObject(slab());
      test::polyStroke(
          e, path, Vec3(0, 0, -1), 20.0, k == 0 ? 100.0 : 1000.0, [](CutEngine&) {}, tool);
      for (const auto& o : e.objects()) t[k].pieces.emplace_back(o.mesh.nVertices(), o.mesh.nFaces());
      std::sort(t[k].pieces.begin(), t[k].pieces.end());
    }
    ASSERT_FALSE(t[0].pieces.empty());
    EXPECT_TRUE(t[0] == t[1]) << t[0].pieces[0].first << "/" << t[0].pieces[0].second << " vs " << t[1].pieces[0].first
                              << "/" << t[1].pieces[0].second;
  }
}

TEST(CutterThrough, CubeGrooveGoesThroughTheBottom) {
  CutEngine e;
  e.addObject(test::makeBox(Vec3(-2, -2, -2), Vec3(2, 2, 2), {3, 3, 3}));
  test::polyStroke(e, {Vec3(-1.2, 0.3, 0.5), Vec3(-0.2, 0.3, 0.5), Vec3(0.8, 0.3, -3), Vec3(1.4, 0.3, -3)},
                   Vec3(0, 0, -1), 20.0, 1000.0, soundEverySample());
  ASSERT_EQ(e.objects().size(), 1u);
  const auto& m = e.objects()[0].mesh;
  EXPECT_EQ(test::eulerCharacteristic(m), 0);
  EXPECT_GT(test::areaOfKind(m, kGrooveWall), 0.5);
  EXPECT_GT(test::areaOfKind(m, kSideWall), 1.0);
  EXPECT_GT(test::bottomEdgesOnSideWalls(m), 0);
  EXPECT_TRUE(ld::test::near(test::areaOfKind(m, kSurface), 6 * 16.0, 1e-9));
}

// The bundled organ (resources/models/organ.obj, closed, about 10 mm thick here): a
// groove along its rim deepens until the blade leaves the underside.
TEST(CutterThrough, OrganGrooveGoesThroughTheUnderside) {
  const auto file = ld::test::resourcesDir() / "models" / "organ.obj";
  mesh::SurfaceMesh organ = io::readMesh(file);
  ASSERT_TRUE(organ.isClosed());
  const double area0 = organ.area();
  const long chi0 = test::eulerCharacteristic(organ);
  CutEngine e;
  e.addObject(std::move(organ));
  test::polyStroke(e, {Vec3(-35, -27, 6), Vec3(-35, -25, 6), Vec3(-35, -22, -6), Vec3(-35, -19, -6)}, Vec3(0, 0, -1),
                   20.0, 1000.0, soundEverySample(25));
  EXPECT_TRUE(m0Sound(e));
  ASSERT_EQ(e.objects().size(), 1u);
  const auto& m = e.objects()[0].mesh;
  EXPECT_EQ(test::eulerCharacteristic(m), chi0 - 2) << "one hole more";
  EXPECT_EQ(test::coincidentTrianglePairs(m), 0);
  EXPECT_GT(test::areaOfKind(m, kGrooveWall), 1.0);
  EXPECT_GT(test::areaOfKind(m, kSideWall), 5.0);
  EXPECT_TRUE(ld::test::near(test::areaOfKind(m, kSurface), area0, 0.0, 1e-6));
  EXPECT_EQ(e.stats().walkFailures, 0);
}

}  // namespace
}  // namespace ld::cutting

namespace ld::cutting {
namespace {

// A circle cut out from the middle: the blade pierces both layers at the start, goes
// round and comes back to where it began (or 10 degrees on, over its start); the cut
// joins its own start (the slot's back end) as the hand lifts, and the disc comes free.
TEST(CutterThrough, CircleFromAPierceFreesTheDiscWhenItClosesOnItsStart) {
  for (const int extra : {0, 2}) {
    SCOPED_TRACE(extra);
    CutEngine e;
    e.addObject(test::makeBox(Vec3(0, 0, 0), Vec3(10, 10, 2), {10, 10, 2}));
    std::vector<Vec3> pts;
    const int n = 72;
    for (int i = 0; i <= n + extra; ++i) {
      const double a = 2.0 * M_PI * i / n;
      pts.emplace_back(5.0 + 2.5 * std::cos(a), 5.1 + 2.5 * std::sin(a), -1.0);
    }
    test::polyStroke(e, pts, Vec3(0, 0, -1), 20.0, 1000.0, soundEverySample());
    ASSERT_EQ(e.objects().size(), 2u) << "the disc stays attached";
    EXPECT_EQ(e.stats().separations, 1);
    EXPECT_EQ(e.stats().fillFailures, 0);
    EXPECT_EQ(e.stats().walkFailures, 0);
    // The disc: top and bottom pi r^2 each, its wall 2 pi r x 2 (a polygon: a little less).
    const bool first = e.objects()[0].mesh.area() < e.objects()[1].mesh.area();
    const auto& disc = e.objects()[first ? 0 : 1].mesh;
    const auto& kept = e.objects()[first ? 1 : 0].mesh;
    const double r = 2.5, want = 2.0 * M_PI * r * r + 2.0 * M_PI * r * 2.0;
    EXPECT_NEAR(disc.area(), want, 0.03 * want);
    // The slab keeps a hole through it: genus 1 (V - E + F = 0); the disc has none.
    EXPECT_EQ(test::eulerCharacteristic(kept), 0);
    EXPECT_EQ(test::eulerCharacteristic(disc), 2);
  }
}

}  // namespace
}  // namespace ld::cutting

namespace ld::cutting {
namespace {

// A slot from the side that ends in the middle, then a second stroke from the same side
// that turns and crosses it: the piece between the two cuts comes free where the second
// meets the first (its walk goes round the slot's wall as round a side of the object).
TEST(CutterThrough, SecondStrokeCrossingAnEarlierSlotFreesThePieceBetween) {
  CutEngine e;
  e.addObject(test::makeBox(Vec3(0, 0, 0), Vec3(10, 10, 2), {10, 10, 2}));
  test::polyStroke(e, {Vec3(-1, 3.3, -1), Vec3(7.3, 3.3, -1)}, Vec3(0, 0, -1), 20.0, 1000.0, soundEverySample());
  ASSERT_EQ(e.objects().size(), 1u);
  test::polyStroke(e, {Vec3(-1, 7.3, -1), Vec3(5.3, 7.3, -1), Vec3(5.3, 1.5, -1)}, Vec3(0, 0, -1), 20.0, 1000.0,
                   soundEverySample());
  ASSERT_EQ(e.objects().size(), 2u) << "the piece between the cuts stays attached";
  const bool first = e.objects()[0].mesh.area() < e.objects()[1].mesh.area();
  const auto& piece = e.objects()[first ? 0 : 1].mesh;
  // 5.3 x 4 x 2: top and bottom, four sides.
  const double want = 2 * 5.3 * 4.0 + 2 * (5.3 + 4.0) * 2.0;
  EXPECT_NEAR(piece.area(), want, 0.02 * want);
  EXPECT_EQ(test::eulerCharacteristic(piece), 2);
}

}  // namespace
}  // namespace ld::cutting
