#include "sim/collision/swept.h"

#include <algorithm>
#include <cmath>

namespace ld::collision {

using Eigen::Vector3d;
using mesh::Edge;
using mesh::Face;

int sweepStrips(const Vector3d& a0, const Vector3d& b0, const Vector3d& a1, const Vector3d& b1,
                const SweepSettings& settings) {
  // The bilinear patch departs from its two-triangle split by at most |twist| / 4,
  // and the twist of one of N strips is 1/N of the whole.
  const double twist = (a0 - b0 - a1 + b1).norm();
  const double dev = std::max(settings.maxTwistDeviation, 1e-12);
  const double n = std::ceil(twist / (4.0 * dev));
  return static_cast<int>(std::clamp(n, 1.0, static_cast<double>(std::max(1, settings.maxStrips))));
}

SweptContacts sweepSegment(const mesh::SurfaceMesh& m, const TriangleBvh* bvh, const Vector3d& a0, const Vector3d& b0,
                           const Vector3d& a1, const Vector3d& b1, const SweepSettings& settings) {
  SweptContacts out;
  const Tolerance& tol = settings.tol;
  if (bvh) {
    bvh->intersectSegment(m, a0, b0, out.before);
    bvh->intersectSegment(m, a1, b1, out.after);
    bvh->intersectSegment(m, a0, a1, out.pathA);
    bvh->intersectSegment(m, b0, b1, out.pathB);
  } else {
    out.before = intersectSegment(m, a0, b0, tol);
    out.after = intersectSegment(m, a1, b1, tol);
    out.pathA = intersectSegment(m, a0, a1, tol);
    out.pathB = intersectSegment(m, b0, b1, tol);
  }

  const int strips = sweepStrips(a0, b0, a1, b1, settings);
  // Per strip triangle: the edges of faces in leaves the triangle meets (BVH with a
  // separating-axis test), each tested against that triangle only. An edge keeps
  // its earliest crossing.
  std::vector<Face> candidates;
  std::vector<Edge> edges;
  std::vector<SweptEdgeCrossing> found;
  for (int j = 0; j < strips; ++j) {
    const double s0 = static_cast<double>(j) / strips, s1 = static_cast<double>(j + 1) / strips;
    const Vector3d A0 = a0 + s0 * (a1 - a0), B0 = b0 + s0 * (b1 - b0);
    const Vector3d A1 = a0 + s1 * (a1 - a0), B1 = b0 + s1 * (b1 - b0);
    // Triangle 1 (A0, B0, B1): corners at (time, along) (0,0), (0,1), (1,1);
    // triangle 2 (A0, B1, A1): (0,0), (1,1), (1,0).
    for (int k = 0; k < 2; ++k) {
      const Vector3d& P = A0;
      const Vector3d& Q = k == 0 ? B0 : B1;
      const Vector3d& R = k == 0 ? B1 : A1;
      candidates.clear();
      if (bvh) {
        bvh->facesNearTriangle(P, Q, R, candidates);
      } else {
        for (Face f : m.faces()) candidates.push_back(f);
      }
      edges.clear();
      for (Face f : candidates)
        for (Edge e : m.edges(f)) edges.push_back(e);
      std::sort(edges.begin(), edges.end());
      edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
      for (Edge e : edges) {
        const SegTriResult r =
            intersectSegmentTriangle(m.position(m.vertex(e, 0)), m.position(m.vertex(e, 1)), P, Q, R, tol);
        if (!r.hit()) continue;
        SweptEdgeCrossing c;
        c.edge = e;
        c.edgeT = r.t;
        c.point = r.point;
        const double localTime = k == 0 ? r.bary[2] : r.bary[1] + r.bary[2];
        const double along = k == 0 ? r.bary[1] + r.bary[2] : r.bary[1];
        c.time = std::clamp(s0 + localTime * (s1 - s0), 0.0, 1.0);
        c.along = std::clamp(along, 0.0, 1.0);
        c.coplanar = r.kind == HitKind::Coplanar;
        found.push_back(c);
      }
    }
  }
  // Each edge once: its earliest crossing (then the lowest `along`).
  std::sort(found.begin(), found.end(), [](const SweptEdgeCrossing& x, const SweptEdgeCrossing& y) {
    if (x.edge != y.edge) return x.edge < y.edge;
    if (x.time != y.time) return x.time < y.time;
    return x.along < y.along;
  });
  for (std::size_t i = 0; i < found.size(); ++i)
    if (i == 0 || found[i].edge != found[i - 1].edge) out.edgeCrossings.push_back(found[i]);
  std::sort(out.edgeCrossings.begin(), out.edgeCrossings.end(),
            [](const SweptEdgeCrossing& x, const SweptEdgeCrossing& y) {
              if (x.time != y.time) return x.time < y.time;
              if (x.along != y.along) return x.along < y.along;
              return x.edge < y.edge;
            });

  for (const SweptEdgeCrossing& c : out.edgeCrossings)
    for (int k = 0; k < 2; ++k) {
      const Face f = m.face(c.edge, k);
      if (f.isValid()) out.faces.push_back(f);
    }
  auto addHitFaces = [&](const std::vector<SurfaceHit>& hits) {
    for (const SurfaceHit& h : hits) {
      out.faces.push_back(h.face);
      // A canonical edge/vertex hit stands for every face around it.
      if (h.kind == HitKind::OnEdge) {
        for (int k = 0; k < 2; ++k)
          if (m.face(h.edge, k).isValid()) out.faces.push_back(m.face(h.edge, k));
      } else if (h.kind == HitKind::OnVertex) {
        for (Edge e : m.edges(h.vertex))
          for (int k = 0; k < 2; ++k)
            if (m.face(e, k).isValid()) out.faces.push_back(m.face(e, k));
      }
    }
  };
  addHitFaces(out.before);
  addHitFaces(out.after);
  addHitFaces(out.pathA);
  addHitFaces(out.pathB);
  std::sort(out.faces.begin(), out.faces.end());
  out.faces.erase(std::unique(out.faces.begin(), out.faces.end()), out.faces.end());
  return out;
}

}  // namespace ld::collision
