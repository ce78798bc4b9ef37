#include "sim/cutting/mesh_checks.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <vector>

namespace ld::cutting {

using mesh::Edge;
using mesh::Face;
using mesh::Vertex;

bool isManifoldVertex(const mesh::SurfaceMesh& m, Vertex v) {
  const std::vector<Face> around = m.faces(v);
  if (around.size() <= 1) return true;
  std::vector<int> parent(around.size());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int i) {
    while (parent[static_cast<std::size_t>(i)] != i) i = parent[static_cast<std::size_t>(i)];
    return i;
  };
  auto index = [&](Face f) { return static_cast<int>(std::find(around.begin(), around.end(), f) - around.begin()); };
  for (Edge e : m.edges(v)) {
    const Face f0 = m.face(e, 0), f1 = m.face(e, 1);
    if (!f0.isValid() || !f1.isValid()) continue;
    parent[static_cast<std::size_t>(find(index(f0)))] = find(index(f1));
  }
  const int root = find(0);
  for (std::size_t i = 1; i < around.size(); ++i)
    if (find(static_cast<int>(i)) != root) return false;
  return true;
}

MeshQuality measureQuality(const mesh::SurfaceMesh& m) {
  MeshQuality q;
  q.minArea = std::numeric_limits<double>::infinity();
  q.minAngleDeg = 180.0;
  q.minEdge = std::numeric_limits<double>::infinity();
  for (Face f : m.faces()) {
    const auto& v = m.vertices(f);
    const Eigen::Vector3d p[3] = {m.position(v[0]), m.position(v[1]), m.position(v[2])};
    q.minArea = std::min(q.minArea, m.faceArea(f));
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d a = p[(i + 1) % 3] - p[i], b = p[(i + 2) % 3] - p[i];
      const double na = a.norm(), nb = b.norm();
      double ang = 0.0;
      if (na > 0.0 && nb > 0.0) ang = std::acos(std::clamp(a.dot(b) / (na * nb), -1.0, 1.0)) * 180.0 / M_PI;
      q.minAngleDeg = std::min(q.minAngleDeg, ang);
    }
  }
  for (Edge e : m.edges()) q.minEdge = std::min(q.minEdge, m.edgeLength(e));
  for (Vertex v : m.vertices()) {
    if (!m.position(v).allFinite()) q.finite = false;
    if (!isManifoldVertex(m, v)) q.manifoldVertices = false;
  }
  if (m.nFaces() == 0) q.minArea = q.minAngleDeg = q.minEdge = 0.0;
  q.closed = m.isClosed();
  q.components = m.connectedComponents().count;
  return q;
}

}  // namespace ld::cutting
