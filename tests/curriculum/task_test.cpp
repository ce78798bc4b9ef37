#include "curriculum/task.h"

#include <filesystem>
#include <fstream>

#include "curriculum/curriculum_error.h"
#include "curriculum/json_check.h"
#include "tests/support/test_support.h"

namespace ld::curriculum {
namespace {

nlohmann::json minimalTask() {
  return nlohmann::json::parse(R"({
    "format": "lapdissect-task", "format_version": 1, "id": "t1", "version": 1, "title": "T",
    "author": {"name": "A"}, "model": {"file": "resources/models/tissue_slab.obj"},
    "instruments": {"left": "grasper", "right": "hook"},
    "path": {"pieces": [[[0, 0, 2.5], [10, 0, 2.5]], [[20, 0, 2.5], [30, 0, 2.5], [40, 0, 2.5]]]},
    "scoring": {"time_limit_s": 120}, "proficiency": {"max_deviation_mm2": 100, "consecutive": 2}})");
}

bool anyContains(const std::vector<std::string>& v, const std::string& s) {
  for (const auto& x : v)
    if (x.find(s) != std::string::npos) return true;
  return false;
}

TEST(Task, ParsesAMinimalTask) {
  const Task t = parseTask(minimalTask(), "t1.json");
  EXPECT_EQ(t.id, "t1");
  ASSERT_EQ(t.path.size(), 5u);
  EXPECT_TRUE(t.path[1].stop);
  EXPECT_FALSE(t.path[2].stop);
  EXPECT_TRUE(t.path[4].stop);
  EXPECT_EQ(t.rightTool, "hook");
  EXPECT_DOUBLE_EQ(t.metrics.band, 2.0);  // default
  EXPECT_DOUBLE_EQ(*t.proficiency.maxDeviationMm2, 100.0);
  EXPECT_FALSE(t.proficiency.minBandFraction.has_value());
}

TEST(Task, ErrorsNameFilePathAndReason) {
  nlohmann::json j = minimalTask();
  j["path"]["pieces"][1][2][1] = "x";
  j["scoring"]["time_limit_s"] = -5;
  j["instruments"]["right"] = "laser";
  j["colour"] = "red";
  j.erase("title");
  const auto errs = validateTask(j, "bad.json");
  EXPECT_TRUE(anyContains(errs, "bad.json: /path/pieces/1/2/1: must be a finite number")) << errs.size();
  EXPECT_TRUE(anyContains(errs, "bad.json: /scoring/time_limit_s: -5 is out of range"));
  EXPECT_TRUE(anyContains(errs, "bad.json: /instruments/right: 'laser' is not one of"));
  EXPECT_TRUE(anyContains(errs, "bad.json: /colour: unknown key"));
  EXPECT_TRUE(anyContains(errs, "bad.json: /title: missing"));
  EXPECT_THROW(parseTask(j, "bad.json"), FormatError);
  try {
    parseTask(j, "bad.json");
  } catch (const FormatError& e) {
    EXPECT_EQ(e.problems().size(), errs.size());
  }
}

TEST(Task, RejectsStructuralProblems) {
  auto errsFor = [](auto edit) {
    nlohmann::json j = minimalTask();
    edit(j);
    return validateTask(j, "f.json");
  };
  EXPECT_TRUE(anyContains(errsFor([](auto& j) {
                            j["path"]["pieces"][0] = {{0, 0, 0}};
                          }),
                          "/path/pieces/0: a piece needs at least two"));
  EXPECT_TRUE(anyContains(errsFor([](auto& j) { j["path"]["pieces"] = nlohmann::json::array(); }),
                          "/path/pieces: a path needs"));
  EXPECT_TRUE(anyContains(errsFor([](auto& j) { j["format_version"] = 7; }), "/format_version: version 7 is newer"));
  EXPECT_TRUE(anyContains(errsFor([](auto& j) { j["version"] = 1.5; }), "/version: must be an integer"));
  EXPECT_TRUE(anyContains(errsFor([](auto& j) { j["id"] = "Bad Id"; }), "/id: 'Bad Id' must be"));
  EXPECT_TRUE(anyContains(errsFor([](auto& j) { j["instruments"]["right"] = "grasper"; }), "no hand holds a cutting"));
  EXPECT_TRUE(anyContains(errsFor([](auto& j) { j["proficiency"]["min_band_fraction"] = 1.5; }),
                          "/proficiency/min_band_fraction: 1.5 is out of range"));
  EXPECT_TRUE(anyContains(errsFor([](auto& j) {
                            j["path"]["pieces"][0][1] = {0, 0, 2.5};
                          }),
                          "/path/pieces/0/1: repeats"));
  EXPECT_TRUE(
      anyContains(errsFor([](auto& j) { j = nlohmann::json::array(); }), "f.json: /: a task must be a JSON object"));
}

TEST(Task, SyntaxErrorsGiveLineAndColumn) {
  try {
    parseJsonText("{\n  \"id\": \"x\",\n  oops\n}", "s.json");
    FAIL() << "no error";
  } catch (const FormatError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("s.json:3:", 0), 0u) << e.what();
  }
}

TEST(Task, RoundTripsThroughJson) {
  const Task t = parseTask(minimalTask(), "t1.json");
  const Task u = parseTask(toJson(t), "again");
  EXPECT_EQ(contentHash(t), contentHash(u));
  EXPECT_EQ(toJson(t), toJson(u));
}

TEST(Task, VersionsAnEdit) {
  const Task published = parseTask(minimalTask(), "t1.json");
  Task same = published;
  EXPECT_EQ(reviseTask(published, same).version, 1);
  Task edited = published;
  edited.proficiency.maxDeviationMm2 = 80.0;
  const Task v2 = reviseTask(published, edited);
  EXPECT_EQ(v2.version, 2);
  EXPECT_NE(contentHash(v2), contentHash(published));
  // Version alone does not change the content hash.
  Task bumped = published;
  bumped.version = 9;
  EXPECT_EQ(contentHash(bumped), contentHash(published));
  Task other = published;
  other.id = "t2";
  EXPECT_THROW(reviseTask(published, other), CurriculumError);

  // A library keeps both versions; the same version with other content is refused.
  TaskLibrary lib;
  lib.add(published, "a.json");
  lib.add(v2, "b.json");
  EXPECT_EQ(lib.find("t1")->version, 2);
  EXPECT_EQ(lib.find("t1", 1)->version, 1);
  EXPECT_EQ(lib.find("t1", 3), nullptr);
  Task clash = v2;
  clash.title = "changed without a new version";
  EXPECT_THROW(lib.add(clash, "c.json"), FormatError);
}

TEST(Task, SavesAndLoads) {
  const auto file = std::filesystem::temp_directory_path() / "ld_task_save_test.json";
  const Task t = parseTask(minimalTask(), "t1.json");
  saveTask(t, file);
  EXPECT_EQ(contentHash(loadTask(file)), contentHash(t));
  std::filesystem::remove(file);
  EXPECT_THROW(loadTask(file), FormatError);
}

}  // namespace
}  // namespace ld::curriculum
