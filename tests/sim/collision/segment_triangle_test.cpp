#include "sim/collision/segment_triangle.h"

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/test_support.h"

namespace ld::collision {
namespace {

using Eigen::Vector3d;
using ld::test::near;
using ld::test::nearVec;

const Vector3d V0(0, 0, 0), V1(4, 0, 0), V2(0, 4, 0);

TEST(SegmentTriangle, InteriorCrossingGivesParameterPointAndBary) {
  const auto r = intersectSegmentTriangle(Vector3d(1, 1, 2), Vector3d(1, 1, -2), V0, V1, V2);
  ASSERT_EQ(r.kind, HitKind::Interior);
  EXPECT_TRUE(near(r.t, 0.5, 1e-15));
  EXPECT_TRUE(nearVec(r.point, Vector3d(1, 1, 0), 1e-15));
  EXPECT_TRUE(nearVec(r.bary, Vector3d(0.5, 0.25, 0.25), 1e-15));
  EXPECT_EQ(r.direction, 1);  // from the front (+z, the normal side) to the back
  EXPECT_EQ(r.endTouch, EndTouch::None);
  const auto back = intersectSegmentTriangle(Vector3d(1, 1, -2), Vector3d(1, 1, 6), V0, V1, V2);
  ASSERT_EQ(back.kind, HitKind::Interior);
  EXPECT_TRUE(near(back.t, 0.25, 1e-15));
  EXPECT_EQ(back.direction, -1);
}

TEST(SegmentTriangle, MissesOutsideShortAndBeside) {
  EXPECT_EQ(intersectSegmentTriangle(Vector3d(3, 3, 1), Vector3d(3, 3, -1), V0, V1, V2).kind, HitKind::None);
  EXPECT_EQ(intersectSegmentTriangle(Vector3d(1, 1, 2), Vector3d(1, 1, 0.5), V0, V1, V2).kind, HitKind::None);
  EXPECT_EQ(intersectSegmentTriangle(Vector3d(1, 1, -0.5), Vector3d(1, 1, -2), V0, V1, V2).kind, HitKind::None);
}

TEST(SegmentTriangle, EdgeAndVertexHitsCountWithTheMeshEdgeNumbering) {
  // Edge i joins corner i and i+1: edge 0 is y=0, edge 1 is x+y=4, edge 2 is x=0.
  auto r = intersectSegmentTriangle(Vector3d(2, 0, 1), Vector3d(2, 0, -1), V0, V1, V2);
  EXPECT_EQ(r.kind, HitKind::OnEdge);
  EXPECT_EQ(r.local, 0);
  r = intersectSegmentTriangle(Vector3d(2, 2, 1), Vector3d(2, 2, -1), V0, V1, V2);
  EXPECT_EQ(r.kind, HitKind::OnEdge);
  EXPECT_EQ(r.local, 1);
  EXPECT_TRUE(nearVec(r.bary, Vector3d(0, 0.5, 0.5), 1e-15));
  r = intersectSegmentTriangle(Vector3d(0, 1, 1), Vector3d(0, 1, -1), V0, V1, V2);
  EXPECT_EQ(r.kind, HitKind::OnEdge);
  EXPECT_EQ(r.local, 2);
  for (int c = 0; c < 3; ++c) {
    const Vector3d v = c == 0 ? V0 : (c == 1 ? V1 : V2);
    r = intersectSegmentTriangle(v + Vector3d(0.3, -0.2, 1), v - Vector3d(0.3, -0.2, 1), V0, V1, V2);
    EXPECT_EQ(r.kind, HitKind::OnVertex) << c;
    EXPECT_EQ(r.local, c);
    EXPECT_TRUE(near(r.bary[c], 1.0, 1e-12));
  }
  // Just outside an edge by more than the tolerance: a miss.
  r = intersectSegmentTriangle(Vector3d(2, -1e-6, 1), Vector3d(2, -1e-6, -1), V0, V1, V2);
  EXPECT_EQ(r.kind, HitKind::None);
  // Outside by less than the tolerance: on the edge.
  r = intersectSegmentTriangle(Vector3d(2, -1e-10, 1), Vector3d(2, -1e-10, -1), V0, V1, V2);
  EXPECT_EQ(r.kind, HitKind::OnEdge);
}

TEST(SegmentTriangle, EndTouchingTheTriangleIsAHit) {
  auto r = intersectSegmentTriangle(Vector3d(1, 1, 0), Vector3d(1, 1, 3), V0, V1, V2);
  ASSERT_EQ(r.kind, HitKind::Interior);
  EXPECT_EQ(r.endTouch, EndTouch::Start);
  EXPECT_EQ(r.t, 0.0);
  EXPECT_EQ(r.direction, -1);
  r = intersectSegmentTriangle(Vector3d(1, 1, 3), Vector3d(1, 1, 0), V0, V1, V2);
  ASSERT_EQ(r.kind, HitKind::Interior);
  EXPECT_EQ(r.endTouch, EndTouch::End);
  EXPECT_EQ(r.t, 1.0);
  EXPECT_EQ(r.direction, 1);
  r = intersectSegmentTriangle(Vector3d(4, 0, 0), Vector3d(5, 1, 1), V0, V1, V2);  // end on a corner
  EXPECT_EQ(r.kind, HitKind::OnVertex);
  EXPECT_EQ(r.local, 1);
}

TEST(SegmentTriangle, CoplanarIsReportedWithItsOverlapNotAsAHit) {
  auto r = intersectSegmentTriangle(Vector3d(-1, 1, 0), Vector3d(5, 1, 0), V0, V1, V2);
  ASSERT_EQ(r.kind, HitKind::Coplanar);
  EXPECT_TRUE(near(r.t, 1.0 / 6.0, 1e-9));
  EXPECT_TRUE(near(r.tExit, 4.0 / 6.0, 1e-9));  // leaves through x + y = 4 at x = 3
  r = intersectSegmentTriangle(Vector3d(-1, 5, 0), Vector3d(5, 5, 0), V0, V1, V2);
  EXPECT_EQ(r.kind, HitKind::None);  // coplanar but disjoint
  r = intersectSegmentTriangle(Vector3d(-1, 1, 1e-12), Vector3d(5, 1, -1e-12), V0, V1, V2);
  EXPECT_EQ(r.kind, HitKind::Coplanar);  // within the tolerance of the plane
}

TEST(SegmentTriangle, DegenerateInputsGiveNoNaN) {
  auto r = intersectSegmentTriangle(Vector3d(1, 1, 1), Vector3d(1, 1, -1), V0, V1, Vector3d(8, 0, 0));
  EXPECT_EQ(r.kind, HitKind::None);
  EXPECT_TRUE(r.degenerate);
  r = intersectSegmentTriangle(Vector3d(1, 1, 0), Vector3d(1, 1, 0), V0, V1, V2);  // a point on it
  EXPECT_EQ(r.kind, HitKind::Interior);
  r = intersectSegmentTriangle(Vector3d(1, 1, 1), Vector3d(1, 1, 1), V0, V1, V2);
  EXPECT_EQ(r.kind, HitKind::None);
}

// --- oracle vectors from public test suites -----------------------------------

Vector3d parseVec(const std::string& s) {
  std::istringstream in(s);
  Vector3d v;
  in >> v.x() >> v.y() >> v.z();
  return v;
}

std::vector<std::string> splitCsv(const std::string& line) {
  std::vector<std::string> out;
  std::string cur;
  bool quoted = false;
  for (char c : line) {
    if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  out.push_back(cur);
  return out;
}

TEST(SegmentTriangle, OracleVectors) {
  LD_REQUIRE_SHARED_DATA(path, "oracles/segtri_vectors.csv");
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  const auto header = splitCsv(line);
  auto col = [&](const std::string& name) {
    for (std::size_t i = 0; i < header.size(); ++i)
      if (header[i] == name) return i;
    ADD_FAILURE() << "no column " << name;
    return std::size_t{0};
  };
  const std::size_t cCase = col("case"), cKind = col("kind"), cP0 = col("p0"), cP1 = col("p1_or_dir"), cA = col("a"),
                    cB = col("b"), cC = col("c"), cHit = col("expected_hit"), cPoint = col("expected_point");
  int n = 0;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    const auto f = splitCsv(line);
    ASSERT_GT(f.size(), cPoint) << line;
    const Vector3d p0 = parseVec(f[cP0]);
    Vector3d p1 = parseVec(f[cP1]);
    if (f[cKind] == "ray") p1 = p0 + 1e3 * p1;  // rays: a segment far past the triangle
    // Our test never culls back faces: "false(cull)/true(no cull)" expects a hit.
    const bool expected = f[cHit].find("true") != std::string::npos;
    const auto r = intersectSegmentTriangle(p0, p1, parseVec(f[cA]), parseVec(f[cB]), parseVec(f[cC]));
    EXPECT_EQ(r.hit(), expected) << f[cCase];
    EXPECT_NE(r.kind, HitKind::Coplanar) << f[cCase];
    if (expected && !f[cPoint].empty()) {
      EXPECT_TRUE(nearVec(r.point, parseVec(f[cPoint]), 1e-9)) << f[cCase];
    }
    if (f[cCase] == "G-seg-1" || f[cCase] == "S-ray-1") {
      EXPECT_EQ(r.kind, HitKind::OnEdge) << f[cCase];
    }
    if (f[cCase] == "G-seg-2") {
      EXPECT_EQ(r.kind, HitKind::OnVertex) << f[cCase];
    }
    ++n;
  }
  EXPECT_EQ(n, 14);
}

}  // namespace
}  // namespace ld::collision

