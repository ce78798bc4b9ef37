#include "curriculum/metrics/live.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace ld::curriculum {
namespace {

constexpr std::size_t kWindow = 32;  // drawn segments searched either way for the progress point

std::int64_t key(std::int64_t cx, std::int64_t cy) {
  return static_cast<std::int64_t>((static_cast<std::uint64_t>(cx + (1LL << 31)) << 32) ^
                                   static_cast<std::uint64_t>(cy + (1LL << 31)));
}

// Mean of max(u, 0) for u running linearly from u0 to u1.
double meanPositive(double u0, double u1) {
  if (u0 >= 0.0 && u1 >= 0.0) return 0.5 * (u0 + u1);
  if (u0 <= 0.0 && u1 <= 0.0) return 0.0;
  const double m = std::max(u0, u1);
  return m * m / (2.0 * std::abs(u1 - u0));
}

}  // namespace

LiveDeviation::LiveDeviation(const Polyline& drawn, double cellMm, std::size_t maxCells, std::size_t maxPieces)
    : d_(joinedPoints(drawn)), h_(cellMm > 0.0 ? cellMm : kCellMm), maxCells_(maxCells), maxPieces_(maxPieces) {
  // Room for a long attempt's cells up front: a rehash in the middle of it would cost
  // one cut point time proportional to the attempt so far.
  for (PlaneGrid& g : planes_) g.cells.reserve(1u << 15);
}

Eigen::Vector3d LiveDeviation::drawnPoint(std::size_t seg, double u) const {
  if (d_.size() < 2) return d_.empty() ? Eigen::Vector3d::Zero() : d_[0];
  return d_[seg] + u * (d_[seg + 1] - d_[seg]);
}

Eigen::Vector3d LiveDeviation::closestNear(const Eigen::Vector3d& p, std::size_t& seg, double& u) const {
  if (d_.size() < 2) {
    seg = 0;
    u = 0.0;
    return drawnPoint(0, 0.0);
  }
  double best = std::numeric_limits<double>::infinity();
  std::size_t bestSeg = seg;
  double bestU = u;
  const std::size_t last = std::min(d_.size() - 2, seg + kWindow), first = seg > kWindow ? seg - kWindow : 0;
  for (std::size_t i = first; i <= last; ++i) {
    const Eigen::Vector3d a = d_[i], ab = d_[i + 1] - d_[i];
    const double l2 = ab.squaredNorm();
    const double t = l2 > 0.0 ? std::clamp((p - a).dot(ab) / l2, 0.0, 1.0) : 0.0;
    const double dist = (a + t * ab - p).squaredNorm();
    if (dist < best) {
      best = dist;
      bestSeg = i;
      bestU = t;
    }
  }
  seg = bestSeg;
  u = bestU;
  return drawnPoint(seg, u);
}

void LiveDeviation::addCutPoint(const Eigen::Vector3d& p) {
  if (d_.empty() || finished_) return;
  std::vector<Eigen::Vector3d> poly;
  if (!started_) {
    started_ = true;
    seg_ = 0;
    u_ = 0.0;
    p_ = closestNear(p, seg_, u_);
    for (std::size_t i = 0; i <= seg_ && i < d_.size(); ++i) poly.push_back(d_[i]);
    poly.push_back(p_);
    poly.push_back(p);
  } else {
    std::size_t seg = seg_;
    double u = u_;
    const Eigen::Vector3d pNew = closestNear(p, seg, u);
    // The drawn path from the old progress point to the new one, forward or back.
    poly.push_back(p_);
    if (seg >= seg_)
      for (std::size_t i = seg_ + 1; i <= seg; ++i) poly.push_back(d_[i]);
    else
      for (std::size_t i = seg_; i > seg; --i) poly.push_back(d_[i]);
    poly.push_back(pNew);
    poly.push_back(p);
    poly.push_back(lastCut_);
    seg_ = seg;
    u_ = u;
    p_ = pNew;
  }
  lastCut_ = p;
  addPolygon(poly);
}

