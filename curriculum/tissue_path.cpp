#include "curriculum/tissue_path.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_set>

#include "curriculum/curriculum_error.h"

namespace ld::curriculum {

using mesh::Face;
using mesh::SurfaceMesh;

Eigen::Vector3d position(const SurfaceMesh& m, const SurfaceLocation& loc) {
  if (!m.isValid(loc.face)) throw PathError("position: the path point's face is not in the mesh");
  const auto& v = m.vertices(loc.face);
  return loc.bary[0] * m.position(v[0]) + loc.bary[1] * m.position(v[1]) + loc.bary[2] * m.position(v[2]);
}

Eigen::Vector3d closestBarycentric(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                   const Eigen::Vector3d& c) {
  // Voronoi regions of the triangle's features (Ericson, Real-Time Collision Detection 5.1.5).
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return {1, 0, 0};
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return {0, 1, 0};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    return {1 - v, v, 0};
  }
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return {0, 0, 1};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    return {1 - w, 0, w};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {0, 1 - w, w};
  }
  const double den = va + vb + vc;
  if (!(std::abs(den) > 0)) return {1, 0, 0};  // degenerate triangle
  const double v = vb / den, w = vc / den;
  return {1 - v - w, v, w};
}

namespace {

SurfaceLocation closestIn(const SurfaceMesh& m, Face f, const Eigen::Vector3d& p, double& d2) {
  const auto& v = m.vertices(f);
  SurfaceLocation loc{f, closestBarycentric(p, m.position(v[0]), m.position(v[1]), m.position(v[2]))};
  d2 = (position(m, loc) - p).squaredNorm();
  return loc;
}

}  // namespace

SurfaceLocation closestLocation(const SurfaceMesh& m, const Eigen::Vector3d& p, double* distance) {
  SurfaceLocation best;
  double bestD2 = std::numeric_limits<double>::infinity();
  for (Face f : m.faces()) {
    double d2;
    SurfaceLocation loc = closestIn(m, f, p, d2);
    if (d2 < bestD2) {
      bestD2 = d2;
      best = loc;
    }
  }
  if (distance) *distance = std::sqrt(bestD2);
  return best;
}

SurfaceLocation closestLocationNear(const SurfaceMesh& m, Face start, const Eigen::Vector3d& p, int rings,
                                    double* distance) {
  if (!m.isValid(start)) return closestLocation(m, p, distance);
  std::unordered_set<Face> seen{start};
  std::vector<Face> frontier{start};
  SurfaceLocation best;
  double bestD2 = std::numeric_limits<double>::infinity();
  for (int r = 0; r <= rings && !frontier.empty(); ++r) {
    std::vector<Face> next;
    for (Face f : frontier) {
      double d2;
      SurfaceLocation loc = closestIn(m, f, p, d2);
      if (d2 < bestD2) {
        bestD2 = d2;
        best = loc;
      }
      for (mesh::Vertex v : m.vertices(f))
        for (Face g : m.faces(v))
          if (seen.insert(g).second) next.push_back(g);
    }
    frontier = std::move(next);
  }
  if (distance) *distance = std::sqrt(bestD2);
  return best;
}

void tagOriginalFaces(SurfaceMesh& m) {
  auto prop = m.faceProperty<std::int64_t>(kOriginFaceProp, -1);
  for (Face f : m.faces()) prop[f] = static_cast<std::int64_t>(f.idx());
}

std::int64_t originalFace(const SurfaceMesh& m, Face f) {
  auto prop = m.getFaceProperty<std::int64_t>(kOriginFaceProp);
  if (prop && prop[f] >= 0) return prop[f];
  return static_cast<std::int64_t>(f.idx());
}

TissuePath TissuePath::embed(const SurfaceMesh& m, const Polyline& world, double maxDistance) {
  TissuePath tp;
  Face hint;
  for (std::size_t i = 0; i < world.size(); ++i) {
    double d = 0.0;
    SurfaceLocation loc = closestLocationNear(m, hint, world[i].p, 2, &d);
    if (d > 1e-6) loc = closestLocation(m, world[i].p, &d);
    if (!m.isValid(loc.face) || !(d <= maxDistance))
      throw PathError("path point " + std::to_string(i) + " is " + std::to_string(d) +
                      " mm from the surface (more than " + std::to_string(maxDistance) + " mm)");
    hint = loc.face;
    tp.pts_.push_back({loc, world[i].stop || i + 1 == world.size(), false});
  }
  tp.startTracking(m);
  tp.rest_ = tp.world_;
  return tp;
}

