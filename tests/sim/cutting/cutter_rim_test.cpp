// A cut-through that leaves over a rim the tissue no longer has in its undeformed
// shape (a settled slab: thin, rounded ends) still frees the piece.
#include <gtest/gtest.h>

#include <cmath>

#include "sim/cutting/cutter.h"
#include "sim/cutting/mesh_checks.h"
#include "tests/sim/cutting/cut_test_meshes.h"

namespace ld::cutting {
namespace {
using test::Vec3;

// Box slab whose ends taper smoothly (the way a settled slab sags at its rim): the
// cut's cross-section beyond the last tips is a thin crescent.
mesh::SurfaceMesh taperedSlab(double endScale) {
  auto m = test::makeBox(Vec3(-10, -6, -2.5), Vec3(10, 6, 2.5), {40, 24, 5});
  for (mesh::Vertex v : m.vertices()) {
    Vec3 p = m.position(v);
    const double s = std::clamp((std::abs(p.x()) - 7.0) / 3.0, 0.0, 1.0);
    const double w = s * s * (3 - 2 * s);
    p.z() *= 1.0 - (1.0 - endScale) * w;
    p.x() *= 1.0 - 0.02 * w * std::abs(p.z());
    m.position(v) = p;
  }
  return m;
}

TEST(CutterRim, StraightCutThroughTaperedRimsSeparates) {
  for (double endScale : {0.15, 0.06}) {
    CutEngine e;
    e.addObject(taperedSlab(endScale));
    test::stroke(e, Vec3(-13, -2.2, -5.5), Vec3(13, -2.2, -5.5), Vec3(0, 0, -1), 80.0, 160.0);
    EXPECT_EQ(e.objects().size(), 2u) << "end scale " << endScale;
    for (const auto& o : e.objects()) {
      EXPECT_TRUE(o.mesh.validate().ok());
      EXPECT_TRUE(o.mesh.isClosed());
    }
    EXPECT_EQ(e.stats().fillFailures, 0);
  }
}

// The tissue moves under the blade (as physics would between samples): the far rim
// sags smoothly while the stroke goes on, so the crossings there are not where the
// undeformed slab had them.
// Was a bug (found with this test, also without the motion): the first step past the
// long cut-in front closed it with a triangulation that left no edge from the new tip
// to the other layer's tip, so the top layer lost its front, grew closed to the end and
// cut-out found no loop. The front now closes with a fan from the new tip.
TEST(CutterRim, RimMovingBetweenSamplesStillSeparates) {
  CutEngine e;
  const int id = e.addObject(taperedSlab(1.0));
  const Vec3 a(-13, -2.2, -5.5), b(13, -2.2, -5.5);
  const int n = 26 * 2;
  for (int i = 0; i <= n; ++i) {
    auto& m = e.object(id).mesh;
    const double k = 0.985;  // per sample: about 0.45 of the thickness left at the end
    for (mesh::Vertex v : m.vertices()) {
      Vec3 p = m.position(v);
      const double s = std::clamp((p.x() - 6.0) / 4.0, 0.0, 1.0);
      p.z() *= 1.0 - (1.0 - k) * s * s * (3 - 2 * s);
      m.position(v) = p;
    }
    auto pose = test::scalpel(a + (b - a) * (static_cast<double>(i) / n), Vec3(0, 0, -1), Vec3(1, 0, 0));
    e.step(instruments::Hand::Right, instruments::Tool::Scalpel, pose);
  }
  e.endStroke(instruments::Hand::Right);
  EXPECT_EQ(e.objects().size(), 2u);
  for (const auto& o : e.objects()) {
    EXPECT_TRUE(o.mesh.validate().ok());
    EXPECT_TRUE(o.mesh.isClosed());
  }
}

}  // namespace
}  // namespace ld::cutting