void LiveDeviation::finish() {
  if (!started_ || finished_) return;
  finished_ = true;
  std::vector<Eigen::Vector3d> poly{p_};
  for (std::size_t i = seg_ + 1; i < d_.size(); ++i) poly.push_back(d_[i]);
  poly.push_back(lastCut_);
  addPolygon(poly);
}

void LiveDeviation::addPolygon(const std::vector<Eigen::Vector3d>& poly) {
  for (Plane pl : {Plane::XY, Plane::YZ, Plane::XZ}) {
    std::vector<Eigen::Vector2d> loop;
    loop.reserve(poly.size());
    for (const auto& q : poly) loop.push_back(project(q, pl));
    value_.plane(pl) += addToPlane(planes_[static_cast<int>(pl)], loop);
  }
}

double LiveDeviation::addToPlane(PlaneGrid& g, const std::vector<Eigen::Vector2d>& loop) {
  const std::size_t n = loop.size();
  if (n < 3) return 0.0;
  Eigen::Vector2d lo = loop[0], hi = loop[0];
  for (const auto& q : loop) {
    if (!q.allFinite()) return 0.0;
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  }
  const auto cell = [&](double v) { return static_cast<std::int64_t>(std::floor(v / h_)); };
  const std::int64_t i0 = cell(lo.x()), i1 = cell(hi.x()), j0 = cell(lo.y()), j1 = cell(hi.y());
  const std::int64_t nc = i1 - i0 + 1, nr = j1 - j0 + 1;
  if (static_cast<double>(nc) * static_cast<double>(nr) > static_cast<double>(maxCells_)) {
    // Too large for the grid: its |signed area| (exact when Q is simple and alone).
    exact_ = false;
    double a2 = 0.0;
    for (std::size_t k = 0; k < n; ++k) {
      const auto& p = loop[k];
      const auto& q = loop[(k + 1) % n];
      a2 += p.x() * q.y() - q.x() * p.y();
    }
    return 0.5 * std::abs(a2);
  }
  // Signed integral of w over cell (i, j) = -sum over edges of the integral, along x,
  // of clamp(y - y_j, 0, h): the area of the polygon within the row y_j..y_j+h, by
  // the trapezoid rule made exact for straight edges. Rows below the polygon receive
  // h * dx from every edge, which cancels over the closed loop: only the bounding
  // box's rows are visited.
  std::vector<double>& acc = g.scratch;
  acc.assign(static_cast<std::size_t>(nc * nr), 0.0);
  for (std::size_t k = 0; k < n; ++k) {
    const Eigen::Vector2d& p = loop[k];
    const Eigen::Vector2d& q = loop[(k + 1) % n];
    if (p.x() == q.x()) continue;
    const double xl = std::min(p.x(), q.x()), xr = std::max(p.x(), q.x());
    const double sign = q.x() > p.x() ? 1.0 : -1.0;
    const double slope = (q.y() - p.y()) / (q.x() - p.x());
    const auto yAt = [&](double x) { return p.y() + slope * (x - p.x()); };
    for (std::int64_t i = cell(xl); i <= cell(xr) && i <= i1; ++i) {
      const double xa = std::max(xl, static_cast<double>(i) * h_), xb = std::min(xr, static_cast<double>(i + 1) * h_);
      if (!(xb > xa)) continue;
      const double dx = sign * (xb - xa);
      const double ya = yAt(xa), yb = yAt(xb);
      const double ymin = std::min(ya, yb), ymax = std::max(ya, yb);
      double* col = &acc[static_cast<std::size_t>((i - i0) * nr)];
      for (std::int64_t j = j0; j <= j1; ++j) {
        const double yj = static_cast<double>(j) * h_;
        if (yj >= ymax) break;  // rows above the edge piece get nothing
        const double f =
            yj + h_ <= ymin ? h_ : meanPositive(ya - yj, yb - yj) - meanPositive(ya - yj - h_, yb - yj - h_);
        col[j - j0] -= dx * f;
      }
    }
  }
  ++update_;
  g.dirty.clear();
  for (std::int64_t i = 0; i < nc; ++i)
    for (std::int64_t j = 0; j < nr; ++j) {
      const double dv = acc[static_cast<std::size_t>(i * nr + j)];
      if (dv == 0.0) continue;
      g.cells[key(i0 + i, j0 + j)].integral += dv;
      g.dirty.emplace_back(i0 + i, j0 + j);
    }
  // Q's edges, clipped to the cells they pass through, join those cells' pieces
  // (a refined cell takes Q's edges into its sub-cells below instead).
  g.clipped.clear();
  for (std::size_t k = 0; k < n; ++k) clipEdge(loop[k], loop[(k + 1) % n], g);
  for (const auto& c : g.clipped) {
    Cell& into = g.cells[key(c.i, c.j)];
    g.dirty.emplace_back(c.i, c.j);
    if (!into.sub.empty()) continue;
    auto& pieces = into.pieces;
    auto it = std::find_if(pieces.begin(), pieces.end(),
                           [&](const Piece& x) { return x.a == c.piece.a && x.b == c.piece.b; });
    if (it == pieces.end()) {
      pieces.push_back(c.piece);
    } else if ((it->count += c.piece.count) == 0) {
      *it = pieces.back();  // a piece and its reverse cancel
      pieces.pop_back();
    }
    into.histOk = false;
  }
  std::sort(g.dirty.begin(), g.dirty.end());
  g.dirty.erase(std::unique(g.dirty.begin(), g.dirty.end()), g.dirty.end());
  double change = 0.0;
  for (const auto& [i, j] : g.dirty) {
    Cell& c = g.cells[key(i, j)];
    if (c.sub.empty() && c.pieces.size() > maxPieces_) refine(c, i, j);  // already holds Q
    double a = 0.0;
    if (!c.sub.empty()) {
      if (c.refinedAt != update_)
        for (std::size_t k = 0; k < n; ++k) rasterAdd({loop[k], loop[(k + 1) % n], 1}, i, j, c.sub);
      for (double v : c.sub) a += std::abs(v);
    } else {
      a = c.pieces.empty() ? std::abs(c.integral) : cellAbs(c, i, j);
    }
    change += a - c.abs;
    c.abs = a;
  }
  return change;
}

