#include "curriculum/task.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <limits>

#include "curriculum/curriculum_error.h"
#include "curriculum/json_check.h"

namespace ld::curriculum {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kMaxCoord = 1e6;  // mm

bool isTool(const std::string& s) { return s == "grasper" || s == "hook" || s == "scalpel" || s == "none"; }

Polyline parsePath(const nlohmann::json& j, const std::string& path, JsonCheck& c) {
  Polyline out;
  c.onlyKeys(j, path, {"pieces"});
  const nlohmann::json* pieces = c.array(j, path, "pieces", true);
  if (!pieces) return out;
  const std::string pp = jsonPath(path, "pieces");
  if (pieces->empty()) c.error(pp, "a path needs at least one piece");
  for (std::size_t i = 0; i < pieces->size(); ++i) {
    const nlohmann::json& piece = (*pieces)[i];
    const std::string ip = jsonPath(pp, i);
    if (!piece.is_array()) {
      c.error(ip, "a piece must be an array of [x, y, z] points");
      continue;
    }
    if (piece.size() < 2) c.error(ip, "a piece needs at least two points");
    for (std::size_t k = 0; k < piece.size(); ++k) {
      const nlohmann::json& q = piece[k];
      const std::string kp = jsonPath(ip, k);
      if (!q.is_array() || q.size() != 3) {
        c.error(kp, "a point must be [x, y, z]");
        continue;
      }
      Eigen::Vector3d p;
      bool good = true;
      for (int a = 0; a < 3; ++a) {
        if (!q[a].is_number() || !std::isfinite(q[a].get<double>()) || std::abs(q[a].get<double>()) > kMaxCoord) {
          c.error(jsonPath(kp, static_cast<std::size_t>(a)), "must be a finite number of mm (|value| <= 1e6)");
          good = false;
        } else {
          p[a] = q[a].get<double>();
        }
      }
      if (!good) continue;
      if (!out.empty() && !out.back().stop && (out.back().p - p).norm() < 1e-9)
        c.error(kp, "repeats the previous point");
      out.push_back({p, false});
    }
    if (!out.empty()) out.back().stop = true;
  }
  return out;
}

void parseThresholds(const nlohmann::json& j, const std::string& path, JsonCheck& c, Thresholds& t) {
  c.onlyKeys(j, path,
             {"max_deviation_mm2", "max_time_s", "min_band_fraction", "max_contact_breaks", "max_path_breaks",
              "max_dwell_s", "max_cut_distance_mean_mm", "min_score", "consecutive"});
  t.maxDeviationMm2 = c.number(j, path, "max_deviation_mm2", false, 0, kInf);
  t.maxTimeS = c.number(j, path, "max_time_s", false, 0, kInf);
  t.minBandFraction = c.number(j, path, "min_band_fraction", false, 0, 1);
  if (auto v = c.integer(j, path, "max_contact_breaks", false, 0, 1000000)) t.maxContactBreaks = static_cast<int>(*v);
  if (auto v = c.integer(j, path, "max_path_breaks", false, 0, 1000000)) t.maxPathBreaks = static_cast<int>(*v);
  t.maxDwellS = c.number(j, path, "max_dwell_s", false, 0, kInf);
  t.maxCutDistanceMeanMm = c.number(j, path, "max_cut_distance_mean_mm", false, 0, kInf);
  t.minScore = c.number(j, path, "min_score", false, 0, 100);
  if (auto v = c.integer(j, path, "consecutive", false, 1, 100)) t.consecutive = static_cast<int>(*v);
}

Task parseInto(const nlohmann::json& j, JsonCheck& c) {
  Task t;
  if (!j.is_object()) {
    c.error("", "a task must be a JSON object");
    return t;
  }
  c.onlyKeys(j, "",
             {"format", "format_version", "id", "version", "title", "description", "author", "level", "model", "tissue",
              "instruments", "path", "metrics", "scoring", "proficiency"});
  if (auto f = c.string(j, "", "format", true); f && *f != "lapdissect-task")
    c.error("/format", "is '" + *f + "', expected 'lapdissect-task'");
  if (auto v = c.integer(j, "", "format_version", true, 1, 1000)) {
    t.formatVersion = static_cast<int>(*v);
    if (*v > kTaskFormatVersion)
      c.error("/format_version", "version " + std::to_string(*v) + " is newer than this program reads (" +
                                     std::to_string(kTaskFormatVersion) + ")");
  }
  if (auto id = c.string(j, "", "id", true)) {
    bool okId = !id->empty() && id->size() <= 64;
    for (char ch : *id) okId = okId && ((ch >= 'a' && ch <= 'z') || (ch >= '0' && ch <= '9') || ch == '-' || ch == '_');
    if (!okId)
      c.error("/id", "'" + *id + "' must be 1-64 characters of a-z, 0-9, '-' or '_'");
    else
      t.id = *id;
  }
  if (auto v = c.integer(j, "", "version", true, 1, 1000000)) t.version = static_cast<int>(*v);
  if (auto s = c.string(j, "", "title", true)) t.title = *s;
  if (auto s = c.string(j, "", "description", false, false)) t.description = *s;
  if (auto v = c.integer(j, "", "level", false, 1, 100)) t.level = static_cast<int>(*v);
  if (const auto* a = c.object(j, "", "author", true)) {
    c.onlyKeys(*a, "/author", {"name", "date"});
    if (auto s = c.string(*a, "/author", "name", true)) t.authorName = *s;
    if (auto s = c.string(*a, "/author", "date", false)) t.authorDate = *s;
  }
  if (const auto* m = c.object(j, "", "model", true)) {
    c.onlyKeys(*m, "/model", {"file", "units"});
    if (auto s = c.string(*m, "/model", "file", true)) t.model = *s;
    if (auto s = c.string(*m, "/model", "units", false)) {
      if (*s != "mm" && *s != "cm" && *s != "m")
        c.error("/model/units", "'" + *s + "' is not one of mm, cm, m");
      else
        t.units = *s;
    }
  }
  if (const auto* ts = c.object(j, "", "tissue", false)) {
    c.onlyKeys(*ts, "/tissue", {"stiffness", "rest_length_ratio", "home_stiffness", "damping", "density"});
    if (auto v = c.number(*ts, "/tissue", "stiffness", false, 1e-9, 1e9)) t.tissue.stiffness = *v;
    if (auto v = c.number(*ts, "/tissue", "rest_length_ratio", false, 0.05, 2.0)) t.tissue.restLengthRatio = *v;
    if (auto v = c.number(*ts, "/tissue", "home_stiffness", false, 0, 1e9)) t.tissue.homeStiffness = *v;
    if (auto v = c.number(*ts, "/tissue", "damping", false, 0, 1e9)) t.tissue.damping = *v;
    if (auto v = c.number(*ts, "/tissue", "density", false, 1e-6, 1e3)) t.tissue.density = *v;
  }
  if (const auto* in = c.object(j, "", "instruments", true)) {
    c.onlyKeys(*in, "/instruments", {"left", "right"});
    for (const char* hand : {"left", "right"}) {
      if (auto s = c.string(*in, "/instruments", hand, true)) {
        if (!isTool(*s))
          c.error(jsonPath("/instruments", hand), "'" + *s + "' is not one of grasper, hook, scalpel, none");
        else
          (std::string(hand) == "left" ? t.leftTool : t.rightTool) = *s;
      }
    }
    if (t.leftTool != "hook" && t.leftTool != "scalpel" && t.rightTool != "hook" && t.rightTool != "scalpel" &&
        in->contains("left") && in->contains("right"))
      c.error("/instruments", "no hand holds a cutting instrument (hook or scalpel)");
  }
  if (const auto* p = c.object(j, "", "path", true)) t.path = parsePath(*p, "/path", c);
  if (const auto* m = c.object(j, "", "metrics", false)) {
    c.onlyKeys(*m, "/metrics", {"contact_radius_mm", "band_mm"});
    if (auto v = c.number(*m, "/metrics", "contact_radius_mm", false, 1e-3, 1e3)) t.metrics.contactRadius = *v;
    if (auto v = c.number(*m, "/metrics", "band_mm", false, 1e-3, 1e3)) t.metrics.band = *v;
  }
  if (const auto* s = c.object(j, "", "scoring", true)) {
    c.onlyKeys(*s, "/scoring", {"time_limit_s", "weights"});
    if (auto v = c.number(*s, "/scoring", "time_limit_s", true, 1, 86400)) t.scoring.timeLimitS = *v;
    if (const auto* w = c.object(*s, "/scoring", "weights", false)) {
      const std::string wp = "/scoring/weights";
      c.onlyKeys(*w, wp,
                 {"deviation_per_mm2", "uncut_fraction", "contact_break", "path_break", "max_dwell_per_s",
                  "cut_distance_mean_per_mm"});
      ScoreWeights& sw = t.scoring.weights;
      if (auto v = c.number(*w, wp, "deviation_per_mm2", false, 0, 1e6)) sw.deviationPerMm2 = *v;
      if (auto v = c.number(*w, wp, "uncut_fraction", false, 0, 1e6)) sw.uncutFraction = *v;
      if (auto v = c.number(*w, wp, "contact_break", false, 0, 1e6)) sw.contactBreak = *v;
      if (auto v = c.number(*w, wp, "path_break", false, 0, 1e6)) sw.pathBreak = *v;
      if (auto v = c.number(*w, wp, "max_dwell_per_s", false, 0, 1e6)) sw.maxDwellPerS = *v;
      if (auto v = c.number(*w, wp, "cut_distance_mean_per_mm", false, 0, 1e6)) sw.cutDistanceMeanPerMm = *v;
    }
  }
  if (const auto* pr = c.object(j, "", "proficiency", true)) parseThresholds(*pr, "/proficiency", c, t.proficiency);
  if (t.proficiency.maxTimeS && *t.proficiency.maxTimeS > t.scoring.timeLimitS)
    c.error("/proficiency/max_time_s", "is longer than /scoring/time_limit_s");
  return t;
}

}  // namespace