namespace ld::collision {
namespace {

// An n x n grid of unit squares in z = 0, each split along its diagonal.
mesh::SurfaceMesh grid(int n) {
  mesh::SurfaceMesh m;
  std::vector<mesh::Vertex> v;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) v.push_back(m.addVertex(Vector3d(i, j, 0)));
  auto at = [&](int i, int j) { return v[static_cast<std::size_t>(j * (n + 1) + i)]; };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      m.addFace(at(i, j), at(i + 1, j), at(i + 1, j + 1));
      m.addFace(at(i, j), at(i + 1, j + 1), at(i, j + 1));
    }
  return m;
}

TEST(IntersectSegmentMesh, VertexHitIsReportedOnceOnItsLowestFace) {
  const auto m = grid(2);
  const auto hits = intersectSegment(m, Vector3d(1, 1, 1), Vector3d(1, 1, -1));
  ASSERT_EQ(hits.size(), 1u);
  EXPECT_EQ(hits[0].kind, HitKind::OnVertex);
  EXPECT_EQ(hits[0].vertex, mesh::Vertex(4));
  EXPECT_EQ(m.vertices(hits[0].face)[static_cast<std::size_t>(hits[0].local)], hits[0].vertex);
  for (mesh::Face f : m.faces(hits[0].vertex)) EXPECT_LE(hits[0].face, f);
}