namespace {

std::int64_t originTag(const SurfaceMesh& m, Face f) {
  const auto prop = m.getFaceProperty<std::int64_t>(kOriginFaceProp);
  return prop ? prop[f] : -1;
}

int faceKind(const SurfaceMesh& m, Face f) {
  // Walls the cutter adds (groove, side) share the cut's edges with the surface: a
  // point on such an edge stays on the surface face.
  const auto kind = m.getFaceProperty<int>("f:cut_kind");
  return kind ? kind[f] : 0;
}

// Of the faces considered, the one holding p (within tol; the surface preferred over
// a wall), else the nearest.
struct Nearest {
  const SurfaceMesh& m;
  Eigen::Vector3d p;
  double tol;
  SurfaceLocation best;
  double bestD2 = std::numeric_limits<double>::infinity();
  bool bestWall = true;
  void consider(Face f) {
    if (!m.isValid(f)) return;
    double d2;
    const SurfaceLocation loc = closestIn(m, f, p, d2);
    const bool wall = faceKind(m, f) != 0;
    const bool in = d2 <= tol * tol, bestIn = found();
    const bool better = in != bestIn ? in : in ? (bestWall && !wall) || (wall == bestWall && d2 < bestD2) : d2 < bestD2;
    if (better) {
      best = loc;
      bestD2 = d2;
      bestWall = wall;
    }
  }
  // The faces and those sharing a vertex with them, `rings` times.
  void considerAround(std::vector<Face> frontier, int rings) {
    std::unordered_set<Face> seen(frontier.begin(), frontier.end());
    for (int r = 0; r <= rings && !frontier.empty(); ++r) {
      std::vector<Face> next;
      for (Face f : frontier) {
        consider(f);
        for (mesh::Vertex v : m.vertices(f))
          for (Face g : m.faces(v))
            if (seen.insert(g).second) next.push_back(g);
      }
      frontier = std::move(next);
    }
  }
  [[nodiscard]] bool found() const { return bestD2 <= tol * tol; }
};

double tolerance(const Eigen::Vector3d& p) { return 1e-9 * (1.0 + p.cwiseAbs().maxCoeff()); }

}  // namespace

void TissuePath::startTracking(const SurfaceMesh& m) {
  std::vector<Eigen::Vector3d> w(pts_.size(), Eigen::Vector3d::Zero());
  origin_.assign(pts_.size(), -1);
  byFace_.clear();
  for (std::size_t i = 0; i < pts_.size(); ++i) {
    if (pts_[i].freed) {
      if (i < world_.size()) w[i] = world_[i];
      continue;
    }
    w[i] = position(m, pts_[i].loc);
    origin_[i] = originTag(m, pts_[i].loc.face);
    byFace_[pts_[i].loc.face.idx()].push_back(static_cast<std::uint32_t>(i));
  }
  world_ = std::move(w);
  layout_ = m.layoutVersion();
  journalFaces_ = m.editedFaces().size();
}

void TissuePath::refreshWorld(const SurfaceMesh& m) {
  for (std::size_t i = 0; i < pts_.size(); ++i)
    if (!pts_[i].freed) world_[i] = position(m, pts_[i].loc);
}

Eigen::Vector3d TissuePath::pointAt(const SurfaceMesh& m, std::size_t i) const {
  return pts_[i].freed ? world_[i] : position(m, pts_[i].loc);
}

std::size_t TissuePath::freedPoints() const {
  return static_cast<std::size_t>(std::count_if(pts_.begin(), pts_.end(), [](const Point& q) { return q.freed; }));
}

void TissuePath::relocate(const SurfaceMesh& m, std::size_t i, std::span<const Face> edited) {
  const Eigen::Vector3d& p = world_[i];
  Nearest n{m, p, tolerance(p), {}};
  if (m.isValid(pts_[i].loc.face)) n.considerAround({pts_[i].loc.face}, 2);  // the old face, two rings
  if (!n.found())
    for (Face f : edited) n.consider(f);
  if (!n.found()) {
    ++global_;
    double d = 0.0;
    const SurfaceLocation loc = closestLocation(m, p, &d);
    if (m.isValid(loc.face) && d * d < n.bestD2) n.best = loc;
  }
  if (!m.isValid(n.best.face)) throw PathError("followEdits: a path point has no face left in the mesh");
  pts_[i].loc = n.best;
  origin_[i] = originTag(m, n.best.face);
}

