// Triangulation, clean-up, orientation, statistics and mesh building on inline soups.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/sim/io/io_test_util.h"
#include "tests/support/test_support.h"

namespace ld::io {
namespace {

RawMesh rawOf(std::vector<Eigen::Vector3d> pts, const std::vector<std::vector<std::uint32_t>>& polys) {
  RawMesh r;
  r.points = std::move(pts);
  r.source = "inline";
  for (const auto& p : polys) r.addPolygon(p.data(), p.size(), 0);
  return r;
}

bool hasEdge(const TriangleSoup& s, std::uint32_t a, std::uint32_t b) {
  for (const auto& t : s.triangles)
    for (int i = 0; i < 3; ++i) {
      const auto x = t[static_cast<std::size_t>(i)], y = t[static_cast<std::size_t>((i + 1) % 3)];
      if ((x == a && y == b) || (x == b && y == a)) return true;
    }
  return false;
}

TEST(Triangulate, QuadAvoidsDiagonalThatIsAlreadyAnEdge) {
  // Quad 0-1-2-3 plus a triangle that already uses 0-2: the quad must be cut along 1-3,
  // otherwise 0-2 would get three faces.
  const std::vector<Eigen::Vector3d> pts = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5, 0.5, 1}};
  const auto s = triangulate(rawOf(pts, {{0, 1, 2, 3}, {0, 2, 4}}));
  ASSERT_EQ(s.triangles.size(), 3u);
  EXPECT_TRUE(hasEdge(s, 1, 3));
  EXPECT_EQ(computeStats(s).nonManifoldEdges, 0u);
  // And the other way round: 1-3 taken elsewhere -> 0-2.
  const auto t = triangulate(rawOf(pts, {{1, 3, 4}, {0, 1, 2, 3}}));
  EXPECT_TRUE(hasEdge(t, 0, 2));
  EXPECT_EQ(computeStats(t).nonManifoldEdges, 0u);
}

TEST(Triangulate, NonConvexQuadUsesTheInsideDiagonal) {
  // A dart: corner 2 points inward, so only diagonal 0-2 keeps both triangles inside.
  const std::vector<Eigen::Vector3d> pts = {{0, 0, 0}, {2, -1, 0}, {0.5, 0, 0}, {2, 1, 0}};
  const auto s = triangulate(rawOf(pts, {{0, 1, 2, 3}}));
  ASSERT_EQ(s.triangles.size(), 2u);
  EXPECT_TRUE(hasEdge(s, 0, 2));
  for (const auto& t : s.triangles) EXPECT_GT(test::faceNormal(s, t).z(), 0);
  EXPECT_TRUE(ld::test::near(computeStats(s).area, 0.5, 1e-12));  // shoelace
}

TEST(Triangulate, PentagonDiagonalsAvoidExistingEdges) {
  // Every fan from corner 0 would reuse 0-2 or 0-3, which other faces own.
  const std::vector<Eigen::Vector3d> pts = {{0, 0, 0}, {2, 0, 0}, {3, 1, 0}, {1, 2, 0}, {-1, 1, 0}, {1, 1, 3}};
  const auto s = triangulate(rawOf(pts, {{0, 1, 2, 3, 4}, {0, 2, 5}, {0, 3, 5}}));
  EXPECT_EQ(s.triangles.size(), 5u);
  EXPECT_EQ(computeStats(s).nonManifoldEdges, 0u);
}

TEST(Triangulate, DropsPolygonsWithFewerThanThreeDistinctCorners) {
  ImportReport rep;
  const std::vector<Eigen::Vector3d> pts = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  const auto s = triangulate(rawOf(pts, {{0, 1, 1, 0}, {0, 0, 0}, {0, 1, 2, 2, 0}}), &rep);
  EXPECT_EQ(s.triangles.size(), 1u);  // the last one collapses to 0-1-2
  EXPECT_EQ(rep.droppedPolygons, 2u);
}

TEST(CleanSoup, OrientsClosedPiecesOutwardAndConsistently) {
  TriangleSoup s;
  s.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  s.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 2, 3}, {1, 2, 3}};  // third face reversed
  ImportReport rep;
  cleanSoup(s, false, &rep);
  EXPECT_EQ(rep.flippedFaces, 1u);
  EXPECT_TRUE(computeStats(s).consistentlyOriented);
  EXPECT_GT(test::signedVolume(s), 0);
  // All inward: all four flipped.
  TriangleSoup in;
  in.points = s.points;
  in.triangles = {{0, 1, 2}, {0, 3, 1}, {0, 2, 3}, {1, 3, 2}};
  ImportReport rep2;
  cleanSoup(in, false, &rep2);
  EXPECT_EQ(rep2.flippedFaces, 4u);
  EXPECT_TRUE(ld::test::near(test::signedVolume(in), 1.0 / 6.0, 1e-12));
}