void LiveDeviation::refine(Cell& c, std::int64_t i, std::int64_t j) {
  std::vector<WSeg> segs;
  std::vector<char> inside;
  const double base = std::round((c.integral - 0.5 * closePieces(c, i, j, segs, inside)) / (h_ * h_));
  const double hs = h_ / kSub;
  c.sub.assign(static_cast<std::size_t>(kSub * kSub), base * hs * hs);
  for (const WSeg& s : segs) rasterAdd(s, i, j, c.sub);
  c.pieces.clear();
  c.pieces.shrink_to_fit();
  c.hist.clear();
  c.hist.shrink_to_fit();
  c.refinedAt = update_;
  ++refined_;
  exact_ = false;
}

void LiveDeviation::rasterAdd(const WSeg& s, std::int64_t i, std::int64_t j, std::vector<double>& sub) const {
  // The cells' formula on the sub-grid: sub-cell (c, r) gets -sum over edges of the
  // integral along x of clamp(y - y_r, 0, hs); edges below the cell give nothing.
  const Eigen::Vector2d& p = s.a;
  const Eigen::Vector2d& q = s.b;
  if (p.x() == q.x() || s.w == 0) return;
  const double xa = static_cast<double>(i) * h_, xb = static_cast<double>(i + 1) * h_;
  const double ya = static_cast<double>(j) * h_, hs = h_ / kSub;
  const double xl = std::max(std::min(p.x(), q.x()), xa), xr = std::min(std::max(p.x(), q.x()), xb);
  if (!(xr > xl)) return;
  const double slope = (q.y() - p.y()) / (q.x() - p.x());
  const auto yAt = [&](double x) { return p.y() + slope * (x - p.x()); };
  if (std::max(yAt(xl), yAt(xr)) <= ya) return;
  const double sign = (q.x() > p.x() ? 1.0 : -1.0) * s.w;
  const auto col = [&](double x) { return std::clamp(static_cast<int>(std::floor((x - xa) / hs)), 0, kSub - 1); };
  for (int c = col(xl); c <= col(xr); ++c) {
    const double xA = std::max(xl, xa + c * hs), xB = std::min(xr, c + 1 == kSub ? xb : xa + (c + 1) * hs);
    if (!(xB > xA)) continue;
    const double dx = sign * (xB - xA);
    const double y0 = yAt(xA), y1 = yAt(xB);
    const double ymin = std::min(y0, y1), ymax = std::max(y0, y1);
    double* column = &sub[static_cast<std::size_t>(c * kSub)];
    for (int r = 0; r < kSub; ++r) {
      const double yr = ya + r * hs;
      if (yr >= ymax) break;
      const double f = yr + hs <= ymin ? hs : meanPositive(y0 - yr, y1 - yr) - meanPositive(y0 - yr - hs, y1 - yr - hs);
      column[r] -= dx * f;
    }
  }
}

