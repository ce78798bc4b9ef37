#include "curriculum/metrics/deviation.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace ld::curriculum {
namespace {

double cross(const Eigen::Vector2d& u, const Eigen::Vector2d& v) { return u.x() * v.y() - u.y() * v.x(); }

struct Edge2 {
  Eigen::Vector2d lo, hi;  // lo.x < hi.x
  int sign;                // +1 when the loop runs toward +x
  [[nodiscard]] double yAt(double x) const {
    if (x <= lo.x()) return lo.y();
    if (x >= hi.x()) return hi.y();
    const double t = (x - lo.x()) / (hi.x() - lo.x());
    return lo.y() + t * (hi.y() - lo.y());
  }
};

}  // namespace

void appendLoop(const std::vector<Eigen::Vector2d>& loop, std::vector<Segment2>& segs) {
  const std::size_t n = loop.size();
  for (std::size_t i = 0; i < n; ++i) segs.push_back({loop[i], loop[(i + 1) % n]});
}

double absWindingArea(const std::vector<Eigen::Vector2d>& loop) {
  std::vector<Segment2> segs;
  appendLoop(loop, segs);
  return absWindingArea(segs);
}

double absWindingArea(const std::vector<Segment2>& segs) {
  std::vector<Edge2> edges;
  std::vector<double> xs;
  edges.reserve(segs.size());
  xs.reserve(2 * segs.size());
  for (const Segment2& s : segs) {
    if (!s.a.allFinite() || !s.b.allFinite()) continue;
    // Vertical edges bound no slab interior; their abscissa is an event already
    // (it is an end point of the neighbouring edges).
    xs.push_back(s.a.x());
    xs.push_back(s.b.x());
    if (s.a.x() == s.b.x()) continue;
    if (s.a.x() < s.b.x())
      edges.push_back({s.a, s.b, +1});
    else
      edges.push_back({s.b, s.a, -1});
  }
  if (edges.size() < 2) return 0.0;
  std::sort(edges.begin(), edges.end(), [](const Edge2& e, const Edge2& f) { return e.lo.x() < f.lo.x(); });

  // Crossing abscissae of every pair whose x-ranges overlap.
  for (std::size_t i = 0; i < edges.size(); ++i) {
    const Edge2& e = edges[i];
    const Eigen::Vector2d r = e.hi - e.lo;
    for (std::size_t j = i + 1; j < edges.size() && edges[j].lo.x() <= e.hi.x(); ++j) {
      const Edge2& f = edges[j];
      const Eigen::Vector2d s = f.hi - f.lo;
      const double den = cross(r, s);
      if (den == 0.0) continue;  // parallel: overlaps add no area, their ends are events
      const Eigen::Vector2d q = f.lo - e.lo;
      const double t = cross(q, s) / den, u = cross(q, r) / den;
      if (t <= 0.0 || t >= 1.0 || u <= 0.0 || u >= 1.0) continue;
      double x = e.lo.x() + t * r.x();
      x = std::clamp(x, std::max(e.lo.x(), f.lo.x()), std::min(e.hi.x(), f.hi.x()));
      xs.push_back(x);
    }
  }
  std::sort(xs.begin(), xs.end());
  xs.erase(std::unique(xs.begin(), xs.end()), xs.end());

  struct Slot {
    double ym, y0, y1;
    int sign;
  };
  std::vector<std::size_t> active;
  std::vector<Slot> slots;
  std::size_t next = 0;
  double area = 0.0;
  for (std::size_t k = 0; k + 1 < xs.size(); ++k) {
    const double x0 = xs[k], x1 = xs[k + 1];
    while (next < edges.size() && edges[next].lo.x() <= x0) active.push_back(next++);
    active.erase(std::remove_if(active.begin(), active.end(), [&](std::size_t i) { return edges[i].hi.x() <= x0; }),
                 active.end());
    if (active.size() < 2) continue;
    slots.clear();
    for (std::size_t i : active) {
      const Edge2& e = edges[i];
      const double y0 = e.yAt(x0), y1 = e.yAt(x1);
      slots.push_back({0.5 * (y0 + y1), y0, y1, e.sign});
    }
    std::sort(slots.begin(), slots.end(), [](const Slot& a, const Slot& b) { return a.ym < b.ym; });
    int w = 0;
    double sum = 0.0;
    for (std::size_t i = 0; i + 1 < slots.size(); ++i) {
      w += slots[i].sign;
      if (w != 0) sum += std::abs(w) * ((slots[i + 1].y0 - slots[i].y0) + (slots[i + 1].y1 - slots[i].y1));
    }
    area += 0.5 * sum * (x1 - x0);
  }
  return area;
}

