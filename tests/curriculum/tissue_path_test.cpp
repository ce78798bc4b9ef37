#include "curriculum/tissue_path.h"

#include "curriculum/curriculum_error.h"
#include "tests/curriculum/grid_mesh.h"
#include "tests/support/test_support.h"

namespace ld::curriculum {
namespace {

using V = Eigen::Vector3d;

using testmesh::grid;

Polyline straight(double y, int n, double x0 = 0.3, double x1 = 3.7) {
  std::vector<V> pts;
  for (int k = 0; k <= n; ++k) pts.emplace_back(x0 + (x1 - x0) * k / n, y, 0);
  return makePolyline(pts);
}

TEST(TissuePath, EmbedsAndMovesWithTheTissue) {
  mesh::SurfaceMesh m = grid(4);
  const Polyline world = straight(1.3, 7);
  const TissuePath tp = TissuePath::embed(m, world);
  const Polyline now = tp.positions(m);
  ASSERT_EQ(now.size(), world.size());
  for (std::size_t i = 0; i < now.size(); ++i) EXPECT_TRUE(test::nearVec(now[i].p, world[i].p, 1e-12));
  // Stretch the tissue 1.5x along x and lift it: the path follows (affine map).
  for (mesh::Vertex v : m.vertices()) {
    V& p = m.position(v);
    p = V(1.5 * p.x(), p.y(), 0.2 * p.y());
  }
  const Polyline moved = tp.positions(m);
  for (std::size_t i = 0; i < moved.size(); ++i)
    EXPECT_TRUE(test::nearVec(moved[i].p, V(1.5 * world[i].p.x(), world[i].p.y(), 0.2 * world[i].p.y()), 1e-12));
}

TEST(TissuePath, RefusesPointsOffTheSurface) {
  const mesh::SurfaceMesh m = grid(2);
  EXPECT_THROW(TissuePath::embed(m, makePolyline({V(0.5, 0.5, 0), V(0.5, 0.5, 3)})), PathError);
}

TEST(TissuePath, ReembedsWithoutMovingWhenTrianglesAreSubdivided) {
  mesh::SurfaceMesh m = grid(4);
  TissuePath tp = TissuePath::embed(m, straight(1.4, 12));
  const auto before = tp.worldPoints(m);
  // Subdivide every face the path touches, twice (faces and edges).
  for (int round = 0; round < 2; ++round) {
    const auto snap = tp.worldPoints(m);
    std::vector<mesh::Face> touched;
    for (const auto& q : tp.points())
      if (std::find(touched.begin(), touched.end(), q.loc.face) == touched.end()) touched.push_back(q.loc.face);
    for (mesh::Face f : touched) m.splitFace(f, m.centroid(f));
    const mesh::Edge e = m.edges(tp.points()[3].loc.face)[0];
    const V mid = 0.5 * (m.position(m.vertex(e, 0)) + m.position(m.vertex(e, 1)));
    m.splitEdge(e, mid);
    ASSERT_TRUE(m.validate().ok()) << m.validate().message();
    tp.reembed(m, snap);
  }
  const auto after = tp.worldPoints(m);
  for (std::size_t i = 0; i < after.size(); ++i) {
    EXPECT_TRUE(test::nearVec(after[i], before[i], 1e-9));
    const V& b = tp.points()[i].loc.bary;
    EXPECT_GE(b.minCoeff(), -1e-9);
    EXPECT_TRUE(test::near(b.sum(), 1.0, 1e-9));
  }
  // And it still moves with the (now finer) tissue.
  for (mesh::Vertex v : m.vertices()) m.position(v).z() += 2.0;
  for (const auto& q : tp.positions(m)) EXPECT_TRUE(test::near(q.p.z(), 2.0, 1e-12));
}

TEST(TissuePath, RemapsAfterCompaction) {
  mesh::SurfaceMesh m = grid(3);
  TissuePath tp = TissuePath::embed(m, straight(2.5, 5));
  const auto before = tp.worldPoints(m);
  m.deleteFace(mesh::Face(0));  // far from y = 2.5
  const mesh::Compaction c = m.garbageCollection();
  tp.remap(c);
  const auto after = tp.worldPoints(m);
  for (std::size_t i = 0; i < after.size(); ++i) EXPECT_TRUE(test::nearVec(after[i], before[i], 1e-12));
}

TEST(TissuePath, CutAcrossBreaksThePath) {
  const mesh::SurfaceMesh m = grid(4);
  TissuePath tp = TissuePath::embed(m, straight(1.5, 4, 0.5, 3.5));  // x = 0.5, 1.25, 2, 2.75, 3.5
  // A cut across at x = 1.6: crosses the second segment (1.25..2).
  EXPECT_EQ(tp.cutAcross(m, V(1.6, 0.5, 0), V(1.6, 2.5, 0), V(0, 0, 1)), 1);
  const Polyline p = tp.positions(m);
  EXPECT_FALSE(p[0].stop);
  EXPECT_TRUE(p[1].stop);  // the point before the crossing ends a piece
  EXPECT_FALSE(p[2].stop);
  EXPECT_EQ(pieces(p).size(), 2u);
  EXPECT_EQ(pieces(tp.drawnPositions(m)).size(), 1u);  // as drawn
  // A cut beside the path does not cross; one through a path vertex counts once.
  EXPECT_EQ(tp.cutAcross(m, V(0.2, 0.5, 0), V(0.2, 2.5, 0), V(0, 0, 1)), 0);
  EXPECT_EQ(tp.cutAcross(m, V(2.0, 0.5, 0), V(2.0, 1.5, 0), V(0, 0, 1)) +
                tp.cutAcross(m, V(2.0, 1.5, 0), V(2.0, 2.5, 0), V(0, 0, 1)),
            1);
  // Far above the surface (another layer): no crossing.
  EXPECT_EQ(tp.cutAcross(m, V(3.0, 0.5, 5), V(3.0, 2.5, 5), V(0, 0, 1)), 0);
}

TEST(CutPathRecorder, OnePiecePerOriginalTriangleAndStopsOnLift) {
  mesh::SurfaceMesh m = grid(4);
  tagOriginalFaces(m);
  // Subdivide face 2 after tagging: its children stay "one original triangle".
  const mesh::Face f2(2);
  m.splitFace(f2, m.centroid(f2));
  CutPathRecorder rec;
  auto at = [&](double x, double y) {
    double d;
    const SurfaceLocation loc = closestLocation(m, V(x, y, 0), &d);
    rec.contact(m, loc.face, V(x, y, 0));
  };
  // Along y = 0.02 from x = 0.05 to 1.95 in small steps: faces 0 (x<1) then 2 (split);
  // below the squares' diagonals all the way.
  for (int k = 0; k <= 19; ++k) at(0.05 + 0.1 * k, 0.02);
  rec.loseContact();
  at(3.5, 3.5);
  at(3.6, 3.55);
  const Polyline done = rec.currentPath();
  const Polyline& p = rec.path();
  // First and last point in each original triangle, the stop at the lift.
  ASSERT_EQ(p.size(), 5u);
  EXPECT_TRUE(test::nearVec(p[0].p, V(0.05, 0.02, 0), 1e-12));
  EXPECT_TRUE(test::nearVec(p[1].p, V(0.95, 0.02, 0), 1e-12));
  EXPECT_TRUE(test::nearVec(p[2].p, V(1.05, 0.02, 0), 1e-12));
  EXPECT_TRUE(test::nearVec(p[3].p, V(1.95, 0.02, 0), 1e-12));
  EXPECT_TRUE(p[3].stop);
  EXPECT_TRUE(test::nearVec(p[4].p, V(3.5, 3.5, 0), 1e-12));
  ASSERT_EQ(done.size(), 6u);
  EXPECT_TRUE(test::nearVec(done[5].p, V(3.6, 3.55, 0), 1e-12));
}

TEST(SurfaceLocation, ClosestPointBarycentrics) {
  const V a(0, 0, 0), b(2, 0, 0), c(0, 2, 0);
  EXPECT_TRUE(test::nearVec(closestBarycentric(V(0.5, 0.5, 3), a, b, c), V(0.5, 0.25, 0.25), 1e-12));
  EXPECT_TRUE(test::nearVec(closestBarycentric(V(-1, -1, 0), a, b, c), V(1, 0, 0), 1e-12));
  EXPECT_TRUE(test::nearVec(closestBarycentric(V(2, 2, 0), a, b, c), V(0, 0.5, 0.5), 1e-12));
  EXPECT_TRUE(test::nearVec(closestBarycentric(V(1, -3, 0), a, b, c), V(0.5, 0.5, 0), 1e-12));
}

}  // namespace
}  // namespace ld::curriculum