std::size_t TissuePath::relayout(const SurfaceMesh& m) {
  // Face indices changed (compaction; a separation compacts the mesh it keeps).
  const auto origin = m.getFaceProperty<std::int64_t>(kOriginFaceProp);
  std::unordered_map<std::int64_t, std::vector<Face>> byOrigin;
  if (origin)
    for (Face f : m.faces())
      if (origin[f] >= 0) byOrigin[origin[f]].push_back(f);
  std::size_t count = 0;
  for (std::size_t i = 0; i < pts_.size(); ++i) {
    if (pts_[i].freed) continue;
    ++count;
    if (origin && origin_[i] >= 0) {
      // The descendants of the point's original triangle (and a ring around them):
      // the point is on one of them, or it left with a freed piece.
      Nearest n{m, world_[i], tolerance(world_[i]), {}};
      const auto it = byOrigin.find(origin_[i]);
      if (it != byOrigin.end()) n.considerAround(it->second, 1);
      if (n.found())
        pts_[i].loc = n.best;
      else
        pts_[i].freed = true;
      continue;
    }
    double d = 0.0;
    pts_[i].loc = closestLocation(m, world_[i], &d);
    if (!m.isValid(pts_[i].loc.face)) throw PathError("followEdits: the mesh has no face left");
    ++global_;
  }
  const std::vector<Eigen::Vector3d> keep = world_;
  startTracking(m);
  world_ = keep;
  return count;
}

std::size_t TissuePath::followEdits(const SurfaceMesh& m) {
  if (m.layoutVersion() != layout_ || m.editedFaces().size() < journalFaces_) return relayout(m);
  const std::span<const Face> edited = m.editedFaces().subspan(journalFaces_);
  journalFaces_ = m.editedFaces().size();
  if (edited.empty() || byFace_.empty()) return 0;
  std::vector<std::uint32_t> affected;
  for (Face f : edited) {
    auto it = byFace_.find(f.idx());
    if (it == byFace_.end()) continue;
    affected.insert(affected.end(), it->second.begin(), it->second.end());
    byFace_.erase(it);
  }
  std::sort(affected.begin(), affected.end());
  affected.erase(std::unique(affected.begin(), affected.end()), affected.end());
  for (std::uint32_t i : affected) {
    relocate(m, i, edited);
    byFace_[pts_[i].loc.face.idx()].push_back(i);
  }
  return affected.size();
}

Polyline TissuePath::positions(const SurfaceMesh& m) const {
  Polyline out;
  out.reserve(pts_.size());
  for (std::size_t i = 0; i < pts_.size(); ++i) out.push_back({pointAt(m, i), pts_[i].stop || pts_[i].cut});
  return out;
}

Polyline TissuePath::drawnPositions(const SurfaceMesh& m) const {
  Polyline out;
  out.reserve(pts_.size());
  for (std::size_t i = 0; i < pts_.size(); ++i) out.push_back({pointAt(m, i), pts_[i].stop});
  return out;
}

std::vector<Eigen::Vector3d> TissuePath::worldPoints(const SurfaceMesh& m) const {
  std::vector<Eigen::Vector3d> out;
  out.reserve(pts_.size());
  for (std::size_t i = 0; i < pts_.size(); ++i) out.push_back(pointAt(m, i));
  return out;
}

void TissuePath::reembed(const SurfaceMesh& m, const std::vector<Eigen::Vector3d>& before) {
  if (before.size() != pts_.size()) throw PathError("reembed: positions do not match the path");
  for (std::size_t i = 0; i < pts_.size(); ++i) {
    if (pts_[i].freed) continue;
    const Eigen::Vector3d& p = before[i];
    const double tol = 1e-9 * (1.0 + p.cwiseAbs().maxCoeff());
    double d = std::numeric_limits<double>::infinity();
    if (m.isValid(pts_[i].loc.face)) {
      double d2;
      SurfaceLocation loc = closestIn(m, pts_[i].loc.face, p, d2);
      if (std::sqrt(d2) <= tol) {
        pts_[i].loc = loc;
        continue;
      }
      loc = closestLocationNear(m, pts_[i].loc.face, p, 3, &d);
      if (d <= tol) {
        pts_[i].loc = loc;
        continue;
      }
    }
    pts_[i].loc = closestLocation(m, p, &d);
  }
  startTracking(m);
}

void TissuePath::remap(const mesh::Compaction& c) {
  for (Point& q : pts_) {
    if (q.freed) continue;
    if (!q.loc.face.isValid() || q.loc.face.idx() >= c.faceMap.size())
      throw PathError("remap: a path point's face was removed");
    q.loc.face = c.faceMap[q.loc.face.idx()];
    if (!q.loc.face.isValid()) throw PathError("remap: a path point's face was removed");
  }
  byFace_.clear();
  for (std::size_t i = 0; i < pts_.size(); ++i)
    if (!pts_[i].freed) byFace_[pts_[i].loc.face.idx()].push_back(static_cast<std::uint32_t>(i));
  layout_ = ~std::uint64_t{0};  // the caller's mesh has a new layout: next followEdits rebuilds
}

