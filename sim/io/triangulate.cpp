// Polygon triangulation that keeps manifold input manifold: a diagonal that already
// is an edge of the mesh would give that edge extra faces, so ears are chosen whose
// new diagonal does not exist yet (see the teapot note in shared/data/SOURCES.md).
#include <algorithm>
#include <cmath>
#include <string>
#include <unordered_set>

#include "sim/io/mesh_formats.h"

namespace ld::io {
namespace {

std::uint64_t edgeKey(std::uint32_t a, std::uint32_t b) {
  if (a > b) std::swap(a, b);
  return (static_cast<std::uint64_t>(a) << 32) | b;
}

constexpr std::size_t kMaxEarClip = 256;  // larger polygons are fanned (cost is cubic)

double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  return (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
}

// Shape quality of a triangle in (0, 1]; 0 for a degenerate one.
double quality(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const double l = (b - a).squaredNorm() + (c - b).squaredNorm() + (a - c).squaredNorm();
  if (!(l > 0)) return 0.0;
  return 2.0 * std::sqrt(3.0) * (b - a).cross(c - a).norm() / l;
}

class Triangulator {
 public:
  Triangulator(const std::vector<Eigen::Vector3d>& pts, std::unordered_set<std::uint64_t>& edges,
               std::vector<Triangle>& out)
      : pts_(pts), edges_(edges), out_(out) {}

  void run(const std::vector<std::uint32_t>& poly) {
    const std::size_t n = poly.size();
    if (n == 3) {
      out_.push_back({poly[0], poly[1], poly[2]});
      return;
    }
    // Newell normal and a projection that keeps the polygon counter-clockwise.
    Eigen::Vector3d nrm = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < n; ++i) {
      const auto& a = pts_[poly[i]];
      const auto& b = pts_[poly[(i + 1) % n]];
      nrm += Eigen::Vector3d((a.y() - b.y()) * (a.z() + b.z()), (a.z() - b.z()) * (a.x() + b.x()),
                             (a.x() - b.x()) * (a.y() + b.y()));
    }
    if (n > kMaxEarClip || !(nrm.norm() > 0)) {
      fan(poly);
      return;
    }
    int k = 0;
    nrm.cwiseAbs().maxCoeff(&k);
    const int u = (k + 1) % 3, v = (k + 2) % 3;
    std::vector<Eigen::Vector2d> p2(n);
    for (std::size_t i = 0; i < n; ++i) {
      const auto& p = pts_[poly[i]];
      p2[i] = nrm[k] >= 0 ? Eigen::Vector2d(p[u], p[v]) : Eigen::Vector2d(p[v], p[u]);
    }
    std::vector<std::size_t> ring(n);
    for (std::size_t i = 0; i < n; ++i) ring[i] = i;
    while (ring.size() > 3) {
      const std::size_t m = ring.size();
      // Best ear: a new diagonal first, then a convex corner with nothing inside,
      // then the best-shaped triangle.
      int bestScore = -1;
      double bestQ = -1;
      std::size_t best = 0;
      for (std::size_t i = 0; i < m; ++i) {
        const std::size_t a = ring[(i + m - 1) % m], b = ring[i], c = ring[(i + 1) % m];
        const bool fresh = poly[a] != poly[c] && !edges_.count(edgeKey(poly[a], poly[c]));
        const bool ear = isEar(p2, ring, a, b, c);
        const int score = (fresh ? 2 : 0) + (ear ? 1 : 0);
        const double q = quality(pts_[poly[a]], pts_[poly[b]], pts_[poly[c]]);
        if (score > bestScore || (score == bestScore && q > bestQ)) {
          bestScore = score;
          bestQ = q;
          best = i;
        }
      }
      const std::size_t a = ring[(best + m - 1) % m], b = ring[best], c = ring[(best + 1) % m];
      out_.push_back({poly[a], poly[b], poly[c]});
      edges_.insert(edgeKey(poly[a], poly[c]));
      ring.erase(ring.begin() + static_cast<std::ptrdiff_t>(best));
    }
    out_.push_back({poly[ring[0]], poly[ring[1]], poly[ring[2]]});
  }

 private:
  static bool isEar(const std::vector<Eigen::Vector2d>& p2, const std::vector<std::size_t>& ring, std::size_t a,
                    std::size_t b, std::size_t c) {
    if (!(cross2(p2[a], p2[b], p2[c]) > 0)) return false;
    for (std::size_t j : ring) {
      if (j == a || j == b || j == c) continue;
      const auto& q = p2[j];
      if (q == p2[a] || q == p2[b] || q == p2[c]) continue;
      if (cross2(p2[a], p2[b], q) >= 0 && cross2(p2[b], p2[c], q) >= 0 && cross2(p2[c], p2[a], q) >= 0) return false;
    }
    return true;
  }

  // Fan from the first corner whose diagonals are all new (corner 0 if none is).
  void fan(const std::vector<std::uint32_t>& poly) {
    const std::size_t n = poly.size();
    std::size_t s = 0;
    for (std::size_t cand = 0; cand < n; ++cand) {
      bool ok = true;
      for (std::size_t j = 2; j + 1 < n && ok; ++j) ok = !edges_.count(edgeKey(poly[cand], poly[(cand + j) % n]));
      if (ok) {
        s = cand;
        break;
      }
    }
    for (std::size_t j = 1; j + 1 < n; ++j) {
      const std::uint32_t a = poly[s], b = poly[(s + j) % n], c = poly[(s + j + 1) % n];
      out_.push_back({a, b, c});
      if (j + 2 < n) edges_.insert(edgeKey(a, c));
    }
  }

  const std::vector<Eigen::Vector3d>& pts_;
  std::unordered_set<std::uint64_t>& edges_;
  std::vector<Triangle>& out_;
};

}  // namespace

TriangleSoup triangulate(const RawMesh& raw, ImportReport* report) {
  TriangleSoup soup;
  soup.points = raw.points;
  soup.source = raw.source;
  const std::size_t np = raw.polygonCount();
  // Corners with consecutive repeats removed (they carry no area and no edge).
  std::vector<std::vector<std::uint32_t>> polys(np);
  std::unordered_set<std::uint64_t> edges;
  std::size_t dropped = 0;
  long firstDroppedLine = 0;
  for (std::size_t i = 0; i < np; ++i) {
    auto& p = polys[i];
    for (std::uint32_t k = raw.start[i]; k < raw.start[i + 1]; ++k)
      if (p.empty() || p.back() != raw.indices[k]) p.push_back(raw.indices[k]);
    while (p.size() > 1 && p.front() == p.back()) p.pop_back();
    if (p.size() < 3) {
      if (dropped++ == 0) firstDroppedLine = raw.line[i];
      p.clear();
      continue;
    }
    for (std::size_t k = 0; k < p.size(); ++k) edges.insert(edgeKey(p[k], p[(k + 1) % p.size()]));
  }
  soup.triangles.reserve(raw.indices.size() / 3 + np);
  Triangulator tr(soup.points, edges, soup.triangles);
  for (const auto& p : polys)
    if (!p.empty()) tr.run(p);
  if (report) {
    report->droppedPolygons += dropped;
    if (dropped > 0)
      report->warnings.push_back(raw.source + ":" + std::to_string(firstDroppedLine) + ": " + std::to_string(dropped) +
                                 " polygon(s) with fewer than three distinct corners dropped (first here)");
  }
  return soup;
}

}  // namespace ld::io