int windingNumber(const std::vector<Eigen::Vector2d>& loop, const Eigen::Vector2d& p) {
  int w = 0;
  const std::size_t n = loop.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d& a = loop[i];
    const Eigen::Vector2d& b = loop[(i + 1) % n];
    if (a.y() <= p.y()) {
      if (b.y() > p.y() && cross(b - a, p - a) > 0) ++w;
    } else if (b.y() <= p.y() && cross(b - a, p - a) < 0) {
      --w;
    }
  }
  return w;
}

std::vector<Eigen::Vector2d> deviationLoop(const Polyline& drawn, const Polyline& cut, Plane plane) {
  std::vector<Eigen::Vector2d> loop;
  loop.reserve(drawn.size() + cut.size());
  for (const PathPoint& q : drawn) loop.push_back(project(q.p, plane));
  for (auto it = cut.rbegin(); it != cut.rend(); ++it) loop.push_back(project(it->p, plane));
  return loop;
}

Deviation deviation(const Polyline& drawn, const Polyline& cut) {
  Deviation d;
  for (Plane p : {Plane::XY, Plane::YZ, Plane::XZ}) d.plane(p) = absWindingArea(deviationLoop(drawn, cut, p));
  return d;
}

Deviation deviationWithoutCut(const Polyline& drawn, double band) {
  Deviation d;
  for (Plane p : {Plane::XY, Plane::YZ, Plane::XZ}) {
    std::vector<Eigen::Vector2d> loop;
    for (const PathPoint& q : drawn) loop.push_back(project(q.p, p));
    double len = 0.0;
    for (std::size_t i = 1; i < drawn.size(); ++i)
      if (!drawn[i - 1].stop) len += (project(drawn[i].p, p) - project(drawn[i - 1].p, p)).norm();
    d.plane(p) = absWindingArea(loop) + 2.0 * band * len;
  }
  return d;
}

namespace {

double triArea(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  return 0.5 * std::abs(cross(b - a, c - a));
}

// Proper crossing of [a,b] and [c,d] (not at their ends).
bool crossing(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c, const Eigen::Vector2d& d,
              Eigen::Vector2d& at) {
  const Eigen::Vector2d r = b - a, s = d - c;
  const double den = cross(r, s);
  if (std::abs(den) <= 1e-300) return false;
  const double t = cross(c - a, s) / den, u = cross(c - a, r) / den;
  constexpr double eps = 1e-12;
  if (t <= eps || t >= 1 - eps || u <= eps || u >= 1 - eps) return false;
  at = a + t * r;
  return true;
}

}  // namespace

double deviationThesis2d(const std::vector<Eigen::Vector2d>& d, const std::vector<Eigen::Vector2d>& a) {
  if (d.empty() || a.empty()) return 0.0;
  std::size_t i = 0, j = 0;  // indices of the current points' successors - 1
  Eigen::Vector2d cd = d[0], ca = a[0];
  double area = 0.0;
  while (i + 1 < d.size() || j + 1 < a.size()) {
    Eigen::Vector2d x;
    if (i + 1 < d.size() && j + 1 < a.size() && crossing(cd, d[i + 1], ca, a[j + 1], x)) {
      area += triArea(cd, ca, x);
      cd = x;
      ca = x;
      continue;
    }
    bool advanceA;
    if (i + 1 >= d.size())
      advanceA = true;
    else if (j + 1 >= a.size())
      advanceA = false;
    else
      advanceA = (a[j + 1] - cd).squaredNorm() < (d[i + 1] - ca).squaredNorm();
    if (advanceA) {
      area += triArea(cd, ca, a[j + 1]);
      ca = a[++j];
    } else {
      area += triArea(cd, ca, d[i + 1]);
      cd = d[++i];
    }
  }
  return area;
}

Deviation deviationThesis(const Polyline& drawn, const Polyline& cut) {
  Deviation out;
  for (Plane p : {Plane::XY, Plane::YZ, Plane::XZ}) {
    std::vector<Eigen::Vector2d> d, a;
    for (const auto& q : drawn) d.push_back(project(q.p, p));
    for (const auto& q : cut) a.push_back(project(q.p, p));
    out.plane(p) = deviationThesis2d(d, a);
  }
  return out;
}

}  // namespace ld::curriculum
