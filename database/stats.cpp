#include "database/stats.h"

#include <algorithm>
#include <cmath>

namespace ld::db {
namespace {

double quantileSorted(const std::vector<double>& v, double p) {
  const double h = p * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(h));
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (h - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

}  // namespace

Summary summarize(std::vector<double> values) {
  Summary s;
  s.n = values.size();
  if (values.empty()) return s;
  std::sort(values.begin(), values.end());
  s.min = values.front();
  s.max = values.back();
  s.q1 = quantileSorted(values, 0.25);
  s.median = quantileSorted(values, 0.5);
  s.q3 = quantileSorted(values, 0.75);
  return s;
}

}  // namespace ld::db