Task parseTask(const nlohmann::json& j, const std::string& source) {
  JsonCheck c(source);
  Task t = parseInto(j, c);
  c.throwIfErrors();
  return t;
}

std::vector<std::string> validateTask(const nlohmann::json& j, const std::string& source) {
  JsonCheck c(source);
  parseInto(j, c);
  return c.errors();
}

Task loadTask(const std::filesystem::path& file) { return parseTask(readJsonFile(file.string()), file.string()); }

nlohmann::json toJson(const Task& t) {
  nlohmann::json jp = nlohmann::json::array();
  for (const auto& piece : pieces(t.path)) {
    nlohmann::json pts = nlohmann::json::array();
    for (const auto& p : piece) pts.push_back({p.x(), p.y(), p.z()});
    jp.push_back(std::move(pts));
  }
  nlohmann::json prof = nlohmann::json::object();
  const Thresholds& th = t.proficiency;
  if (th.maxDeviationMm2) prof["max_deviation_mm2"] = *th.maxDeviationMm2;
  if (th.maxTimeS) prof["max_time_s"] = *th.maxTimeS;
  if (th.minBandFraction) prof["min_band_fraction"] = *th.minBandFraction;
  if (th.maxContactBreaks) prof["max_contact_breaks"] = *th.maxContactBreaks;
  if (th.maxPathBreaks) prof["max_path_breaks"] = *th.maxPathBreaks;
  if (th.maxDwellS) prof["max_dwell_s"] = *th.maxDwellS;
  if (th.maxCutDistanceMeanMm) prof["max_cut_distance_mean_mm"] = *th.maxCutDistanceMeanMm;
  if (th.minScore) prof["min_score"] = *th.minScore;
  prof["consecutive"] = th.consecutive;
  const ScoreWeights& w = t.scoring.weights;
  nlohmann::json j = {{"format", "lapdissect-task"},
                      {"format_version", t.formatVersion},
                      {"id", t.id},
                      {"version", t.version},
                      {"title", t.title},
                      {"description", t.description},
                      {"author", {{"name", t.authorName}}},
                      {"level", t.level},
                      {"model", {{"file", t.model}, {"units", t.units}}},
                      {"tissue",
                       {{"stiffness", t.tissue.stiffness},
                        {"rest_length_ratio", t.tissue.restLengthRatio},
                        {"home_stiffness", t.tissue.homeStiffness},
                        {"damping", t.tissue.damping},
                        {"density", t.tissue.density}}},
                      {"instruments", {{"left", t.leftTool}, {"right", t.rightTool}}},
                      {"path", {{"pieces", jp}}},
                      {"metrics", {{"contact_radius_mm", t.metrics.contactRadius}, {"band_mm", t.metrics.band}}},
                      {"scoring",
                       {{"time_limit_s", t.scoring.timeLimitS},
                        {"weights",
                         {{"deviation_per_mm2", w.deviationPerMm2},
                          {"uncut_fraction", w.uncutFraction},
                          {"contact_break", w.contactBreak},
                          {"path_break", w.pathBreak},
                          {"max_dwell_per_s", w.maxDwellPerS},
                          {"cut_distance_mean_per_mm", w.cutDistanceMeanPerMm}}}}},
                      {"proficiency", prof}};
  if (!t.authorDate.empty()) j["author"]["date"] = t.authorDate;
  return j;
}