void LiveDeviation::clipEdge(const Eigen::Vector2d& p, const Eigen::Vector2d& q, PlaneGrid& g) const {
  if (p == q) return;
  // Canonical order, so that an edge and its reverse clip to bit-identical pieces.
  const bool forward = p.x() < q.x() || (p.x() == q.x() && p.y() < q.y());
  const Eigen::Vector2d a = forward ? p : q, b = forward ? q : p;
  const int count = forward ? 1 : -1;
  const auto cell = [&](double v) { return static_cast<std::int64_t>(std::floor(v / h_)); };
  const auto atX = [&](double x) {
    return Eigen::Vector2d(x, a.y() + (b.y() - a.y()) * ((x - a.x()) / (b.x() - a.x())));
  };
  const auto atY = [&](double y) {
    return Eigen::Vector2d(a.x() + (b.x() - a.x()) * ((y - a.y()) / (b.y() - a.y())), y);
  };
  for (std::int64_t i = cell(a.x()); i <= cell(b.x()); ++i) {
    const double xl = static_cast<double>(i) * h_, xr = static_cast<double>(i + 1) * h_;
    const Eigen::Vector2d s0 = a.x() < xl ? atX(xl) : a, s1 = b.x() > xr ? atX(xr) : b;
    if (a.x() != b.x() && !(s1.x() > s0.x())) continue;  // touches the column at a point
    const double ylo = std::min(s0.y(), s1.y()), yhi = std::max(s0.y(), s1.y());
    for (std::int64_t j = cell(ylo); j <= cell(yhi); ++j) {
      const double yb = static_cast<double>(j) * h_, yt = static_cast<double>(j + 1) * h_;
      const auto clampY = [&](const Eigen::Vector2d& s) { return s.y() < yb ? atY(yb) : s.y() > yt ? atY(yt) : s; };
      const Eigen::Vector2d c0 = clampY(s0), c1 = clampY(s1);
      if (c0 == c1) continue;
      // A piece on the cell's border changes w inside by a constant only (the
      // integral fixes it): left out.
      if ((c0.x() == xl && c1.x() == xl) || (c0.x() == xr && c1.x() == xr) || (c0.y() == yb && c1.y() == yb) ||
          (c0.y() == yt && c1.y() == yt))
        continue;
      g.clipped.push_back({i, j, {c0, c1, count}});
    }
  }
}