TEST(CleanSoup, OpenPieceKeepsMajorityOrientation) {
  TriangleSoup s;
  s.points = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {2, 0, 0}, {2, 1, 0}};
  s.triangles = {{0, 1, 2}, {0, 2, 3}, {1, 5, 2}, {1, 5, 4}};  // the last one disagrees
  ImportReport rep;
  cleanSoup(s, false, &rep);
  EXPECT_EQ(rep.flippedFaces, 1u);
  for (const auto& t : s.triangles) EXPECT_GT(test::faceNormal(s, t).z(), 0);
}

TEST(CleanSoup, WeldsDropsUnreferencedKeepsOrder) {
  TriangleSoup s;
  s.points = {{9, 9, 9}, {0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {-0.0, 0, 0}, {-1, 0, 0}};
  s.triangles = {{1, 2, 3}, {4, 6, 5}, {7, 3, 8}};
  ImportReport rep;
  cleanSoup(s, true, &rep);
  EXPECT_EQ(rep.weldedVertices, 3u);  // 4 -> 2, 5 -> 3, 7 (minus zero) -> 1
  EXPECT_EQ(rep.droppedVertices, 1u);
  ASSERT_EQ(s.points.size(), 5u);
  EXPECT_TRUE(ld::test::nearVec(s.points[0], Eigen::Vector3d(0, 0, 0), 0));
  EXPECT_TRUE(ld::test::nearVec(s.points[3], Eigen::Vector3d(1, 1, 0), 0));
  EXPECT_TRUE(ld::test::nearVec(s.points[4], Eigen::Vector3d(-1, 0, 0), 0));
  const auto st = computeStats(s);
  EXPECT_EQ(st.triangles, 3u);
  EXPECT_EQ(st.edges, 7u);
  EXPECT_EQ(st.nonManifoldEdges, 0u);
  EXPECT_TRUE(st.consistentlyOriented);
  // Without welding the three triangles stay apart.
  TriangleSoup apart;
  apart.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  apart.triangles = {{0, 1, 2}, {3, 4, 5}};
  cleanSoup(apart, false);
  EXPECT_EQ(computeStats(apart).components, 2u);
}

TEST(ComputeStats, NonManifoldEdgeBowtieComponentsAndBounds) {
  TriangleSoup fin;  // three faces on edge 0-1
  fin.points = {{0, 0, 0}, {1, 0, 0}, {0.5, 1, 0}, {0.5, -1, 0}, {0.5, 0, 1}};
  fin.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
  auto st = computeStats(fin);
  EXPECT_EQ(st.nonManifoldEdges, 1u);
  EXPECT_FALSE(st.manifold);
  EXPECT_FALSE(st.closed);
  EXPECT_EQ(st.boundaryEdges, 6u);
  EXPECT_EQ(st.components, 1u);
  EXPECT_TRUE(ld::test::nearVec(st.bboxMin, Eigen::Vector3d(0, -1, 0), 0));
  EXPECT_TRUE(ld::test::nearVec(st.bboxMax, Eigen::Vector3d(1, 1, 1), 0));
  EXPECT_TRUE(ld::test::near(st.area, 1.5, 1e-12));

  TriangleSoup bow;  // two triangles touching at vertex 0 only
  bow.points = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {-1, 0, 0}, {-1, -1, 0}, {5, 5, 5}};
  bow.triangles = {{0, 1, 2}, {0, 3, 4}};
  st = computeStats(bow);
  EXPECT_EQ(st.nonManifoldEdges, 0u);
  EXPECT_EQ(st.nonManifoldVertices, 1u);
  EXPECT_FALSE(st.manifold);
  EXPECT_EQ(st.vertices, 5u);  // the unreferenced point does not count
  EXPECT_EQ(st.components, 1u);
  EXPECT_EQ(st.euler, 5 - 6 + 2);
}

TEST(BuildMesh, NonManifoldEdgeGetsCopiedVerticesAndValidates) {
  TriangleSoup fin;
  fin.points = {{0, 0, 0}, {1, 0, 0}, {0.5, 1, 0}, {0.5, -1, 0}, {0.5, 0, 1}};
  fin.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
  ImportReport rep;
  const auto m = buildMesh(fin, &rep);
  EXPECT_EQ(m.nFaces(), 3u);
  EXPECT_EQ(m.nVertices(), 7u);
  EXPECT_EQ(rep.duplicatedVertices, 2u);
  EXPECT_TRUE(m.validate().ok()) << m.validate().message();
  ASSERT_FALSE(rep.warnings.empty());
  EXPECT_THAT(rep.warnings.back(), ::testing::HasSubstr("non-manifold"));
}

TEST(BuildMesh, ZeroAreaFacesLeftOutAndCounted) {
  TriangleSoup s;
  s.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 0, 0}};
  s.triangles = {{0, 1, 2}, {0, 1, 3}};  // the second one is a flat sliver
  ImportReport rep;
  const auto m = buildMesh(s, &rep);
  EXPECT_EQ(m.nFaces(), 1u);
  EXPECT_EQ(m.nVertices(), 3u);  // vertex 3 would be isolated
  EXPECT_EQ(rep.degenerateFaces, 1u);
  EXPECT_EQ(computeStats(s).degenerateFaces, 1u);
  EXPECT_TRUE(m.validate().ok()) << m.validate().message();
}

}  // namespace
}  // namespace ld::io
