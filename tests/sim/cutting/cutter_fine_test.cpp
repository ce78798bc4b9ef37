// Through-cuts on a fine mesh (cells of 0.44 mm, as on the 100k-triangle slab, smaller
// than the blade's path between the walls' sides): the side walls open at every step,
// the front between the layers stays short and every strip comes off.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

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

namespace ld::cutting {
namespace {

struct SweepCase {
  double speed, tiltDeg, tiltAzDeg, entryDeg, y;
};

// One stroke on a fresh fine slab: enters over the side x = -12 at height y with the
// stroke direction `entryDeg` off the side's normal (toward +y), blade tilted by tiltDeg
// toward azimuth tiltAzDeg (0: along the motion). Returns whether the strip came off.
bool sweepStroke(const SweepCase& c, long* walkFailures) {
  CutEngine e;
  e.addObject(fineSlab());
  const double a = c.entryDeg * M_PI / 180.0;
  const Vec3 d(std::cos(a), std::sin(a), 0.0);
  const Vec3 side(-d.y(), d.x(), 0.0);
  const double t = c.tiltDeg * M_PI / 180.0, az = c.tiltAzDeg * M_PI / 180.0;
  const Vec3 lean = std::cos(az) * d + std::sin(az) * side;
  const Vec3 dir = (Vec3(0, 0, -1) * std::cos(t) + lean * std::sin(t)).normalized();
  const Vec3 entry(-12.0, c.y, 0.0);
  // Leave the box: the first side the line reaches.
  double tx = d.x() > 1e-9 ? (12.0 - entry.x()) / d.x() : 1e300;
  double ty = d.y() > 1e-9 ? (8.0 - entry.y()) / d.y() : (d.y() < -1e-9 ? (-8.0 - entry.y()) / d.y() : 1e300);
  const double len = std::min(tx, ty);
  // The blade passes the line's points at z = 0; its tip is at z = -4 (under the slab).
  const Vec3 toTip = dir * (4.0 / -dir.z());
  const Vec3 tip0 = entry - 3.0 * d + toTip, tip1 = entry + (len + 3.0) * d + toTip;
  test::stroke(e, tip0, tip1, dir, c.speed, 1000.0);
  for (const auto& o : e.objects()) {
    const auto rep = o.mesh.validate();
    EXPECT_TRUE(rep.ok()) << rep.message();
  }
  if (walkFailures) *walkFailures += e.stats().walkFailures;
  return e.stats().separations == 1 && e.objects().size() == 2u;
}

TEST(CutterFine, SweepTiltedAndObliqueStrokes) {
  if (const char* one = std::getenv("LD_CUT_FINE_CASE")) {
    SweepCase c{};
    std::sscanf(one, "%lf,%lf,%lf,%lf,%lf", &c.speed, &c.tiltDeg, &c.tiltAzDeg, &c.entryDeg, &c.y);
    long wf = 0;
    const bool ok = sweepStroke(c, &wf);
    std::cout << (ok ? "freed" : "not freed") << ", walk failures " << wf << "\n";
    return;
  }
  const char* env = std::getenv("LD_CUT_FINE_SWEEP");
  if (!env) GTEST_SKIP();
  std::vector<double> tilts{0, 3, 6, 10}, azs{0, 90, 180, 270}, entries{0, 30, 45, 60}, speeds{20, 100, 250};
  std::vector<double> ys{-5.3, -1.7, 2.15};
  for (double tilt : tilts)
    for (double entry : entries) {
      int freed = 0, total = 0;
      long wf = 0;
      for (double az : azs) {
        if (tilt == 0 && az != 0) continue;
        for (double sp : speeds)
          for (double y : ys) {
            SweepCase c{sp, tilt, az, entry, entry > 40 ? y - 2.0 : y};
            const bool ok = sweepStroke(c, &wf);
            freed += ok;
            ++total;
            if (!ok && std::string(env) == "2")
              std::cout << "  miss: speed " << sp << " tilt " << tilt << " az " << az << " entry " << entry << " y "
                        << c.y << "\n";
          }
      }
      std::cout << "tilt " << tilt << " entry " << entry << ": freed " << freed << "/" << total << ", walk failures "
                << wf << "\n";
    }
}

}  // namespace
}  // namespace ld::cutting