double LiveDeviation::closePieces(const Cell& c, std::int64_t i, std::int64_t j, std::vector<WSeg>& segs,
                                  std::vector<char>& inside) const {
  // The pieces, closed along the cell's border: every end on the border runs back
  // along it to the corner (xa, ya). Inside the cell w then is this closed set's
  // winding number plus a whole number B, which the cell's integral gives.
  const double xa = static_cast<double>(i) * h_, xb = xa + h_, ya = static_cast<double>(j) * h_, yb = ya + h_;
  const Eigen::Vector2d corner[4] = {{xa, ya}, {xb, ya}, {xb, yb}, {xa, yb}};
  segs.clear();
  inside.clear();
  segs.reserve(c.pieces.size() * 4);
  const auto onBorder = [&](const Eigen::Vector2d& p) {
    return p.y() == ya || p.x() == xb || p.y() == yb || p.x() == xa;
  };
  const auto toCorner = [&](const Eigen::Vector2d& p, int w) {
    // Counter-clockwise border parameter from corner 0, then back down to 0.
    const double s = p.y() == ya   ? p.x() - xa
                     : p.x() == xb ? h_ + (p.y() - ya)
                     : p.y() == yb ? 2 * h_ + (xb - p.x())
                                   : 3 * h_ + (yb - p.y());
    Eigen::Vector2d cur = p;
    for (int k = 3; k >= 1; --k)
      if (s > k * h_) {
        segs.push_back({cur, corner[k], w});
        cur = corner[k];
      }
    segs.push_back({cur, corner[0], w});
  };
  for (const Piece& pc : c.pieces) {
    segs.push_back({pc.a, pc.b, pc.count});
    inside.resize(segs.size(), 1);  // segs[i] is a piece (not a closing run along the border)
    if (onBorder(pc.b)) toCorner(pc.b, pc.count);
    if (onBorder(pc.a)) toCorner(pc.a, -pc.count);
    inside.resize(segs.size(), 0);
  }
  // ∫ w of the closed set (shoelace about the corner), then B.
  double twice = 0.0;
  for (const WSeg& s : segs) {
    const Eigen::Vector2d u = s.a - corner[0], v = s.b - corner[0];
    twice += s.w * (u.x() * v.y() - u.y() * v.x());
  }
  return twice;
}

double LiveDeviation::cellAbs(Cell& c, std::int64_t i, std::int64_t j) const {
  if (!c.histOk) buildHistogram(c, i, j);
  // ∫|w| = sum over the levels of the closed set of area x |level + B|.
  const double base = std::round((c.integral - 0.5 * c.twice) / (h_ * h_));
  double a = 0.0;
  for (const auto& [w, area] : c.hist) a += area * std::abs(w + base);
  return a;
}