bool segmentsCross(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                   const Eigen::Vector3d& d, const Eigen::Vector3d& n, double maxGap) {
  Eigen::Vector3d nn = n.norm() > 0 ? n.normalized() : Eigen::Vector3d(0, 0, 1);
  const Eigen::Vector3d u = nn.unitOrthogonal(), v = nn.cross(u);
  auto pr = [&](const Eigen::Vector3d& p) { return Eigen::Vector2d(p.dot(u), p.dot(v)); };
  const Eigen::Vector2d A = pr(a), B = pr(b), C = pr(c), D = pr(d);
  const Eigen::Vector2d r = B - A, s = D - C;
  const double den = r.x() * s.y() - r.y() * s.x();
  if (std::abs(den) <= 1e-15 * (r.norm() * s.norm() + 1e-300)) return false;
  const Eigen::Vector2d q = C - A;
  const double t = (q.x() * s.y() - q.y() * s.x()) / den, w = (q.x() * r.y() - q.y() * r.x()) / den;
  // Half-open: a crossing at a shared end point counts once along each chain.
  if (t < 0 || t >= 1 || w < 0 || w >= 1) return false;
  return ((a + t * (b - a)) - (c + w * (d - c))).norm() <= maxGap;
}

template <class At>
std::vector<std::size_t> TissuePath::crossedWith(const At& at, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                                 const Eigen::Vector3d& n, double maxGap) const {
  std::vector<std::size_t> out;
  if ((b - a).squaredNorm() <= 0) return out;
  const Eigen::Vector3d lo = a.cwiseMin(b).array() - maxGap, hi = a.cwiseMax(b).array() + maxGap;
  Eigen::Vector3d prev;
  for (std::size_t i = 0; i + 1 < pts_.size(); ++i) {
    const Eigen::Vector3d c = i == 0 ? at(0) : prev;
    const Eigen::Vector3d d = at(i + 1);
    prev = d;
    if (pts_[i].stop || pts_[i].freed || pts_[i + 1].freed) continue;
    if ((c.cwiseMax(d).array() < lo.array()).any() || (c.cwiseMin(d).array() > hi.array()).any()) continue;
    if (segmentsCross(a, b, c, d, n, maxGap)) out.push_back(i);
  }
  return out;
}

int TissuePath::cutAcross(const SurfaceMesh& m, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                          const Eigen::Vector3d& n, double maxGap) {
  const std::vector<std::size_t> crossed = crossedWith([&](std::size_t i) { return pointAt(m, i); }, a, b, n, maxGap);
  for (std::size_t i : crossed) markCut(i);
  return static_cast<int>(crossed.size());
}

int TissuePath::cutAcrossAtRest(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& n,
                                double maxGap) {
  const std::vector<std::size_t> crossed = crossingsAtRest(a, b, n, maxGap);
  for (std::size_t i : crossed) markCut(i);
  return static_cast<int>(crossed.size());
}

std::vector<std::size_t> TissuePath::crossingsAtRest(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                                     const Eigen::Vector3d& n, double maxGap) const {
  return crossedWith([&](std::size_t i) -> const Eigen::Vector3d& { return rest_[i]; }, a, b, n, maxGap);
}

void TissuePath::markCut(std::size_t segment) {
  if (segment >= pts_.size()) throw PathError("markCut: no such path segment");
  pts_[segment].cut = true;
}

template <class At>
double TissuePath::distanceWith(const At& at, const Eigen::Vector3d& p) const {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i + 1 < pts_.size(); ++i) {
    if (pts_[i].stop || pts_[i].freed || pts_[i + 1].freed) continue;
    const Eigen::Vector3d c = at(i), d = at(i + 1), cd = d - c;
    const double len2 = cd.squaredNorm();
    const double u = len2 > 0 ? std::clamp((p - c).dot(cd) / len2, 0.0, 1.0) : 0.0;
    best = std::min(best, (c + u * cd - p).norm());
  }
  return best;
}

double TissuePath::distance(const SurfaceMesh& m, const Eigen::Vector3d& p) const {
  return distanceWith([&](std::size_t i) { return pointAt(m, i); }, p);
}

double TissuePath::distanceAtRest(const Eigen::Vector3d& p) const {
  return distanceWith([&](std::size_t i) { return rest_[i]; }, p);
}

void CutPathRecorder::contact(const SurfaceMesh& m, Face f, const Eigen::Vector3d& p) {
  const std::int64_t o = originalFace(m, f);
  if (!open_) {
    path_.push_back({p, false});
    open_ = true;
    pending_ = false;
    origin_ = o;
  } else if (o == origin_) {
    last_ = p;
    pending_ = true;
  } else {
    if (pending_) path_.push_back({last_, false});
    path_.push_back({p, false});
    origin_ = o;
    pending_ = false;
  }
}

void CutPathRecorder::loseContact() {
  if (!open_) return;
  if (pending_) path_.push_back({last_, false});
  path_.back().stop = true;
  open_ = pending_ = false;
}

Polyline CutPathRecorder::currentPath() const {
  Polyline out = path_;
  if (open_ && pending_) out.push_back({last_, false});
  return out;
}

}  // namespace ld::curriculum
