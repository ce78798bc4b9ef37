// Polygon triangulation that keeps manifold input manifold: a diagonal that already
// is an edge of the mesh would give that edge extra faces, so ears are chosen whose
// new diagonal does not exist yet (see the teapot note in shared/data/SOURCES.md).
#include <algorithm>
#include <cmath>
#include <span>
#include <string>
#include <unordered_set>

#include "sim/io/mesh_formats.h"

namespace ld::io {
namespace {

std::uint64_t edgeKey(std::uint32_t a, std::uint32_t b) {
  if (a > b) std::swap(a, b);
  return (static_cast<std::uint64_t>(a) << 32) | b;
}

// The file's edges (sorted once) plus the diagonals added so far.
class EdgeSet {
 public:
  explicit EdgeSet(std::vector<std::uint64_t> fileEdges) : file_(std::move(fileEdges)) {
    std::sort(file_.begin(), file_.end());
    file_.erase(std::unique(file_.begin(), file_.end()), file_.end());
  }
  [[nodiscard]] bool contains(std::uint64_t k) const {
    return std::binary_search(file_.begin(), file_.end(), k) || added_.count(k) > 0;
  }
  void insert(std::uint64_t k) { added_.insert(k); }

 private:
  std::vector<std::uint64_t> file_;
  std::unordered_set<std::uint64_t> added_;
};

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
  Triangulator(const std::vector<Eigen::Vector3d>& pts, EdgeSet& edges, std::vector<Triangle>& out)
      : pts_(pts), edges_(edges), out_(out) {}

  void run(std::span<const std::uint32_t> poly) {
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
    if (n == 4 && nrm.norm() > 0) {
      quad(poly, nrm);
      return;
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
        const bool fresh = poly[a] != poly[c] && !edges_.contains(edgeKey(poly[a], poly[c]));
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

  // The common case without allocations: diagonal 0-2 or 1-3, preferring one that is
  // new, then one whose triangles both face along the quad's normal, then shape.
  void quad(std::span<const std::uint32_t> q, const Eigen::Vector3d& nrm) {
    auto option = [&](std::size_t s, double& score) {
      const std::uint32_t a = q[s], b = q[(s + 1) % 4], c = q[(s + 2) % 4], d = q[(s + 3) % 4];
      const auto& pa = pts_[a];
      const auto& pb = pts_[b];
      const auto& pc = pts_[c];
      const auto& pd = pts_[d];
      const bool fresh = !edges_.contains(edgeKey(a, c));
      const bool valid = (pb - pa).cross(pc - pa).dot(nrm) > 0 && (pc - pa).cross(pd - pa).dot(nrm) > 0;
      score = (fresh ? 4.0 : 0.0) + (valid ? 2.0 : 0.0) + std::min(quality(pa, pb, pc), quality(pa, pc, pd));
    };
    double s0 = 0, s1 = 0;
    option(0, s0);
    option(1, s1);
    const std::size_t s = s1 > s0 ? 1 : 0;
    const std::uint32_t a = q[s], b = q[(s + 1) % 4], c = q[(s + 2) % 4], d = q[(s + 3) % 4];
    out_.push_back({a, b, c});
    out_.push_back({a, c, d});
    edges_.insert(edgeKey(a, c));
  }

  // Fan from the first corner whose diagonals are all new (corner 0 if none is).
  void fan(std::span<const std::uint32_t> poly) {
    const std::size_t n = poly.size();
    std::size_t s = 0;
    for (std::size_t cand = 0; cand < n; ++cand) {
      bool ok = true;
      for (std::size_t j = 2; j + 1 < n && ok; ++j) ok = !edges_.contains(edgeKey(poly[cand], poly[(cand + j) % n]));
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
  EdgeSet& edges_;
  std::vector<Triangle>& out_;
};

}  // namespace

TriangleSoup triangulate(const RawMesh& raw, ImportReport* report) {
  TriangleSoup soup;
  soup.points = raw.points;
  soup.source = raw.source;
  const std::size_t np = raw.polygonCount();
  // Corners with consecutive repeats removed (they carry no area and no edge), flat.
  std::vector<std::uint32_t> flat;
  std::vector<std::size_t> begin{0};
  flat.reserve(raw.indices.size());
  begin.reserve(np + 1);
  std::size_t dropped = 0, big = 0;
  long firstDroppedLine = 0;
  for (std::size_t i = 0; i < np; ++i) {
    const std::size_t b0 = flat.size();
    for (std::uint32_t k = raw.start[i]; k < raw.start[i + 1]; ++k)
      if (flat.size() == b0 || flat.back() != raw.indices[k]) flat.push_back(raw.indices[k]);
    while (flat.size() - b0 > 1 && flat[b0] == flat.back()) flat.pop_back();
    if (flat.size() - b0 < 3) {
      if (dropped++ == 0) firstDroppedLine = raw.line[i];
      flat.resize(b0);
    } else if (flat.size() - b0 > 3) {
      ++big;
    }
    begin.push_back(flat.size());
  }
  // Only needed when some polygon has more than three corners.
  std::vector<std::uint64_t> fileEdges;
  if (big > 0) {
    fileEdges.reserve(flat.size());
    for (std::size_t i = 0; i + 1 < begin.size(); ++i)
      for (std::size_t k = begin[i]; k < begin[i + 1]; ++k)
        fileEdges.push_back(edgeKey(flat[k], flat[k + 1 < begin[i + 1] ? k + 1 : begin[i]]));
  }
  EdgeSet edges(std::move(fileEdges));
  soup.triangles.reserve(flat.size());
  Triangulator tr(soup.points, edges, soup.triangles);
  for (std::size_t i = 0; i + 1 < begin.size(); ++i)
    if (begin[i + 1] > begin[i])
      tr.run(std::span<const std::uint32_t>(flat.data() + begin[i], begin[i + 1] - begin[i]));
  if (report) {
    report->droppedPolygons += dropped;
    if (dropped > 0)
      report->warnings.push_back(raw.source + ":" + std::to_string(firstDroppedLine) + ": " + std::to_string(dropped) +
                                 " polygon(s) with fewer than three distinct corners dropped (first here)");
  }
  return soup;
}

}  // namespace ld::io
