#pragma once
// Curricula (DESIGN.md, Files): ordered modules of tasks with repetitions,
// proficiency rules and a schedule. JSON (resources/curriculum/*.json):
//
// { "format": "lapdissect-curriculum", "format_version": 1, "id": "default", "version": 1,
//   "title": "...", "description": "...",
//   "modules": [ { "id": "basics", "title": "...", "requires": [],
//                  "tasks": [ {"task": "slab-straight-line", "repetitions": 3}, ... ],
//                  "proficiency": {"rule": "every_task", "consecutive": 2} } ],
//   "schedule": { "sessions_per_week": 2, "min_hours_between_sessions": 12,
//                 "max_attempts_per_session": 6, "retention_check_days": 14 } }
//
// A task is proficient when its thresholds are met on `consecutive` attempts in a row;
// a module is complete when every task has its repetitions and the rule holds
// ("every_task": each task proficient; "final_task": the last one).
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "curriculum/task.h"

namespace ld::curriculum {

struct ModuleTask {
  std::string task;
  std::optional<int> version;  // pinned version, or the latest
  int repetitions = 1;         // attempts required at least
};

struct Module {
  std::string id, title;
  std::vector<std::string> requires_;  // modules to complete first
  std::vector<ModuleTask> tasks;
  std::string rule = "every_task";
  int consecutive = 2;
};

struct Schedule {
  int sessionsPerWeek = 2;
  double minHoursBetweenSessions = 12.0;
  int maxAttemptsPerSession = 6;
  int retentionCheckDays = 14;  // a completed module's final task comes back after this
};

struct Curriculum {
  int formatVersion = 1;
  std::string id;
  int version = 1;
  std::string title, description;
  std::vector<Module> modules;
  Schedule schedule;
};

// With a library, task references (and pinned versions) must exist in it.
Curriculum parseCurriculum(const nlohmann::json& j, const std::string& source, const TaskLibrary* library = nullptr);
std::vector<std::string> validateCurriculum(const nlohmann::json& j, const std::string& source,
                                            const TaskLibrary* library = nullptr);
Curriculum loadCurriculum(const std::filesystem::path& file, const TaskLibrary* library = nullptr);

struct AttemptSummary {
  std::string task;
  int version = 1;
  bool passed = false;
  double time = 0.0;  // seconds since the epoch (session grouping)
};

struct TaskProgress {
  std::string task;
  int attempts = 0, passes = 0;
  bool repetitionsDone = false, proficient = false;
};

struct ModuleProgress {
  std::string id;
  bool unlocked = false, complete = false;
  std::vector<TaskProgress> tasks;
};

struct Progress {
  std::vector<ModuleProgress> modules;
  std::optional<std::string> nextTask;  // what the resident should do next
  bool complete = false;
};

// attempts oldest first.
Progress progress(const Curriculum& c, const std::vector<AttemptSummary>& attempts);

// Whether a new session may start at `now` given earlier session start times (s);
// `reason` says why not.
bool sessionAllowed(const Schedule& s, const std::vector<double>& sessionStarts, double now,
                    std::string* reason = nullptr);

}  // namespace ld::curriculum
