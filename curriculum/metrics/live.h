#pragma once
// Live metrics: updated as each event arrives, at a cost per event that does not
// grow with the attempt's length, producing the time series the live charts draw.
//
// The live deviation compares the cut so far with the drawn path up to the trainee's
// progress point P (the nearest point of the drawn path to the cut's end, searched in
// a short window of segments either way from the last one, so it follows the cut
// back when the trainee goes back: a P left ahead would close the loop by a long
// chord from P to the cut's end, an area that is not the trainee's, swept again at
// every point). Each new cut point changes the loop of DESIGN.md by one small closed
// polygon Q (P_old, drawn points between it and P_new, the new cut point, the old
// one), so the winding number field changes by w_Q only on Q's
// support. Each plane keeps the field on a grid of square cells (kCellMm) as the exact
// signed integral of w per cell (Q's share of each cell comes from its edges in closed
// form). A cell no edge of the loop passes through has one w: its share is |integral|.
// A cell the loop passes through also keeps the loop's pieces inside it (each edge of
// Q clipped to the cell; a piece and its reverse cancel, so only the loop's current
// edges stay): closed along the cell's border, they give w inside the cell up to a
// whole number, which the cell integral fixes, and ∫|w| over the cell follows exactly
// by the slab sweep of deviation.cpp. So the live value is exact also where the cut
// crosses the drawn path.
//
// A cell the cut passes over and over (a trainee working one place back and forth)
// would collect ever more pieces, and the sweep costs O(pieces²). Past maxPieces a
// cell is refined instead: it keeps the exact signed integral of w over each of
// kSub x kSub sub-cells (made from its pieces once, then updated from Q's edges in
// closed form like the cells), and its share is the sum of their |integral|. That
// is exact in every sub-cell w does not change sign in, and never above the exact
// value: the error is confined to sub-cells (kCellMm / kSub = 16 µm) the zero level
// of w passes through (README: measured tolerance). Cost per cut point depends on
// Q's size, the few pieces per exact cell and kSub² per refined cell, never on the
// attempt's length. finish() closes the loop; the batch value (deviation()) is what
// LiveMetrics reports at the end.
#include <cstdint>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "curriculum/metrics/deviation.h"
#include "curriculum/metrics/metrics.h"

namespace ld::curriculum {

class LiveDeviation {
 public:
  static constexpr double kCellMm = 0.25;
  // A polygon covering more cells than maxCells (a jump of many centimetres) is
  // counted by its |signed area| instead (then exact() is false).
  static constexpr std::size_t kMaxPieces = 4;  // per exact cell, then it is refined
  static constexpr int kSub = 16;               // sub-cells per side of a refined cell
  explicit LiveDeviation(const Polyline& drawn, double cellMm = kCellMm, std::size_t maxCells = 1u << 18,
                         std::size_t maxPieces = kMaxPieces);
  void addCutPoint(const Eigen::Vector3d& p);
  // Closes the loop at the drawn path's end: the value then equals deviation().
  void finish();
  [[nodiscard]] const Deviation& value() const { return value_; }
  // False once a cell was refined or a polygon was too large for the grid.
  [[nodiscard]] bool exact() const { return exact_; }
  [[nodiscard]] std::size_t refinedCells() const { return refined_; }
  [[nodiscard]] std::size_t progressSegment() const { return seg_; }
  [[nodiscard]] const Eigen::Vector3d& progressPoint() const { return p_; }

