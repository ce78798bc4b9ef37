#include "curriculum/curriculum_plan.h"

#include "curriculum/curriculum_error.h"
#include "tests/support/test_support.h"

namespace ld::curriculum {
namespace {

Task task(const std::string& id) {
  Task t;
  t.id = id;
  t.title = id;
  t.model = "m.obj";
  t.path = makePolyline({Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0)});
  return t;
}

nlohmann::json plan() {
  return nlohmann::json::parse(R"({
    "format": "lapdissect-curriculum", "format_version": 1, "id": "c", "version": 1, "title": "C",
    "modules": [
      {"id": "m1", "title": "M1", "tasks": [{"task": "a", "repetitions": 2}, {"task": "b"}]},
      {"id": "m2", "title": "M2", "requires": ["m1"], "tasks": [{"task": "c", "repetitions": 1}],
       "proficiency": {"rule": "final_task", "consecutive": 3}}],
    "schedule": {"sessions_per_week": 2, "min_hours_between_sessions": 12}})");
}

TaskLibrary library() {
  TaskLibrary lib;
  for (const char* id : {"a", "b", "c"}) lib.add(task(id), id);
  return lib;
}

TEST(CurriculumPlan, ParsesAndChecksReferences) {
  const TaskLibrary lib = library();
  const Curriculum c = parseCurriculum(plan(), "c.json", &lib);
  ASSERT_EQ(c.modules.size(), 2u);
  EXPECT_EQ(c.modules[0].tasks[0].repetitions, 2);
  EXPECT_EQ(c.modules[1].rule, "final_task");
  EXPECT_EQ(c.modules[1].consecutive, 3);
  EXPECT_EQ(c.schedule.sessionsPerWeek, 2);

  nlohmann::json j = plan();
  j["modules"][1]["tasks"][0]["task"] = "zzz";
  j["modules"][1]["requires"] = {"m9"};
  j["modules"][0]["tasks"][1]["repetitions"] = 0;
  j["modules"][1]["id"] = "m1";
  const auto errs = validateCurriculum(j, "c.json", &lib);
  auto has = [&](const std::string& s) {
    for (const auto& e : errs)
      if (e.find(s) != std::string::npos) return true;
    return false;
  };
  EXPECT_TRUE(has("c.json: /modules/1/tasks/0/task: task 'zzz' is not in the task library"));
  EXPECT_TRUE(has("c.json: /modules/1/requires/0: module 'm9' is not an earlier module"));
  EXPECT_TRUE(has("c.json: /modules/0/tasks/1/repetitions: 0 is out of range"));
  EXPECT_TRUE(has("c.json: /modules/1/id: module 'm1' appears twice"));
  EXPECT_THROW(parseCurriculum(j, "c.json", &lib), FormatError);
}

TEST(CurriculumPlan, ProgressFollowsRepetitionsAndProficiency) {
  const Curriculum c = parseCurriculum(plan(), "c.json");
  std::vector<AttemptSummary> att;
  Progress p = progress(c, att);
  EXPECT_EQ(p.nextTask, "a");
  EXPECT_FALSE(p.modules[1].unlocked);
  att.push_back({"a", 1, true, 0});
  att.push_back({"a", 1, false, 0});
  EXPECT_EQ(progress(c, att).nextTask, "a");  // repetitions done, not proficient
  att.push_back({"a", 1, true, 0});
  att.push_back({"a", 1, true, 0});
  p = progress(c, att);
  EXPECT_TRUE(p.modules[0].tasks[0].proficient);
  EXPECT_EQ(p.nextTask, "b");
  att.push_back({"b", 1, true, 0});
  att.push_back({"b", 1, true, 0});
  p = progress(c, att);
  EXPECT_TRUE(p.modules[0].complete);
  EXPECT_TRUE(p.modules[1].unlocked);
  EXPECT_EQ(p.nextTask, "c");
  for (int i = 0; i < 3; ++i) att.push_back({"c", 1, true, 0});
  p = progress(c, att);
  EXPECT_TRUE(p.complete);
  EXPECT_FALSE(p.nextTask.has_value());
}

TEST(CurriculumPlan, PinnedVersionsCountOnlyTheirAttempts) {
  nlohmann::json j = plan();
  j["modules"][0]["tasks"][1]["version"] = 2;
  const Curriculum c = parseCurriculum(j, "c.json");
  std::vector<AttemptSummary> att{{"b", 1, true, 0}, {"b", 1, true, 0}};
  EXPECT_FALSE(progress(c, att).modules[0].tasks[1].proficient);
  att.push_back({"b", 2, true, 0});
  att.push_back({"b", 2, true, 0});
  EXPECT_TRUE(progress(c, att).modules[0].tasks[1].proficient);
}

TEST(CurriculumPlan, ScheduleLimitsSessions) {
  Schedule s;
  s.sessionsPerWeek = 2;
  s.minHoursBetweenSessions = 12;
  const double h = 3600, day = 24 * h;
  std::string why;
  EXPECT_TRUE(sessionAllowed(s, {}, 0));
  EXPECT_FALSE(sessionAllowed(s, {0}, 6 * h, &why));
  EXPECT_NE(why.find("12 h"), std::string::npos);
  EXPECT_TRUE(sessionAllowed(s, {0}, 13 * h));
  EXPECT_FALSE(sessionAllowed(s, {0, 2 * day}, 4 * day, &why));
  EXPECT_NE(why.find("2 sessions"), std::string::npos);
  EXPECT_TRUE(sessionAllowed(s, {0, 2 * day}, 7.5 * day));
}

}  // namespace
}  // namespace ld::curriculum
