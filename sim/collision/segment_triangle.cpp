#include "sim/collision/segment_triangle.h"

#include <algorithm>
#include <cmath>

namespace ld::collision {

using Eigen::Vector3d;

namespace {

double maxAbs(const Vector3d& p) { return p.cwiseAbs().maxCoeff(); }

// In-plane signed distances of p to the three edge lines (positive inside).
struct EdgeFrame {
  Vector3d inward[3];  // unit, in the plane, perpendicular to edge i, pointing inside
  double length[3];
  const Vector3d* corner[3];
  double twiceArea;

  Vector3d distances(const Vector3d& p) const {
    return {inward[0].dot(p - *corner[0]), inward[1].dot(p - *corner[1]), inward[2].dot(p - *corner[2])};
  }
  // Barycentric weight of corner (i+2)%3 is the distance to edge i over the altitude.
  Vector3d bary(const Vector3d& s) const {
    Vector3d w;
    for (int i = 0; i < 3; ++i) w[(i + 2) % 3] = s[i] * length[i] / twiceArea;
    return w;
  }
};

// Classifies a point already known to lie within eps of the plane.
void classifyPoint(const EdgeFrame& fr, const Vector3d& q, double eps, SegTriResult& r) {
  const Vector3d s = fr.distances(q);
  if (s.minCoeff() < -eps) return;  // kind stays None
  r.bary = fr.bary(s);
  r.point = q;
  for (int c = 0; c < 3; ++c) {
    if ((q - *fr.corner[c]).squaredNorm() <= eps * eps) {
      r.kind = HitKind::OnVertex;
      r.local = c;
      return;
    }
  }
  int nearest = 0;
  for (int i = 1; i < 3; ++i)
    if (s[i] < s[nearest]) nearest = i;
  if (s[nearest] <= eps) {
    r.kind = HitKind::OnEdge;
    r.local = nearest;
  } else {
    r.kind = HitKind::Interior;
  }
}

}  // namespace

SegTriResult intersectSegmentTriangle(const Vector3d& a, const Vector3d& b, const Vector3d& v0, const Vector3d& v1,
                                      const Vector3d& v2, const Tolerance& tol) {
  SegTriResult r;
  const double scale = std::max({maxAbs(a), maxAbs(b), maxAbs(v0), maxAbs(v1), maxAbs(v2)});
  const double eps = effectiveTolerance(tol, scale);

  const Vector3d e[3] = {v1 - v0, v2 - v1, v0 - v2};
  const Vector3d n = e[0].cross(-e[2]);
  const double twiceArea = n.norm();
  // Cheap early out (most calls): both ends clearly on one side of the plane.
  const double H0 = n.dot(a - v0), H1 = n.dot(b - v0), lim = eps * twiceArea;
  if ((H0 > lim && H1 > lim) || (H0 < -lim && H1 < -lim)) return r;
  EdgeFrame fr;
  fr.corner[0] = &v0;
  fr.corner[1] = &v1;
  fr.corner[2] = &v2;
  double longest = 0.0;
  for (int i = 0; i < 3; ++i) {
    fr.length[i] = e[i].norm();
    longest = std::max(longest, fr.length[i]);
  }
  // Every altitude is at most eps: no plane worth the name.
  if (!(twiceArea > eps * longest) || twiceArea == 0.0) {
    r.degenerate = true;
    return r;
  }
  const Vector3d nh = n / twiceArea;
  fr.twiceArea = twiceArea;
  for (int i = 0; i < 3; ++i) fr.inward[i] = nh.cross(e[i]) / fr.length[i];

  const Vector3d d = b - a;
  const double h0 = H0 / twiceArea;  // heights of the ends over the plane
  const double h1 = H1 / twiceArea;
  const bool on0 = std::abs(h0) <= eps;
  const bool on1 = std::abs(h1) <= eps;

  if (d.squaredNorm() <= eps * eps) {  // a point
    if (!on0) return r;
    classifyPoint(fr, a, eps, r);
    r.t = r.tExit = 0.0;
    r.endTouch = EndTouch::Start;
    return r;
  }

  if (on0 && on1) {
    // Coplanar: clip the segment by the three edge half-planes grown by eps.
    const Vector3d s0 = fr.distances(a), s1 = fr.distances(b);
    double lo = 0.0, hi = 1.0;
    for (int i = 0; i < 3; ++i) {
      const double f0 = s0[i] + eps, f1 = s1[i] + eps;
      if (f0 < 0.0 && f1 < 0.0) return r;
      if (f0 < 0.0) lo = std::max(lo, f0 / (f0 - f1));
      if (f1 < 0.0) hi = std::min(hi, f0 / (f0 - f1));
    }
    if (lo > hi) return r;
    r.kind = HitKind::Coplanar;
    r.t = lo;
    r.tExit = hi;
    r.point = a + lo * d;
    r.bary = fr.bary(fr.distances(r.point));
    return r;
  }

  if ((h0 > eps && h1 > eps) || (h0 < -eps && h1 < -eps)) return r;

  // The line's crossing with the plane; when it falls off the triangle or off the
  // segment, an end lying on the plane (within eps) may still touch the triangle.
  const double tc = h0 / (h0 - h1);  // h0 != h1: one end is farther than eps from the plane
  double t = 0.0;
  if (tc >= 0.0 && tc <= 1.0) {
    t = tc;
    classifyPoint(fr, a + tc * d, eps, r);
  }
  if (r.kind == HitKind::None && on0) {
    t = 0.0;
    classifyPoint(fr, a, eps, r);
  }
  if (r.kind == HitKind::None && on1) {
    t = 1.0;
    classifyPoint(fr, b, eps, r);
  }
  if (r.kind == HitKind::None) return r;
  if (on0) {
    r.endTouch = EndTouch::Start;
  } else if (on1) {
    r.endTouch = EndTouch::End;
  }
  r.t = r.tExit = t;
  r.direction = h0 > h1 ? 1 : -1;
  return r;
}

SurfaceHit toSurfaceHit(const mesh::SurfaceMesh& m, mesh::Face f, const SegTriResult& r) {
  SurfaceHit h;
  if (!r.hit()) return h;
  h.face = f;
  h.kind = r.kind;
  h.local = r.local;
  if (r.kind == HitKind::OnEdge) h.edge = m.edges(f)[static_cast<std::size_t>(r.local)];
  if (r.kind == HitKind::OnVertex) h.vertex = m.vertices(f)[static_cast<std::size_t>(r.local)];
  h.t = r.t;
  h.tExit = r.tExit;
  h.bary = r.bary;
  h.point = r.point;
  h.direction = r.direction;
  h.endTouch = r.endTouch;
  return h;
}

SurfaceHit intersectSegmentFace(const mesh::SurfaceMesh& m, mesh::Face f, const Vector3d& a, const Vector3d& b,
                                const Tolerance& tol) {
  const auto& vs = m.vertices(f);
  return toSurfaceHit(m, f,
                      intersectSegmentTriangle(a, b, m.position(vs[0]), m.position(vs[1]), m.position(vs[2]), tol));
}

double defaultMergeDistance(const Vector3d& a, const Vector3d& b, const Tolerance& tol) {
  const double eps = effectiveTolerance(tol, std::max(maxAbs(a), maxAbs(b)));
  return std::max(16.0 * eps, 1e-7 * (b - a).norm());
}

namespace {

bool faceHasVertex(const mesh::SurfaceMesh& m, mesh::Face f, mesh::Vertex v) {
  const auto& vs = m.vertices(f);
  return vs[0] == v || vs[1] == v || vs[2] == v;
}
bool faceHasEdge(const mesh::SurfaceMesh& m, mesh::Face f, mesh::Edge e) {
  const auto& es = m.edges(f);
  return es[0] == e || es[1] == e || es[2] == e;
}

int dimension(HitKind k) {
  switch (k) {
    case HitKind::OnVertex:
      return 0;
    case HitKind::OnEdge:
      return 1;
    default:
      return 2;
  }
}

// True when the lower-dimensional hit g covers hit h (same contact, seen from a neighbour).
bool covers(const mesh::SurfaceMesh& m, const SurfaceHit& g, const SurfaceHit& h, double mergeDistance) {
  if (h.kind == HitKind::Coplanar || g.kind == HitKind::Coplanar) return false;
  if (dimension(g.kind) >= dimension(h.kind)) return false;
  if ((g.point - h.point).squaredNorm() > mergeDistance * mergeDistance) return false;
  if (g.kind == HitKind::OnVertex) {
    if (h.kind == HitKind::OnEdge) return m.vertex(h.edge, 0) == g.vertex || m.vertex(h.edge, 1) == g.vertex;
    return faceHasVertex(m, h.face, g.vertex);
  }
  return faceHasEdge(m, h.face, g.edge);  // g OnEdge, h Interior
}

}  // namespace

void canonicalizeHits(const mesh::SurfaceMesh& m, std::vector<SurfaceHit>& hits, double mergeDistance) {
  // Deterministic order first: by feature, then face, so "lowest face wins" below.
  std::sort(hits.begin(), hits.end(), [](const SurfaceHit& x, const SurfaceHit& y) {
    if (x.kind != y.kind) return x.kind < y.kind;
    if (x.kind == HitKind::OnVertex && x.vertex != y.vertex) return x.vertex < y.vertex;
    if (x.kind == HitKind::OnEdge && x.edge != y.edge) return x.edge < y.edge;
    return x.face < y.face;
  });
  std::vector<SurfaceHit> kept;
  kept.reserve(hits.size());
  for (const SurfaceHit& h : hits) {
    if (!kept.empty()) {
      const SurfaceHit& p = kept.back();
      if (h.kind == p.kind &&
          ((h.kind == HitKind::OnVertex && h.vertex == p.vertex) || (h.kind == HitKind::OnEdge && h.edge == p.edge)))
        continue;
    }
    kept.push_back(h);
  }
  hits.clear();
  for (const SurfaceHit& h : kept) {
    bool covered = false;
    for (const SurfaceHit& g : kept)
      if (covers(m, g, h, mergeDistance)) {
        covered = true;
        break;
      }
    if (!covered) hits.push_back(h);
  }
  std::sort(hits.begin(), hits.end(), [](const SurfaceHit& x, const SurfaceHit& y) {
    if (x.t != y.t) return x.t < y.t;
    if (x.kind != y.kind) return x.kind < y.kind;
    return x.face < y.face;
  });
}

std::vector<SurfaceHit> intersectSegment(const mesh::SurfaceMesh& m, const Vector3d& a, const Vector3d& b,
                                         const Tolerance& tol) {
  std::vector<SurfaceHit> hits;
  for (mesh::Face f : m.faces()) {
    SurfaceHit h = intersectSegmentFace(m, f, a, b, tol);
    if (h.kind != HitKind::None) hits.push_back(h);
  }
  canonicalizeHits(m, hits, defaultMergeDistance(a, b, tol));
  return hits;
}

}  // namespace ld::collision