 private:
  // A piece of the loop inside a cell, end points in canonical (lexicographic) order;
  // `count` is how many times the loop runs a -> b (negative: b -> a).
  struct Piece {
    Eigen::Vector2d a, b;
    int count = 0;
  };
  struct Cell {
    double integral = 0.0;  // signed integral of w over the cell
    double abs = 0.0;       // ∫|w| over the cell (its share of the value)
    std::vector<Piece> pieces;
    // Exact cells: the area of each level of the pieces' winding number (closed along
    // the border) and twice its integral, kept while the pieces stay the same.
    std::vector<std::pair<int, double>> hist;
    double twice = 0.0;
    bool histOk = false;
    std::vector<double> sub;  // refined: kSub x kSub signed integrals (column-major)
    std::uint64_t refinedAt = 0;
  };
  // A weighted segment of a closed set of edges (its winding number w per crossing).
  struct WSeg {
    Eigen::Vector2d a, b;
    int w;
  };
  struct PlaneGrid {
    std::unordered_map<std::int64_t, Cell> cells;
    std::vector<double> scratch;
    struct Clipped {
      std::int64_t i, j;
      Piece piece;
    };
    std::vector<Clipped> clipped;  // scratch: Q's pieces per cell
    std::vector<std::pair<std::int64_t, std::int64_t>> dirty;
  };
  void clipEdge(const Eigen::Vector2d& p, const Eigen::Vector2d& q, PlaneGrid& g) const;
  [[nodiscard]] double cellAbs(Cell& c, std::int64_t i, std::int64_t j) const;
  void buildHistogram(Cell& c, std::int64_t i, std::int64_t j) const;
  // The cell's pieces closed along its border (to its lower left corner) and the
  // whole number w differs from their winding number by inside the cell.
  double closePieces(const Cell& c, std::int64_t i, std::int64_t j, std::vector<WSeg>& segs,
                     std::vector<char>& inside) const;
  void refine(Cell& c, std::int64_t i, std::int64_t j);
  // Adds the closed set's signed integral of w over each sub-cell of cell (i, j).
  void rasterAdd(const WSeg& s, std::int64_t i, std::int64_t j, std::vector<double>& sub) const;
  void addPolygon(const std::vector<Eigen::Vector3d>& poly);
  double addToPlane(PlaneGrid& g, const std::vector<Eigen::Vector2d>& loop);
  Eigen::Vector3d closestNear(const Eigen::Vector3d& p, std::size_t& seg, double& u) const;
  Eigen::Vector3d drawnPoint(std::size_t seg, double u) const;

  std::vector<Eigen::Vector3d> d_;
  double h_;
  std::size_t maxCells_, maxPieces_;
  std::size_t refined_ = 0;
  std::uint64_t update_ = 0;
  std::size_t seg_ = 0;
  double u_ = 0.0;
  bool started_ = false, finished_ = false, exact_ = true;
  Eigen::Vector3d lastCut_ = Eigen::Vector3d::Zero(), p_ = Eigen::Vector3d::Zero();
  PlaneGrid planes_[3];
  Deviation value_;
};

struct SeriesPoint {
  double t = 0.0;
  Metrics m;
};

class LiveMetrics {
 public:
  LiveMetrics(Polyline drawn, const MetricSettings& settings = {}, double seriesInterval = 0.05);
  void start(double t);
  void addTip(const TipSample& s);
  void addContact(const ContactSample& s);
  void addCutPoint(double t, const Eigen::Vector3d& p);
  void endCutPiece();  // the last cut point ends a piece (contact lost)
  void addPathCrossing(double t);
  void addGrasp(const ForceSample& s);
  // Values now (the live deviation; the contact time counts the open dwell so far).
  [[nodiscard]] Metrics current() const;
  // Closes everything at tEnd; the deviation then is the exact batch value.
  Metrics finish(double tEnd);
  [[nodiscard]] const std::vector<SeriesPoint>& series() const { return series_; }
  [[nodiscard]] const LiveDeviation& liveDeviation() const { return dev_; }
  [[nodiscard]] const Polyline& cut() const { return cut_; }

 private:
  void touch(double t);
  void addCutSegment(const Eigen::Vector3d& a, const Eigen::Vector3d& b);

  Polyline drawn_;
  MetricSettings s_;
  double interval_;
  LiveDeviation dev_;
  DwellTracker dwell_;
  Polyline cut_;
  double t0_ = 0.0, tNow_ = 0.0, lastSeries_ = -1e300;
  bool started_ = false;
  int pathBreaks_ = 0;
  // stretch force
  double fIntegral_ = 0.0, fTime_ = 0.0, fMax_ = 0.0;
  ForceSample lastForce_;
  bool haveForce_ = false;
  // tips
  double len_[2] = {0.0, 0.0};
  Eigen::Vector3d lastTip_[2];
  bool haveTip_[2] = {false, false};
  // cut distance and band coverage
  double distIntegral_ = 0.0, distLength_ = 0.0, distMax_ = 0.0, distPointSum_ = 0.0;
  std::vector<std::vector<std::pair<double, double>>> coverage_;  // per drawn segment
  std::vector<double> coveredLen_;
  double coveredTotal_ = 0.0, drawnLength_ = 0.0;
  std::vector<SeriesPoint> series_;
};

}  // namespace ld::curriculum
