#include "curriculum/curriculum_plan.h"

#include <algorithm>
#include <set>

#include "curriculum/curriculum_error.h"
#include "curriculum/json_check.h"
#include "curriculum/metrics/score.h"

namespace ld::curriculum {
namespace {

Curriculum parseInto(const nlohmann::json& j, JsonCheck& c, const TaskLibrary* lib) {
  Curriculum cur;
  if (!j.is_object()) {
    c.error("", "a curriculum must be a JSON object");
    return cur;
  }
  c.onlyKeys(j, "", {"format", "format_version", "id", "version", "title", "description", "modules", "schedule"});
  if (auto f = c.string(j, "", "format", true); f && *f != "lapdissect-curriculum")
    c.error("/format", "is '" + *f + "', expected 'lapdissect-curriculum'");
  if (auto v = c.integer(j, "", "format_version", true, 1, 1000)) {
    cur.formatVersion = static_cast<int>(*v);
    if (*v > 1) c.error("/format_version", "version " + std::to_string(*v) + " is newer than this program reads (1)");
  }
  if (auto s = c.string(j, "", "id", true)) cur.id = *s;
  if (auto v = c.integer(j, "", "version", true, 1, 1000000)) cur.version = static_cast<int>(*v);
  if (auto s = c.string(j, "", "title", true)) cur.title = *s;
  if (auto s = c.string(j, "", "description", false, false)) cur.description = *s;
  std::set<std::string> seen;
  if (const auto* mods = c.array(j, "", "modules", true)) {
    if (mods->empty()) c.error("/modules", "a curriculum needs at least one module");
    for (std::size_t i = 0; i < mods->size(); ++i) {
      const nlohmann::json& mj = (*mods)[i];
      const std::string mp = jsonPath("/modules", i);
      if (!mj.is_object()) {
        c.error(mp, "a module must be an object");
        continue;
      }
      Module m;
      c.onlyKeys(mj, mp, {"id", "title", "requires", "tasks", "proficiency"});
      if (auto s = c.string(mj, mp, "id", true)) {
        m.id = *s;
        if (seen.count(m.id)) c.error(jsonPath(mp, "id"), "module '" + m.id + "' appears twice");
      }
      if (auto s = c.string(mj, mp, "title", true)) m.title = *s;
      if (const auto* req = c.array(mj, mp, "requires", false)) {
        for (std::size_t k = 0; k < req->size(); ++k) {
          const std::string rp = jsonPath(jsonPath(mp, "requires"), k);
          if (!(*req)[k].is_string()) {
            c.error(rp, "must be a module id (a string)");
            continue;
          }
          const std::string r = (*req)[k].get<std::string>();
          if (!seen.count(r))
            c.error(rp, "module '" + r + "' is not an earlier module");
          else
            m.requires_.push_back(r);
        }
      }
      if (const auto* pr = c.object(mj, mp, "proficiency", false)) {
        const std::string pp = jsonPath(mp, "proficiency");
        c.onlyKeys(*pr, pp, {"rule", "consecutive"});
        if (auto s = c.string(*pr, pp, "rule", false)) {
          if (*s != "every_task" && *s != "final_task")
            c.error(jsonPath(pp, "rule"), "'" + *s + "' is not one of every_task, final_task");
          else
            m.rule = *s;
        }
        if (auto v = c.integer(*pr, pp, "consecutive", false, 1, 100)) m.consecutive = static_cast<int>(*v);
      }
      if (const auto* tasks = c.array(mj, mp, "tasks", true)) {
        if (tasks->empty()) c.error(jsonPath(mp, "tasks"), "a module needs at least one task");
        for (std::size_t k = 0; k < tasks->size(); ++k) {
          const nlohmann::json& tj = (*tasks)[k];
          const std::string tp = jsonPath(jsonPath(mp, "tasks"), k);
          if (!tj.is_object()) {
            c.error(tp, "must be an object {\"task\": id, \"repetitions\": n}");
            continue;
          }
          c.onlyKeys(tj, tp, {"task", "version", "repetitions"});
          ModuleTask mt;
          if (auto s = c.string(tj, tp, "task", true)) mt.task = *s;
          if (auto v = c.integer(tj, tp, "version", false, 1, 1000000)) mt.version = static_cast<int>(*v);
          if (auto v = c.integer(tj, tp, "repetitions", false, 1, 1000)) mt.repetitions = static_cast<int>(*v);
          if (lib && !mt.task.empty() && !lib->find(mt.task, mt.version))
            c.error(jsonPath(tp, "task"), "task '" + mt.task + "'" +
                                              (mt.version ? " version " + std::to_string(*mt.version) : "") +
                                              " is not in the task library");
          m.tasks.push_back(std::move(mt));
        }
      }
      seen.insert(m.id);
      cur.modules.push_back(std::move(m));
    }
  }
  if (const auto* s = c.object(j, "", "schedule", true)) {
    c.onlyKeys(*s, "/schedule",
               {"sessions_per_week", "min_hours_between_sessions", "max_attempts_per_session", "retention_check_days"});
    Schedule& sc = cur.schedule;
    if (auto v = c.integer(*s, "/schedule", "sessions_per_week", true, 1, 21))
      sc.sessionsPerWeek = static_cast<int>(*v);
    if (auto v = c.number(*s, "/schedule", "min_hours_between_sessions", false, 0, 24 * 30))
      sc.minHoursBetweenSessions = *v;
    if (auto v = c.integer(*s, "/schedule", "max_attempts_per_session", false, 1, 1000))
      sc.maxAttemptsPerSession = static_cast<int>(*v);
    if (auto v = c.integer(*s, "/schedule", "retention_check_days", false, 0, 3650))
      sc.retentionCheckDays = static_cast<int>(*v);
  }
  return cur;
}

}  // namespace

Curriculum parseCurriculum(const nlohmann::json& j, const std::string& source, const TaskLibrary* library) {
  JsonCheck c(source);
  Curriculum cur = parseInto(j, c, library);
  c.throwIfErrors();
  return cur;
}

std::vector<std::string> validateCurriculum(const nlohmann::json& j, const std::string& source,
                                            const TaskLibrary* library) {
  JsonCheck c(source);
  parseInto(j, c, library);
  return c.errors();
}

Curriculum loadCurriculum(const std::filesystem::path& file, const TaskLibrary* library) {
  return parseCurriculum(readJsonFile(file.string()), file.string(), library);
}

Progress progress(const Curriculum& c, const std::vector<AttemptSummary>& attempts) {
  Progress p;
  std::set<std::string> done;
  bool allDone = true;
  for (const Module& m : c.modules) {
    ModuleProgress mp;
    mp.id = m.id;
    mp.unlocked = std::all_of(m.requires_.begin(), m.requires_.end(), [&](const auto& r) { return done.count(r) > 0; });
    bool complete = true;
    for (std::size_t k = 0; k < m.tasks.size(); ++k) {
      const ModuleTask& mt = m.tasks[k];
      TaskProgress tp;
      tp.task = mt.task;
      std::vector<bool> passes;
      for (const auto& a : attempts) {
        if (a.task != mt.task || (mt.version && a.version != *mt.version)) continue;
        ++tp.attempts;
        tp.passes += a.passed ? 1 : 0;
        passes.push_back(a.passed);
      }
      tp.repetitionsDone = tp.attempts >= mt.repetitions;
      tp.proficient = proficient(passes, m.consecutive);
      const bool needed = m.rule == "every_task" || k + 1 == m.tasks.size();
      const bool taskDone = tp.repetitionsDone && (!needed || tp.proficient);
      complete = complete && taskDone;
      if (!taskDone && mp.unlocked && !p.nextTask) p.nextTask = mt.task;
      mp.tasks.push_back(tp);
    }
    mp.complete = mp.unlocked && complete;
    if (mp.complete) done.insert(m.id);
    allDone = allDone && mp.complete;
    p.modules.push_back(std::move(mp));
  }
  p.complete = allDone && !c.modules.empty();
  return p;
}

bool sessionAllowed(const Schedule& s, const std::vector<double>& starts, double now, std::string* reason) {
  const double week = 7 * 24 * 3600.0;
  int inWeek = 0;
  double last = -1e300;
  for (double t : starts) {
    if (t <= now && t > now - week) ++inWeek;
    if (t <= now) last = std::max(last, t);
  }
  if (now - last < s.minHoursBetweenSessions * 3600.0) {
    if (reason) *reason = "the last session was less than " + std::to_string(int(s.minHoursBetweenSessions)) + " h ago";
    return false;
  }
  if (inWeek >= s.sessionsPerWeek) {
    if (reason) *reason = "already " + std::to_string(inWeek) + " sessions in the last 7 days";
    return false;
  }
  return true;
}

}  // namespace ld::curriculum