void LiveDeviation::buildHistogram(Cell& c, std::int64_t i, std::int64_t j) const {
  // The area of each level of the closed set's winding number inside the cell (only
  // the pieces move it; a change of the integral alone moves B, not the levels).
  const double xa = static_cast<double>(i) * h_, xb = xa + h_, ya = static_cast<double>(j) * h_, yb = ya + h_;
  thread_local std::vector<WSeg> segs;
  thread_local std::vector<char> inside;
  c.twice = closePieces(c, i, j, segs, inside);
  c.hist.clear();
  const auto addLevel = [&](int w, double area) {
    if (!(area > 0.0)) return;
    for (auto& [lw, la] : c.hist)
      if (lw == w) {
        la += area;
        return;
      }
    c.hist.emplace_back(w, area);
  };
  // Slab sweep (as absWindingArea): between neighbouring edges w is constant.
  thread_local std::vector<double> xs;
  xs.assign({xa, xb});
  for (const WSeg& s : segs) {
    xs.push_back(std::clamp(s.a.x(), xa, xb));
    xs.push_back(std::clamp(s.b.x(), xa, xb));
  }
  // Crossings: only the pieces can cross (the closing runs lie on the border).
  for (std::size_t m = 0; m < segs.size(); ++m)
    for (std::size_t k = m + 1; k < segs.size(); ++k) {
      if (!inside[m] || !inside[k]) continue;
      const Eigen::Vector2d r = segs[m].b - segs[m].a, t = segs[k].b - segs[k].a;
      const double den = r.x() * t.y() - r.y() * t.x();
      if (den == 0.0) continue;
      const Eigen::Vector2d d = segs[k].a - segs[m].a;
      const double u = (d.x() * t.y() - d.y() * t.x()) / den, v = (d.x() * r.y() - d.y() * r.x()) / den;
      if (u <= 0.0 || u >= 1.0 || v <= 0.0 || v >= 1.0) continue;
      xs.push_back(std::clamp(segs[m].a.x() + u * r.x(), xa, xb));
    }
  std::sort(xs.begin(), xs.end());
  xs.erase(std::unique(xs.begin(), xs.end()), xs.end());
  struct Slot {
    double ym, y0, y1;
    int w;
  };
  thread_local std::vector<Slot> slots;
  for (std::size_t k = 0; k + 1 < xs.size(); ++k) {
    const double x0 = xs[k], x1 = xs[k + 1];
    if (!(x1 > x0)) continue;
    slots.clear();
    for (const WSeg& s : segs) {
      if (s.a.x() == s.b.x()) continue;
      const bool right = s.a.x() < s.b.x();
      const Eigen::Vector2d& lo = right ? s.a : s.b;
      const Eigen::Vector2d& hi = right ? s.b : s.a;
      if (lo.x() > x0 || hi.x() < x1) continue;
      const auto yAt = [&](double x) { return lo.y() + (hi.y() - lo.y()) * ((x - lo.x()) / (hi.x() - lo.x())); };
      const double y0 = yAt(x0), y1 = yAt(x1);
      slots.push_back({0.5 * (y0 + y1), y0, y1, right ? s.w : -s.w});
    }
    std::sort(slots.begin(), slots.end(), [](const Slot& p, const Slot& q) { return p.ym < q.ym; });
    int w = 0;
    double y0 = ya, y1 = ya;
    for (const Slot& s : slots) {
      addLevel(w, 0.5 * ((s.y0 - y0) + (s.y1 - y1)) * (x1 - x0));
      w += s.w;
      y0 = s.y0;
      y1 = s.y1;
    }
    addLevel(w, 0.5 * ((yb - y0) + (yb - y1)) * (x1 - x0));
  }
}

// ---------------------------------------------------------------------------

LiveMetrics::LiveMetrics(Polyline drawn, const MetricSettings& settings, double seriesInterval)
    : drawn_(std::move(drawn)), s_(settings), interval_(seriesInterval), dev_(drawn_), dwell_(settings.contactRadius) {
  const std::size_t n = drawn_.size() > 1 ? drawn_.size() - 1 : 0;
  coverage_.resize(n);
  coveredLen_.assign(n, 0.0);
  drawnLength_ = piecesLength(drawn_);
  lastTip_[0] = lastTip_[1] = Eigen::Vector3d::Zero();
}

void LiveMetrics::start(double t) {
  started_ = true;
  t0_ = tNow_ = t;
}

void LiveMetrics::touch(double t) {
  if (!started_) start(t);
  tNow_ = std::max(tNow_, t);
  if (tNow_ - lastSeries_ >= interval_) {
    series_.push_back({tNow_, current()});
    lastSeries_ = tNow_;
  }
}

void LiveMetrics::addTip(const TipSample& s) {
  const int h = static_cast<int>(s.hand);
  if (haveTip_[h]) len_[h] += (s.tip - lastTip_[h]).norm();
  lastTip_[h] = s.tip;
  haveTip_[h] = true;
  touch(s.t);
}

void LiveMetrics::addContact(const ContactSample& s) {
  dwell_.add(s);
  touch(s.t);
}

void LiveMetrics::addGrasp(const ForceSample& s) {
  if (s.grasping) fMax_ = std::max(fMax_, s.force);
  if (haveForce_ && s.grasping && lastForce_.grasping) {
    const double dt = s.t - lastForce_.t;
    fIntegral_ += 0.5 * (s.force + lastForce_.force) * dt;
    fTime_ += dt;
  }
  lastForce_ = s;
  haveForce_ = true;
  touch(s.t);
}

void LiveMetrics::addPathCrossing(double t) {
  ++pathBreaks_;
  touch(t);
}

