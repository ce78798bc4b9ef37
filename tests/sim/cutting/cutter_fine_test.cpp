// Through-cuts on a fine mesh (cells of 0.44 mm, as on the 100k-triangle slab, smaller
// than the blade's path between the walls' sides): the side walls open at every step,
// the front between the layers stays short and every strip comes off.
#include <gtest/gtest.h>

#include <cmath>

#include "sim/cutting/cutter.h"
#include "sim/cutting/mesh_checks.h"
#include "tests/sim/cutting/cut_test_meshes.h"

namespace ld::cutting {
namespace {
using test::Vec3;

// 24 x 16 x 5 mm in cells of 0.44 x 0.44 x 1.25 mm (6.3k triangles).
mesh::SurfaceMesh fineSlab() { return test::makeBox(Vec3(-12, -8, -2.5), Vec3(12, 8, 2.5), {54, 36, 4}); }

void expectClosedPieces(const CutEngine& e, const char* when) {
  for (const auto& o : e.objects()) {
    const auto rep = o.mesh.validate();
    EXPECT_TRUE(rep.ok()) << when << ": " << rep.message();
    const auto q = measureQuality(o.mesh);
    EXPECT_TRUE(q.closed) << when;
    EXPECT_TRUE(q.manifoldVertices) << when;
    EXPECT_TRUE(q.finite) << when;
    EXPECT_EQ(q.components, 1) << when;
  }
}

// Straight strokes from side to side through both layers (100 mm/s at 1 kHz: 0.1 mm per
// sample, a quarter of a cell), each slightly oblique like the benchmark's.
TEST(CutterFine, ThroughCutsOnAFineSlabFreeEveryStripWithShortFronts) {
  CutEngine e;
  e.addObject(fineSlab());
  const double ys[] = {-5.3, -1.7, 2.15, 5.6};
  long cutBefore = 0, addedBefore = 0;
  double wallsBefore = 0.0;
  for (int s = 0; s < 4; ++s) {
    SCOPED_TRACE(s);
    test::stroke(e, Vec3(-15, ys[s], -4), Vec3(15, ys[s] + 0.9, -4), Vec3(0, 0, -1), 100.0, 1000.0);
    const auto& st = e.stats();
    EXPECT_EQ(st.separations, s + 1) << "the strip cut by stroke " << s << " stays attached";
    EXPECT_EQ(e.objects().size(), static_cast<std::size_t>(s + 2));
    expectClosedPieces(e, "after the stroke");
    // Two layers of ~68 crossed triangles each; every one gets its side walls: 2
    // surface + 2 wall triangles per edge crossing (3.8 on the coarse slab). A front
    // that grows instead adds no walls until the cut-out caps it (about 2.5).
    const long cut = st.trianglesCut - cutBefore, added = st.trianglesAdded - addedBefore;
    EXPECT_GT(cut, 100);
    const double perTri = static_cast<double>(added) / static_cast<double>(cut);
    EXPECT_GT(perTri, 3.4);
    EXPECT_LT(perTri, 4.4);
    // Side walls on both pieces over the whole cut: twice its area in its plane.
    double walls = 0.0;
    for (const auto& o : e.objects()) walls += test::areaOfKind(o.mesh, kSideWall);
    // (Up to 1 % more: snapping moves the paths off the blade's plane a little.)
    const double plane = 2.0 * 5.0 * 24.0 * std::hypot(1.0, 0.9 / 30.0);
    EXPECT_NEAR(walls - wallsBefore, plane, 0.01 * plane);
    wallsBefore = walls;
    cutBefore = st.trianglesCut;
    addedBefore = st.trianglesAdded;
    EXPECT_EQ(st.fillFailures, 0);
    EXPECT_EQ(st.walkFailures, 0);
  }
  // The cut-in path around the slab's side (about a dozen vertices) is the longest
  // front; a front that stays closed grows by one vertex per step (hundreds).
  EXPECT_LE(e.stats().longestFront, 24);
}

// Within the snapping distance of a row of mesh edges the path snaps onto their vertices
// all the way, and the tips end on the far side's edge: the walk around it runs down the
// front between the layers (a cut-out loop without area), which must still free the strip.
TEST(CutterFine, ThroughCutAlongMeshEdgesFreesItsStrip) {
  CutEngine e;
  e.addObject(fineSlab());
  const double y = -8.0 + 10.0 * 16.0 / 36.0 + 0.02;  // 0.02 mm off a grid line
  test::stroke(e, Vec3(-15, y, -4), Vec3(15, y, -4), Vec3(0, 0, -1), 100.0, 1000.0);
  EXPECT_EQ(e.stats().separations, 1);
  ASSERT_EQ(e.objects().size(), 2u);
  expectClosedPieces(e, "after the stroke");
  double walls = 0.0;
  for (const auto& o : e.objects()) walls += test::areaOfKind(o.mesh, kSideWall);
  EXPECT_NEAR(walls, 2.0 * 5.0 * 24.0, 0.01 * 240.0);
  EXPECT_LE(e.stats().longestFront, 24);
  EXPECT_EQ(e.stats().fillFailures, 0);
}

}  // namespace
}  // namespace ld::cutting
