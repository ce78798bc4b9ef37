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

// Tilted blades and oblique strokes (issue #4). One stroke on a fresh fine slab: it
// enters over the side x = -12 at height y, `offNormalDeg` off that side's normal (60:
// 30 degrees to the side face; it then leaves over y = 8 at 30 degrees off that side's
// normal), with the blade tilted by tiltDeg toward azimuth tiltAzDeg (0: along the
// motion, its lower end ahead). A tilted blade crosses the side face with one end first:
// the slide-in starts on the side face, the crossing there runs up or down the side at
// speed / tan(tilt), and at the far side one layer's tip goes over the edge and along
// the side face before the other's.
struct TiltCase {
  double speed, tiltDeg, tiltAzDeg, offNormalDeg, y;
};

// Whether the strip came off; `perSample` checks the mesh after every sample over the sides.
bool tiltedStroke(const TiltCase& c, bool perSample, long* walkFailures) {
  CutEngine e;
  e.addObject(fineSlab());
  const double a = c.offNormalDeg * M_PI / 180.0;
  const Vec3 d(std::cos(a), std::sin(a), 0.0);
  const Vec3 side(-d.y(), d.x(), 0.0);
  const double t = c.tiltDeg * M_PI / 180.0, az = c.tiltAzDeg * M_PI / 180.0;
  const Vec3 lean = std::cos(az) * d + std::sin(az) * side;
  const Vec3 dir = (Vec3(0, 0, -1) * std::cos(t) + lean * std::sin(t)).normalized();
  const Vec3 entry(-12.0, c.y, 0.0);
  // Out over the first side the line reaches.
  const double tx = d.x() > 1e-9 ? (12.0 - entry.x()) / d.x() : 1e300;
  const double ty = d.y() > 1e-9 ? (8.0 - entry.y()) / d.y() : (d.y() < -1e-9 ? (-8.0 - entry.y()) / d.y() : 1e300);
  const double len = std::min(tx, ty);
  // The blade passes the line's points at z = 0, its tip at z = -4 (under the slab).
  const Vec3 toTip = dir * (4.0 / -dir.z());
  const Vec3 tip0 = entry - 3.0 * d + toTip, tip1 = entry + (len + 3.0) * d + toTip;
  bool sound = true;
  // Per sample over the sides (6 mm of stroke at each end): the slide-in and the cut-out.
  const double strokeLen = (tip1 - tip0).norm(), perSampleMm = c.speed / 1000.0;
  long k = -1;
  test::stroke(e, tip0, tip1, dir, c.speed, 1000.0, [&](CutEngine& en) {
    const double at = static_cast<double>(++k) * perSampleMm;
    if (!perSample || !sound || (at > 6.0 && at < strokeLen - 6.0)) return;
    for (const auto& o : en.objects()) {
      const auto rep = o.mesh.validate();
      if (!rep.ok() || !o.mesh.isClosed()) {
        ADD_FAILURE() << "speed " << c.speed << " tilt " << c.tiltDeg << " az " << c.tiltAzDeg << " off normal "
                      << c.offNormalDeg << " y " << c.y << ": " << (rep.ok() ? "not closed" : rep.message());
        sound = false;
      }
    }
  });
  expectClosedPieces(e, "after a tilted stroke");
  if (walkFailures) *walkFailures += e.stats().walkFailures;
  return e.stats().separations == 1 && e.objects().size() == 2u;
}

// Up to 10 degrees of tilt any way, strokes down to 30 degrees to the side face: every
// strip comes off. (Before: 51 of these 108 stayed attached, 14 walk failures — the slide-in walk went
// down the side instead of up, the side face's fast crossing was not matched to its
// track, the cut-out walk went off the side, the tips met on the far side face with a
// wall apex on its edge.)
TEST(CutterFine, TiltedAndObliqueStrokesFreeTheirStrips) {
  int freed = 0, total = 0;
  long walkFailures = 0;
  for (double tilt : {3.0, 6.0, 10.0})
    for (double az : {0.0, 90.0, 180.0, 270.0})
      for (double off : {0.0, 30.0, 60.0})
        for (double speed : {20.0, 250.0})
          for (double y : {-5.3, 2.15}) {
            if (speed == 20.0 && y > 0) continue;  // (the slow strokes take most of the time)
            const TiltCase c{speed, tilt, az, off, off > 40 ? y - 2.0 : y};
            const bool ok = tiltedStroke(c, speed > 100.0 && tilt > 5.0, &walkFailures);
            EXPECT_TRUE(ok) << "strip stays attached: speed " << speed << " tilt " << tilt << " az " << az
                            << " off normal " << off << " y " << c.y;
            freed += ok ? 1 : 0;
            ++total;
          }
  std::cout << "tilted strokes: freed " << freed << " of " << total << ", walk failures " << walkFailures << "\n";
  EXPECT_EQ(walkFailures, 0);
}

// The whole table (LD_CUT_FINE_SWEEP=1, =2 lists the misses; 468 strokes), or one
// stroke: LD_CUT_FINE_CASE=speed,tilt,azimuth,offNormal,y (with LD_CUT_DEBUG=1).
TEST(CutterFine, SweepTiltedAndObliqueStrokes) {
  if (const char* one = std::getenv("LD_CUT_FINE_CASE")) {
    TiltCase c{};
    if (std::sscanf(one, "%lf,%lf,%lf,%lf,%lf", &c.speed, &c.tiltDeg, &c.tiltAzDeg, &c.offNormalDeg, &c.y) != 5)
      GTEST_SKIP() << "LD_CUT_FINE_CASE=speed,tilt,azimuth,offNormal,y";
    long wf = 0;
    const bool ok = tiltedStroke(c, true, &wf);
    std::cout << (ok ? "freed" : "not freed") << ", walk failures " << wf << "\n";
    return;
  }
  const char* env = std::getenv("LD_CUT_FINE_SWEEP");
  if (!env) GTEST_SKIP() << "set LD_CUT_FINE_SWEEP=1 (or 2: list the misses)";
  for (double tilt : {0.0, 3.0, 6.0, 10.0})
    for (double off : {0.0, 30.0, 45.0, 60.0}) {
      int freed = 0, total = 0;
      long wf = 0;
      for (double az : {0.0, 90.0, 180.0, 270.0}) {
        if (tilt == 0 && az != 0) continue;
        for (double speed : {20.0, 100.0, 250.0})
          for (double y : {-5.3, -1.7, 2.15}) {
            const TiltCase c{speed, tilt, az, off, off > 40 ? y - 2.0 : y};
            const bool ok = tiltedStroke(c, false, &wf);
            freed += ok ? 1 : 0;
            ++total;
            if (!ok && std::string(env) == "2")
              std::cout << "  miss: speed " << speed << " tilt " << tilt << " az " << az << " off " << off << " y "
                        << c.y << "\n";
          }
      }
      std::cout << "tilt " << tilt << " off normal " << off << ": freed " << freed << "/" << total << ", walk failures "
                << wf << "\n";
    }
}

}  // namespace
}  // namespace ld::cutting
