#include "sim/cutting/cutter.h"

#include <gtest/gtest.h>

#include "sim/cutting/mesh_checks.h"
#include "tests/sim/cutting/cut_test_meshes.h"
#include "tests/support/test_support.h"

namespace ld::cutting {
namespace {
using test::Vec3;

void expectSound(const CutEngine& e, bool closed) {
  for (const auto& o : e.objects()) {
    const auto rep = o.mesh.validate();
    int shown = 0;
    for (auto f : o.mesh.faces())
      if (o.mesh.faceArea(f) < 1e-12 && shown++ < 4) {
        std::cerr << "degenerate " << f << " kind " << o.mesh.getFaceProperty<int>(kFaceKindProp)[f] << ":";
        for (auto v : o.mesh.vertices(f)) std::cerr << " " << v << "(" << o.mesh.position(v).transpose() << ")";
        std::cerr << "\n";
      }
    ASSERT_TRUE(rep.ok()) << "object " << o.id << ": " << rep.message();
    const auto q = measureQuality(o.mesh);
    EXPECT_TRUE(q.manifoldVertices) << "object " << o.id;
    EXPECT_TRUE(q.finite);
    if (closed) {
      EXPECT_TRUE(q.closed) << "object " << o.id;
    }
  }
}

TEST(Explore, SlabThrough) {
  CutEngine e;
  e.addObject(test::makeBox(Vec3(0, 0, 0), Vec3(10, 10, 2), {10, 10, 2}));
  test::stroke(e, Vec3(-1, 5.3, -1), Vec3(11, 5.3, -1), Vec3(0, 0, -1));
  expectSound(e, true);
  std::cerr << "objects " << e.objects().size() << " cut " << e.stats().trianglesCut << " added "
            << e.stats().trianglesAdded << " fillfail " << e.stats().fillFailures << " walkfail "
            << e.stats().walkFailures << " unpinch " << e.stats().unpinched << "\n";
  for (const auto& o : e.objects()) {
    auto q = measureQuality(o.mesh);
    std::cerr << " obj " << o.id << " faces " << o.mesh.nFaces() << " comps " << q.components << " closed " << q.closed
              << " area " << o.mesh.area() << " minArea " << q.minArea << " minAng " << q.minAngleDeg << "\n";
  }
}

TEST(Explore, SlabGroove) {
  CutEngine e;
  e.addObject(test::makeBox(Vec3(0, 0, 0), Vec3(10, 10, 2), {10, 10, 2}));
  test::stroke(e, Vec3(2, 5.3, 1), Vec3(8, 5.3, 1), Vec3(0, 0, -1));
  expectSound(e, true);
  std::cerr << "objects " << e.objects().size() << " cut " << e.stats().trianglesCut << " added "
            << e.stats().trianglesAdded << " fillfail " << e.stats().fillFailures << " walkfail "
            << e.stats().walkFailures << " unpinch " << e.stats().unpinched << "\n";
}

}  // namespace
}  // namespace ld::cutting
