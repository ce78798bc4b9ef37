#pragma once
// Scoring and proficiency (DESIGN.md, Metrics / Score). The default score follows the
// FLS form max(0, time_limit − time − penalty), normalised to 0–100; the penalty is a
// weighted sum of the metrics (weights per task, in seconds per unit).
#include <optional>
#include <string>
#include <vector>

#include "curriculum/metrics/metrics.h"

namespace ld::curriculum {

struct ScoreWeights {
  double deviationPerMm2 = 0.0;       // s per mm² of total deviation
  double uncutFraction = 0.0;         // s for the whole path left outside the band
  double contactBreak = 0.0;          // s per contact break
  double pathBreak = 0.0;             // s per path break
  double maxDwellPerS = 0.0;          // s per second of the longest dwell
  double cutDistanceMeanPerMm = 0.0;  // s per mm of mean cut distance
};

struct ScoringSettings {
  double timeLimitS = 300.0;
  ScoreWeights weights;
};

// Thresholds for passing an attempt; an absent one is not checked.
struct Thresholds {
  std::optional<double> maxDeviationMm2;
  std::optional<double> maxTimeS;
  std::optional<double> minBandFraction;
  std::optional<int> maxContactBreaks;
  std::optional<int> maxPathBreaks;
  std::optional<double> maxDwellS;
  std::optional<double> maxCutDistanceMeanMm;
  std::optional<double> minScore;
  int consecutive = 2;  // passes in a row for proficiency
};

struct Assessment {
  double penaltyS = 0.0;
  double score = 0.0;  // 0..100
  bool passed = false;
  std::vector<std::string> failures;  // readable, e.g. "deviation 412 mm² over the 300 mm² limit"
  std::vector<std::string> passes;    // the thresholds met, same style
};

double penalty(const Metrics& m, const ScoreWeights& w);
double score(const Metrics& m, const ScoringSettings& s);
Assessment assess(const Metrics& m, const ScoringSettings& s, const Thresholds& t);

// True when the attempts (oldest first) contain `consecutive` passes in a row.
bool proficient(const std::vector<bool>& passedInOrder, int consecutive = 2);
// Index of the attempt at which proficiency was first reached, or -1.
int proficiencyReachedAt(const std::vector<bool>& passedInOrder, int consecutive = 2);

}  // namespace ld::curriculum
