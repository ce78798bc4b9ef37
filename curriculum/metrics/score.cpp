#include "curriculum/metrics/score.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace ld::curriculum {
namespace {

std::string fmt(double v) {
  char buf[64];
  const double a = std::abs(v);
  std::snprintf(buf, sizeof buf, a >= 100 ? "%.0f" : a >= 10 ? "%.1f" : "%.2f", v);
  std::string s = buf;
  if (s.find('.') != std::string::npos) {
    while (s.back() == '0') s.pop_back();
    if (s.back() == '.') s.pop_back();
  }
  return s;
}

std::string percent(double f) { return fmt(100.0 * f) + "%"; }

template <class T>
void checkMax(const char* what, double value, const std::optional<T>& limit, const std::string& unit, Assessment& a) {
  if (!limit) return;
  const std::string v = fmt(value) + unit, l = fmt(static_cast<double>(*limit)) + unit;
  if (value > static_cast<double>(*limit))
    a.failures.push_back(std::string(what) + " " + v + " over the " + l + " limit");
  else
    a.passes.push_back(std::string(what) + " " + v + " within the " + l + " limit");
}

}  // namespace

double penalty(const Metrics& m, const ScoreWeights& w) {
  return w.deviationPerMm2 * m.deviation.total() + w.uncutFraction * (1.0 - m.bandFraction) +
         w.contactBreak * m.contactBreaks + w.pathBreak * m.pathBreaks + w.maxDwellPerS * m.contact.maxS +
         w.cutDistanceMeanPerMm * m.cutDistanceMeanMm;
}

double score(const Metrics& m, const ScoringSettings& s) {
  if (s.timeLimitS <= 0.0) return 0.0;
  const double raw = std::max(0.0, s.timeLimitS - m.totalTimeS - penalty(m, s.weights));
  return std::clamp(100.0 * raw / s.timeLimitS, 0.0, 100.0);
}

Assessment assess(const Metrics& m, const ScoringSettings& s, const Thresholds& t) {
  Assessment a;
  a.penaltyS = penalty(m, s.weights);
  a.score = score(m, s);
  checkMax("deviation", m.deviation.total(), t.maxDeviationMm2, " mm²", a);
  checkMax("time", m.totalTimeS, t.maxTimeS, " s", a);
  if (t.minBandFraction) {
    const std::string what = percent(m.bandFraction) + " of the path cut within the band";
    if (m.bandFraction < *t.minBandFraction)
      a.failures.push_back(what + ", under the " + percent(*t.minBandFraction) + " required");
    else
      a.passes.push_back(what + ", at least the " + percent(*t.minBandFraction) + " required");
  }
  checkMax("contact breaks", m.contactBreaks, t.maxContactBreaks, "", a);
  checkMax("path breaks", m.pathBreaks, t.maxPathBreaks, "", a);
  checkMax("longest dwell", m.contact.maxS, t.maxDwellS, " s", a);
  checkMax("mean distance from the path", m.cutDistanceMeanMm, t.maxCutDistanceMeanMm, " mm", a);
  if (t.minScore) {
    if (a.score < *t.minScore)
      a.failures.push_back("score " + fmt(a.score) + " under the " + fmt(*t.minScore) + " required");
    else
      a.passes.push_back("score " + fmt(a.score) + ", at least the " + fmt(*t.minScore) + " required");
  }
  a.passed = a.failures.empty();
  return a;
}

int proficiencyReachedAt(const std::vector<bool>& passed, int consecutive) {
  const int need = std::max(1, consecutive);
  int run = 0;
  for (std::size_t i = 0; i < passed.size(); ++i) {
    run = passed[i] ? run + 1 : 0;
    if (run >= need) return static_cast<int>(i);
  }
  return -1;
}

bool proficient(const std::vector<bool>& passed, int consecutive) {
  return proficiencyReachedAt(passed, consecutive) >= 0;
}

}  // namespace ld::curriculum