TEST(IntersectSegmentMesh, EdgeHitIsReportedOnceWithTheMeshEdge) {
  const auto m = grid(2);
  const auto hits = intersectSegment(m, Vector3d(0.5, 1, 1), Vector3d(0.5, 1, -1));
  ASSERT_EQ(hits.size(), 1u);
  EXPECT_EQ(hits[0].kind, HitKind::OnEdge);
  EXPECT_EQ(m.edges(hits[0].face)[static_cast<std::size_t>(hits[0].local)], hits[0].edge);
  const Vector3d p0 = m.position(m.vertex(hits[0].edge, 0)), p1 = m.position(m.vertex(hits[0].edge, 1));
  EXPECT_TRUE(near(p0.y(), 1.0, 0) && near(p1.y(), 1.0, 0));
  // A diagonal edge, crossed slightly off-vertical: still once.
  const auto diag = intersectSegment(m, Vector3d(0.4, 0.5, 1), Vector3d(0.6, 0.5, -1));
  ASSERT_EQ(diag.size(), 1u);
  EXPECT_EQ(diag[0].kind, HitKind::OnEdge);
}

TEST(IntersectSegmentMesh, HitsOnSeveralLayersAreSortedByT) {
  auto m = grid(2);
  // A second sheet at z = -1 (normals both +z).
  const std::size_t nv = m.nVertices();
  std::vector<mesh::Vertex> copy;
  for (std::size_t i = 0; i < nv; ++i) copy.push_back(m.addVertex(m.position(mesh::Vertex(i)) - Vector3d(0, 0, 1)));
  const std::size_t nf = m.nFaces();
  for (std::size_t i = 0; i < nf; ++i) {
    const auto& vs = m.vertices(mesh::Face(i));
    m.addFace(copy[vs[0].idx()], copy[vs[1].idx()], copy[vs[2].idx()]);
  }
  const auto hits = intersectSegment(m, Vector3d(0.3, 0.6, -3), Vector3d(0.3, 0.6, 1));
  ASSERT_EQ(hits.size(), 2u);
  EXPECT_TRUE(near(hits[0].t, 0.5, 1e-12));
  EXPECT_TRUE(near(hits[1].t, 0.75, 1e-12));
  EXPECT_EQ(hits[0].kind, HitKind::Interior);
  EXPECT_EQ(hits[0].direction, -1);
  EXPECT_TRUE(nearVec(hits[1].point, Vector3d(0.3, 0.6, 0), 1e-12));
  EXPECT_TRUE(intersectSegment(m, Vector3d(3, 3, -3), Vector3d(3, 3, 1)).empty());
}

}  // namespace
}  // namespace ld::collision