void LiveMetrics::addCutSegment(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const double len = (b - a).norm();
  const int n = std::max(1, static_cast<int>(std::ceil(len / s_.distanceStep)));
  double prev = distanceToPath(a, drawn_);
  for (int k = 1; k <= n; ++k) {
    const double dk = distanceToPath(a + (b - a) * (double(k) / n), drawn_);
    distMax_ = std::max(distMax_, dk);
    distIntegral_ += 0.5 * (prev + dk) * len / n;
    prev = dk;
  }
  distLength_ += len;
  for (std::size_t i = 0; i + 1 < drawn_.size(); ++i) {
    if (drawn_[i].stop) continue;
    double t0, t1;
    if (!bandInterval(drawn_[i].p, drawn_[i + 1].p, a, b, s_.band, t0, t1)) continue;
    auto& iv = coverage_[i];
    iv.emplace_back(t0, t1);
    std::sort(iv.begin(), iv.end());
    std::vector<std::pair<double, double>> merged;
    for (const auto& x : iv) {
      if (!merged.empty() && x.first <= merged.back().second)
        merged.back().second = std::max(merged.back().second, x.second);
      else
        merged.push_back(x);
    }
    iv = std::move(merged);
    double c = 0.0;
    for (const auto& x : iv) c += x.second - x.first;
    c *= (drawn_[i + 1].p - drawn_[i].p).norm();
    coveredTotal_ += c - coveredLen_[i];
    coveredLen_[i] = c;
  }
}

void LiveMetrics::addCutPoint(double t, const Eigen::Vector3d& p) {
  distMax_ = std::max(distMax_, distanceToPath(p, drawn_));
  distPointSum_ += distanceToPath(p, drawn_);
  if (!cut_.empty() && !cut_.back().stop) addCutSegment(cut_.back().p, p);
  cut_.push_back({p, false});
  dev_.addCutPoint(p);
  touch(t);
}

void LiveMetrics::endCutPiece() {
  if (cut_.empty() || cut_.back().stop) return;
  const bool single = cut_.size() == 1 || cut_[cut_.size() - 2].stop;
  if (single) addCutSegment(cut_.back().p, cut_.back().p);
  cut_.back().stop = true;
}

Metrics LiveMetrics::current() const {
  Metrics m;
  m.deviation = dev_.value();
  DwellTracker d = dwell_;
  d.finish(tNow_);
  m.contact = d.result();
  m.contactBreaks = std::max(0, dwell_.contactIntervals() - 1);
  m.pathBreaks = pathBreaks_;
  m.totalTimeS = tNow_ - t0_;
  m.stretchMaxN = fMax_;
  m.stretchMeanN = fTime_ > 0.0 ? fIntegral_ / fTime_ : fMax_;
  m.cutDistanceMaxMm = distMax_;
  m.cutDistanceMeanMm = distLength_ > 0.0 ? distIntegral_ / distLength_
                        : cut_.empty()    ? 0.0
                                          : distPointSum_ / static_cast<double>(cut_.size());
  m.bandFraction = drawnLength_ > 0.0 ? std::clamp(coveredTotal_ / drawnLength_, 0.0, 1.0) : 0.0;
  m.pathLengthLeftMm = len_[0];
  m.pathLengthRightMm = len_[1];
  return m;
}

Metrics LiveMetrics::finish(double tEnd) {
  if (!started_) start(tEnd);
  endCutPiece();
  dwell_.finish(tEnd);
  dev_.finish();
  tNow_ = std::max(tNow_, tEnd);
  Metrics m = current();
  if (!cut_.empty()) {
    m.deviation = deviation(drawn_, cut_);
    m.deviationThesis = deviationThesis(drawn_, cut_);
  } else {
    m.deviation = m.deviationThesis = deviationWithoutCut(drawn_, s_.band);
    m.noCut = true;
  }
  series_.push_back({tNow_, m});
  lastSeries_ = tNow_;
  return m;
}

}  // namespace ld::curriculum
