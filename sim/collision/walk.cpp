#include "sim/collision/walk.h"

#include <algorithm>

namespace ld::collision {

using Eigen::Vector3d;
using mesh::Face;

namespace {

void addFacesAround(const mesh::SurfaceMesh& m, mesh::Vertex v, std::vector<Face>& out) {
  for (mesh::Edge e : m.edges(v))
    for (int k = 0; k < 2; ++k) {
      const Face g = m.face(e, k);
      if (g.isValid()) out.push_back(g);
    }
}

void uniqueKeepFirst(std::vector<Face>& out, std::size_t from) {
  // Small lists: keep the first element in place, sort and dedup the rest.
  if (out.size() <= from + 1) return;
  const Face first = out[from];
  std::sort(out.begin() + static_cast<std::ptrdiff_t>(from), out.end());
  out.erase(std::unique(out.begin() + static_cast<std::ptrdiff_t>(from), out.end()), out.end());
  auto it = std::find(out.begin() + static_cast<std::ptrdiff_t>(from), out.end(), first);
  std::rotate(out.begin() + static_cast<std::ptrdiff_t>(from), it, it + 1);
}

}  // namespace

void faceNeighbourhood(const mesh::SurfaceMesh& m, Face f, std::vector<Face>& out) {
  out.clear();
  out.push_back(f);
  for (mesh::Vertex v : m.vertices(f)) addFacesAround(m, v, out);
  uniqueKeepFirst(out, 0);
}

void hitNeighbourhood(const mesh::SurfaceMesh& m, const SurfaceHit& h, std::vector<Face>& out) {
  if (h.kind == HitKind::OnVertex && h.vertex.isValid()) {
    out.clear();
    out.push_back(h.face);
    addFacesAround(m, h.vertex, out);
    uniqueKeepFirst(out, 0);
  } else if (h.kind == HitKind::OnEdge && h.edge.isValid()) {
    out.clear();
    out.push_back(h.face);
    addFacesAround(m, m.vertex(h.edge, 0), out);
    addFacesAround(m, m.vertex(h.edge, 1), out);
    uniqueKeepFirst(out, 0);
  } else {
    faceNeighbourhood(m, h.face, out);
  }
}

void intersectNeighbourhood(const mesh::SurfaceMesh& m, Face f, const Vector3d& a, const Vector3d& b,
                            std::vector<SurfaceHit>& out, const Tolerance& tol) {
  std::vector<Face> faces;
  faceNeighbourhood(m, f, faces);
  out.clear();
  for (Face g : faces) {
    SurfaceHit h = intersectSegmentFace(m, g, a, b, tol);
    if (h.kind != HitKind::None) out.push_back(h);
  }
  if (out.size() > 1) canonicalizeHits(m, out, defaultMergeDistance(a, b, tol));
}

std::optional<SurfaceHit> walkToHit(const mesh::SurfaceMesh& m, Face start, const Vector3d& a, const Vector3d& b,
                                    int maxSteps, const Tolerance& tol) {
  Face f = start;
  Face previous;
  const Vector3d d = b - a;
  for (int step = 0; step < maxSteps && f.isValid(); ++step) {
    SurfaceHit h = intersectSegmentFace(m, f, a, b, tol);
    if (h.kind != HitKind::None) return h;
    const auto& vs = m.vertices(f);
    const Vector3d p0 = m.position(vs[0]), p1 = m.position(vs[1]), p2 = m.position(vs[2]);
    const Vector3d n = (p1 - p0).cross(p2 - p0);
    const double denom = n.dot(d);
    if (denom == 0.0 || n.squaredNorm() == 0.0) return std::nullopt;  // parallel or degenerate
    const Vector3d q = a + (n.dot(p0 - a) / denom) * d;               // the line meets the plane here
    // Signed areas of q against each edge i (corner i -> i+1); the most negative
    // one is the edge to cross.
    const Vector3d* p[3] = {&p0, &p1, &p2};
    int worst = -1;
    double worstValue = 0.0;
    for (int i = 0; i < 3; ++i) {
      const double s = n.dot((*p[(i + 1) % 3] - *p[i]).cross(q - *p[i]));
      if (s < worstValue) {
        worstValue = s;
        worst = i;
      }
    }
    if (worst < 0) return std::nullopt;  // the line crosses here, but the segment does not reach
    Face next = m.otherFace(m.edges(f)[static_cast<std::size_t>(worst)], f);
    if (next == previous) {
      // Do not bounce between two faces on a fold: try the second worst edge.
      int second = -1;
      double secondValue = 0.0;
      for (int i = 0; i < 3; ++i) {
        if (i == worst) continue;
        const double s = n.dot((*p[(i + 1) % 3] - *p[i]).cross(q - *p[i]));
        if (s < secondValue) {
          secondValue = s;
          second = i;
        }
      }
      if (second < 0) return std::nullopt;
      next = m.otherFace(m.edges(f)[static_cast<std::size_t>(second)], f);
    }
    previous = f;
    f = next;
  }
  return std::nullopt;
}

}  // namespace ld::collision
