#include "sim/collision/collision_world.h"

#include <memory>

#include <gtest/gtest.h>

#include "tests/sim/collision/test_meshes.h"
#include "tests/support/test_support.h"

namespace ld::collision {
namespace {

using Eigen::Vector3d;
using instruments::Pose;
using instruments::Tool;
using ld::test::near;
using ld::test::nearVec;

Pose downAt(const Vector3d& tip) {
  Pose p;
  p.tip = tip;
  p.dir = Vector3d(0, 0, -1);
  p.up = Vector3d(1, 0, 0);
  return p;
}

TEST(CollisionWorld, ScalpelThroughASlabAndASphereHitsEveryLayerOfEveryObjectInOrder) {
  const auto slab = std::make_unique<mesh::SurfaceMesh>(testing::slab(10, 1.0, 2.0));  // z in [-2, 0]
  const auto ball = std::make_unique<mesh::SurfaceMesh>(testing::icosphere(3, 1.5, Vector3d(5.2, 5.3, 3.0)));
  CollisionWorld world;
  const ObjectId s = world.add(*slab), b = world.add(*ball);
  EXPECT_NE(s, b);
  // The edge runs from the tip back towards the handle (tip - 20 dir). Shaft pointing
  // down with the tip above everything: the edge is above everything too.
  EXPECT_TRUE(world.query(Tool::Scalpel, downAt(Vector3d(5.2, 5.3, 10.0)))[0].hits.empty());
  // Tip below the slab: the edge reaches up through the slab and the sphere.
  const auto contacts = world.query(Tool::Scalpel, downAt(Vector3d(5.2, 5.3, -5.0)));
  ASSERT_EQ(contacts.size(), 1u);
  const auto& hits = contacts[0].hits;
  ASSERT_EQ(hits.size(), 4u);  // slab bottom and top, sphere in and out, by t from the tip
  EXPECT_EQ(hits[0].object, s);
  EXPECT_EQ(hits[1].object, s);
  EXPECT_EQ(hits[2].object, b);
  EXPECT_EQ(hits[3].object, b);
  for (std::size_t i = 1; i < hits.size(); ++i) EXPECT_LE(hits[i - 1].hit.t, hits[i].hit.t);
  EXPECT_TRUE(near(hits[0].hit.point.z(), -2.0, 1e-12));
  EXPECT_TRUE(near(hits[1].hit.point.z(), 0.0, 1e-12));
  EXPECT_EQ(hits[0].hit.direction, 1);   // into the tissue through the bottom (front -> back)
  EXPECT_EQ(hits[1].hit.direction, -1);  // out through the top
  EXPECT_TRUE(nearVec(contacts[0].segment.a, Vector3d(5.2, 5.3, -5.0), 0));
}

TEST(CollisionWorld, HookAndGrasperReportEachOfTheirSegments) {
  const auto slab = std::make_unique<mesh::SurfaceMesh>(testing::slab(10, 1.0, 2.0));
  CollisionWorld world;
  world.add(*slab);
  // Hook: tip 1 mm under the top, elbow 4 mm along -up: edge elbow->tip lies inside
  // the slab (no hit), the foot from elbow - 6 dir (above) to elbow crosses the top.
  Pose hook = downAt(Vector3d(5.5, 5.5, -1.0));
  hook.up = Vector3d(1, 0, 0);
  const auto hc = world.query(Tool::Hook, hook);
  ASSERT_EQ(hc.size(), 2u);
  EXPECT_TRUE(hc[0].hits.empty());
  ASSERT_EQ(hc[1].hits.size(), 1u);
  EXPECT_TRUE(nearVec(hc[1].hits[0].hit.point, Vector3d(1.5, 5.5, 0.0), 1e-12));
  // Grasper, jaws open (5 mm apart sideways), virtual tip 2.5 mm into the slab: both
  // jaws cross the top and end inside.
  const auto wide = std::make_unique<mesh::SurfaceMesh>(testing::slab(12, 1.0, 2.0));
  CollisionWorld world2;
  world2.add(*wide);
  Pose g = downAt(Vector3d(5.5, 6.2, -2.5));
  g.up = Vector3d(0, 1, 0);
  g.jaw = 1.0;
  const auto gc = world2.query(Tool::Grasper, g);
  ASSERT_EQ(gc.size(), 2u);
  EXPECT_EQ(gc[0].segment.role, instruments::SegmentRole::Jaw);
  ASSERT_EQ(gc[0].hits.size(), 1u);
  ASSERT_EQ(gc[1].hits.size(), 1u);
  EXPECT_TRUE(near(gc[0].hits[0].hit.point.z(), 0.0, 1e-12));
  EXPECT_TRUE(near(gc[0].hits[0].hit.point.y() + gc[1].hits[0].hit.point.y(), 12.4, 1e-9));  // symmetric
}

TEST(CollisionWorld, FollowsCuttingEditsAndMovesAndFreedPieces) {
  auto slab = std::make_unique<mesh::SurfaceMesh>(testing::slab(6, 1.0, 2.0));
  CollisionWorld world;
  const ObjectId id = world.add(*slab);
  // Cutting-like edits, then the physics moves everything up 1 mm.
  for (int i = 0; i < 30; ++i) {
    const mesh::Face f(static_cast<std::uint32_t>((i * 7) % slab->facesSize()));
    const auto& vs = slab->vertices(f);
    slab->splitFace(f, (slab->position(vs[0]) + slab->position(vs[1]) + slab->position(vs[2])) / 3.0);
  }
  for (mesh::Vertex v : slab->vertices()) slab->position(v).z() += 1.0;
  world.update();
  EXPECT_EQ(world.bvh(id).check(*slab), "");
  const Vector3d a(2.2, 3.1, 5), c(2.2, 3.1, -5);
  const auto hits = world.intersectSegment(a, c);
  const auto brute = intersectSegment(*slab, a, c);
  ASSERT_EQ(hits.size(), brute.size());
  for (std::size_t i = 0; i < hits.size(); ++i) EXPECT_EQ(hits[i].hit.face, brute[i].face);
  EXPECT_TRUE(near(hits[0].hit.point.z(), 1.0, 1e-12));
  // A freed piece is just another object; moving a mesh needs a rebind.
  auto piece = std::make_unique<mesh::SurfaceMesh>(testing::icosphere(1, 0.5, Vector3d(2.2, 3.1, 3)));
  const ObjectId p = world.add(*piece);
  EXPECT_EQ(world.intersectSegment(a, c).size(), 4u);
  mesh::SurfaceMesh moved = std::move(*piece);
  world.rebind(p, moved);
  world.sync();
  EXPECT_EQ(world.intersectSegment(a, c).size(), 4u);
  // Compaction renumbers faces: rebuild.
  moved.deleteFace(mesh::Face(0u));
  moved.garbageCollection();
  world.rebuild(p);
  EXPECT_EQ(world.bvh(p).check(moved), "");
  world.remove(p);
  EXPECT_FALSE(world.contains(p));
  EXPECT_TRUE(world.contains(id));
  EXPECT_EQ(world.intersectSegment(a, c).size(), 2u);
  EXPECT_THROW(world.remove(p), CollisionError);
  EXPECT_THROW((void)world.bvh(12345), CollisionError);
}

// The cutter edits the mesh and queries again without telling the world: the
// trees follow the edit journal by themselves, locally.
TEST(CollisionWorld, QueriesFollowTopologyEditsWithoutAnExplicitSync) {
  auto slab = std::make_unique<mesh::SurfaceMesh>(testing::slab(8, 1.0, 2.0));
  auto ball = std::make_unique<mesh::SurfaceMesh>(testing::icosphere(2, 1.0, Vector3d(4.3, 4.6, 3.0)));
  CollisionWorld world;
  const ObjectId s = world.add(*slab), b = world.add(*ball);
  const std::size_t builds = world.bvh(s).stats().builds;
  const Vector3d a(4.3, 4.6, 6), c(4.3, 4.6, -6);
  for (int i = 0; i < 30; ++i) {
    // Split the face under the segment again and again (as a cut would), on the top
    // and the bottom in turn (a third of the area each time: 15 splits stay far from
    // degenerate triangles, which the tolerant test treats as holes).
    const auto brute = intersectSegment(*slab, a, c);
    const mesh::Face f = i % 2 ? brute.back().face : brute.front().face;  // a is above: top first
    const auto& vs = slab->vertices(f);
    slab->splitFace(f, 0.2 * slab->position(vs[0]) + 0.3 * slab->position(vs[1]) + 0.5 * slab->position(vs[2]));
    const auto hits = world.intersectSegment(c, a);  // from below: slab bottom, slab top, ball in, ball out
    const auto expected = intersectSegment(*slab, c, a);
    ASSERT_EQ(hits.size(), expected.size() + 2);
    for (std::size_t k = 0; k < expected.size(); ++k) {
      EXPECT_EQ(hits[k].object, s);
      EXPECT_EQ(hits[k].hit.face, expected[k].face);
      EXPECT_EQ(hits[k].hit.kind, expected[k].kind);
      EXPECT_EQ(hits[k].hit.t, expected[k].t);
    }
    EXPECT_EQ(hits.back().object, b);
  }
  EXPECT_EQ(world.bvh(s).check(*slab), "");
  EXPECT_EQ(world.bvh(s).stats().builds, builds) << "30 splits are absorbed locally";
  // First contact and the yes/no test over all objects.
  const auto first = world.firstHit(a, c);
  ASSERT_TRUE(first.has_value());
  EXPECT_EQ(first->object, b);
  EXPECT_TRUE(near(first->hit.point.z(), 4.0, 0.05));  // top of the ball (a subdivided sphere)
  const auto fromBelow = world.firstHit(c, a);
  ASSERT_TRUE(fromBelow.has_value());
  EXPECT_EQ(fromBelow->object, s);
  EXPECT_TRUE(near(fromBelow->hit.point.z(), -2.0, 1e-12));
  EXPECT_TRUE(world.anyHit(a, c));
  EXPECT_FALSE(world.anyHit(Vector3d(20, 20, 1), Vector3d(30, 30, -1)));
  EXPECT_FALSE(world.firstHit(Vector3d(20, 20, 1), Vector3d(30, 30, -1)).has_value());
  // Physics moves a region: refit only around those vertices.
  std::vector<mesh::Vertex> moved;
  for (mesh::Vertex v : ball->vertices()) {
    ball->position(v).z() += 10.0;
    moved.push_back(v);
  }
  world.refitVertices(b, moved);
  EXPECT_EQ(world.bvh(b).check(*ball), "");
  EXPECT_EQ(world.firstHit(a, c)->object, s);
}

TEST(CollisionWorld, SweepOfAFastScalpelStrokeFindsTopAndBottomLayers) {
  const auto slab = std::make_unique<mesh::SurfaceMesh>(testing::slab(10, 1.0, 2.0));
  CollisionWorld world;
  const ObjectId id = world.add(*slab);
  // Tip below the slab, edge up through both layers; moves 6 mm sideways in one sample.
  Pose p0 = downAt(Vector3d(2.3, 4.4, -5.0)), p1 = downAt(Vector3d(8.3, 4.4, -5.0));
  const auto sw = world.sweep(Tool::Scalpel, p0, p1);
  ASSERT_EQ(sw.size(), 1u);
  ASSERT_EQ(sw[0].objects.size(), 1u);
  EXPECT_EQ(sw[0].objects[0].object, id);
  const auto& c = sw[0].objects[0].contacts;
  int top = 0, bottom = 0;
  for (const auto& x : c.edgeCrossings) {
    top += near(x.point.z(), 0.0, 1e-12) ? 1 : 0;
    bottom += near(x.point.z(), -2.0, 1e-12) ? 1 : 0;
  }
  EXPECT_GT(top, 6);
  EXPECT_EQ(top, bottom);  // the same cut line on both layers
}

// An active region reported as vertex indices, then a compaction handed over as
// maps: the world's queries follow both without a rebuild.
TEST(CollisionWorld, RegionRefitByIndicesAndRemapAfterCompaction) {
  auto sheet = std::make_unique<mesh::SurfaceMesh>(testing::grid(20));  // z = 0, x, y in [0, 20]
  CollisionWorld world;
  const ObjectId id = world.add(*sheet);
  std::vector<std::uint32_t> region;
  for (mesh::Vertex v : sheet->vertices())
    if ((sheet->position(v).head<2>() - Eigen::Vector2d(10, 10)).norm() < 3.0) {
      sheet->position(v).z() = 2.0;  // lifted
      region.push_back(static_cast<std::uint32_t>(v.idx()));
    }
  world.refitVertices(id, std::span<const std::uint32_t>(region));
  EXPECT_EQ(world.bvh(id).check(*sheet), "");
  auto hits = world.intersectSegment(Vector3d(10.3, 10.2, 3.0), Vector3d(10.3, 10.2, 1.0));
  ASSERT_EQ(hits.size(), 1u);
  EXPECT_TRUE(near(hits[0].hit.point.z(), 2.0, 1e-12));
  // Cut away the first column of faces (all corners at x < 2), compact, remap.
  for (mesh::Face f : sheet->faces())
    if (sheet->position(sheet->vertices(f)[0]).x() < 2.0 && sheet->position(sheet->vertices(f)[1]).x() < 2.0 &&
        sheet->position(sheet->vertices(f)[2]).x() < 2.0)
      sheet->deleteFace(f);
  for (mesh::Vertex v : sheet->vertices())
    if (sheet->isIsolated(v)) sheet->deleteVertex(v);
  const mesh::Compaction c = sheet->garbageCollection();
  EXPECT_EQ(world.remap(id, c), SyncResult::Local);
  EXPECT_EQ(world.bvh(id).stats().builds, 1u);
  EXPECT_EQ(world.bvh(id).check(*sheet), "");
  EXPECT_TRUE(world.intersectSegment(Vector3d(0.6, 5.2, 1.0), Vector3d(0.6, 5.2, -1.0)).empty());
  EXPECT_EQ(world.intersectSegment(Vector3d(1.6, 5.2, 1.0), Vector3d(1.6, 5.2, -1.0)).size(), 1u);
  hits = world.intersectSegment(Vector3d(10.3, 10.2, 3.0), Vector3d(10.3, 10.2, 1.0));
  ASSERT_EQ(hits.size(), 1u);
  EXPECT_EQ(hits[0].hit.face, intersectSegment(*sheet, Vector3d(10.3, 10.2, 3.0), Vector3d(10.3, 10.2, 1.0))[0].face);
}

}  // namespace
}  // namespace ld::collision