void saveTask(const Task& t, const std::filesystem::path& file) {
  std::ofstream out(file);
  if (!out) throw CurriculumError(file.string() + ": cannot be written");
  out << toJson(t).dump(2) << "\n";
  if (!out) throw CurriculumError(file.string() + ": write failed");
}

std::string contentHash(const Task& t) {
  nlohmann::json j = toJson(t);
  j.erase("version");
  const std::string s = j.dump();  // keys sorted: canonical
  std::uint64_t h = 1469598103934665603ULL;
  for (unsigned char ch : s) {
    h ^= ch;
    h *= 1099511628211ULL;
  }
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

Task reviseTask(const Task& published, Task edited) {
  if (edited.id != published.id)
    throw CurriculumError("reviseTask: '" + edited.id + "' is not an edit of '" + published.id + "'");
  edited.version = published.version;
  if (contentHash(edited) != contentHash(published)) edited.version = published.version + 1;
  return edited;
}

std::filesystem::path resolveModel(const Task& t, const std::filesystem::path& taskFile) {
  namespace fs = std::filesystem;
  const fs::path m(t.model);
  if (m.is_absolute()) return fs::exists(m) ? m : fs::path();
  std::error_code ec;
  for (fs::path dir = fs::absolute(taskFile, ec).parent_path(); !dir.empty(); dir = dir.parent_path()) {
    if (fs::exists(dir / m)) return dir / m;
    if (dir == dir.parent_path()) break;
  }
  if (fs::exists(m)) return fs::absolute(m, ec);
  return {};
}

TaskLibrary TaskLibrary::loadFolder(const std::filesystem::path& dir) {
  TaskLibrary lib;
  std::vector<std::string> problems;
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    if (e.path().extension() == ".json") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  for (const auto& f : files) {
    try {
      lib.add(loadTask(f), f.string());
    } catch (const FormatError& e) {
      problems.insert(problems.end(), e.problems().begin(), e.problems().end());
    } catch (const CurriculumError& e) {
      problems.push_back(e.what());
    }
  }
  if (!problems.empty()) throw FormatError(problems);
  return lib;
}

void TaskLibrary::add(Task t, const std::string& source) {
  const auto key = std::make_pair(t.id, t.version);
  auto it = tasks_.find(key);
  if (it != tasks_.end()) {
    if (contentHash(it->second.first) != contentHash(t))
      throw FormatError({source + ": /version: task '" + t.id + "' version " + std::to_string(t.version) +
                         " differs from " + it->second.second +
                         " with the same version (an edit needs a new version)"});
    return;
  }
  tasks_.emplace(key, std::make_pair(std::move(t), source));
}

const Task* TaskLibrary::find(const std::string& id, std::optional<int> version) const {
  if (version) {
    auto it = tasks_.find({id, *version});
    return it == tasks_.end() ? nullptr : &it->second.first;
  }
  const Task* best = nullptr;
  for (const auto& [k, v] : tasks_)
    if (k.first == id) best = &v.first;  // map order: highest version last
  return best;
}

std::vector<std::string> TaskLibrary::ids() const {
  std::vector<std::string> out;
  for (const auto& [k, v] : tasks_)
    if (out.empty() || out.back() != k.first) out.push_back(k.first);
  return out;
}

}  // namespace ld::curriculum
