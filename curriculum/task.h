#pragma once
// Tasks (DESIGN.md, Files): a predefined path on a tissue model, the instruments per
// hand, the tissue parameters, the metric settings, the score and the proficiency
// thresholds. Stored as JSON in resources/tasks/*.json:
//
// { "format": "lapdissect-task", "format_version": 1,
//   "id": "slab-straight-line", "version": 1, "title": "...", "description": "...",
//   "author": {"name": "...", "date": "2026-11-22"}, "level": 1,
//   "model": {"file": "resources/models/tissue_slab.obj", "units": "mm"},
//   "tissue": {"stiffness": 60, "rest_length_ratio": 0.7, "home_stiffness": 10, "damping": 2, "density": 1},
//   "instruments": {"left": "grasper", "right": "hook"},
//   "path": {"pieces": [[[x, y, z], ...], ...]},
//   "metrics": {"contact_radius_mm": 2, "band_mm": 2},
//   "scoring": {"time_limit_s": 120, "weights": {"deviation_per_mm2": 0.05, ...}},
//   "proficiency": {"max_deviation_mm2": 300, "min_band_fraction": 0.9, ..., "consecutive": 2} }
//
// Versions: an edited task is saved with version + 1 (reviseTask); attempts record
// {id, version, content hash}, so old attempts keep the version they were made on.
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "curriculum/metrics/metrics.h"
#include "curriculum/metrics/polyline.h"
#include "curriculum/metrics/score.h"

namespace ld::curriculum {

inline constexpr int kTaskFormatVersion = 1;

struct TissueSettings {
  double stiffness = 60.0;       // K: spring stiffness k = K / rest length
  double restLengthRatio = 0.7;  // pre-stretch (thesis)
  double homeStiffness = 10.0;   // tie to the home position
  double damping = 2.0;          // velocity damping
  double density = 1.0;          // g/cm³, for the vertex masses
};

struct Task {
  int formatVersion = kTaskFormatVersion;
  std::string id;
  int version = 1;
  std::string title, description;
  std::string authorName, authorDate;
  int level = 1;      // difficulty, 1 = easiest
  std::string model;  // model file, relative to the project root (or absolute)
  std::string units = "mm";
  TissueSettings tissue;
  std::string leftTool = "grasper", rightTool = "hook";  // "grasper", "hook", "scalpel" or "none"
  Polyline path;                                         // world points (mm) on the surface, stop flags end pieces
  MetricSettings metrics;
  ScoringSettings scoring;
  Thresholds proficiency;
};

// Parse and validate; throws FormatError listing every problem.
Task parseTask(const nlohmann::json& j, const std::string& source);
Task loadTask(const std::filesystem::path& file);
// The problems of a task document (empty when valid).
std::vector<std::string> validateTask(const nlohmann::json& j, const std::string& source);

nlohmann::json toJson(const Task& t);
void saveTask(const Task& t, const std::filesystem::path& file);

// Hash of everything but the version (hex, 16 digits): tells whether two files
// describe the same task content.
std::string contentHash(const Task& t);
// An author's edit of `published`: returns `edited` with version = published.version
// + 1 when the content changed, or published.version when it did not. Throws
// CurriculumError when the ids differ.
Task reviseTask(const Task& published, Task edited);

// Where the model file is: as given when absolute, else the first existing of
// <project root above the task file>/model, <cwd>/model; empty when none exists.
std::filesystem::path resolveModel(const Task& t, const std::filesystem::path& taskFile);

// Every version of every task in a folder (*.json). Two files with the same id and
// version but different content are an error.
class TaskLibrary {
 public:
  static TaskLibrary loadFolder(const std::filesystem::path& dir);
  void add(Task t, const std::string& source);
  [[nodiscard]] const Task* find(const std::string& id, std::optional<int> version = std::nullopt) const;
  [[nodiscard]] std::vector<std::string> ids() const;
  [[nodiscard]] std::size_t size() const { return tasks_.size(); }

 private:
  std::map<std::pair<std::string, int>, std::pair<Task, std::string>> tasks_;  // (id, version) -> task, source
};

}  // namespace ld::curriculum
