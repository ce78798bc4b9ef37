// lapdissect-cli task validate / run / script.
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/data_paths.h"
#include "tests/support/run_command.h"

namespace {

namespace fs = std::filesystem;
using ld::test::resourcesDir;
using ld::test::runCommand;
using ld::test::shellQuote;

std::string cli() { return shellQuote(LD_CLI); }
fs::path tasks() { return resourcesDir() / "tasks"; }
std::string temp(const std::string& name) {
  return (fs::temp_directory_path() / ("ld_task_cli_" + std::to_string(::getpid()) + "_" + name)).string();
}

TEST(TaskCli, ValidatesEveryBundledFile) {
  for (const auto& e : fs::directory_iterator(tasks())) {
    const auto r = runCommand(cli() + " task validate " + shellQuote(e.path().string()));
    EXPECT_EQ(r.exitCode, 0) << e.path() << ": " << r.err;
    EXPECT_TRUE(nlohmann::json::parse(r.out)["valid"].get<bool>());
  }
  const auto r =
      runCommand(cli() + " task validate " + shellQuote((resourcesDir() / "curriculum" / "default.json").string()));
  EXPECT_EQ(r.exitCode, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["kind"], "curriculum");
  EXPECT_TRUE(j["tasks_checked"].get<bool>());
}

TEST(TaskCli, RefusesBadFilesWithReasons) {
  auto j = nlohmann::json::parse(std::ifstream(tasks() / "slab-straight-line.json"));
  j["scoring"]["time_limit_s"] = "long";
  j["path"]["pieces"][0][3] = {0, 0, 40};  // far off the slab
  const auto bad = temp("bad.json");
  std::ofstream(bad) << j.dump();
  auto r = runCommand(cli() + " task validate " + shellQuote(bad));
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find(bad + ": /scoring/time_limit_s: must be a number"), std::string::npos) << r.err;

  j = nlohmann::json::parse(std::ifstream(tasks() / "slab-straight-line.json"));
  j["path"]["pieces"][0][3] = {0, 0, 40};
  j["model"]["file"] = (resourcesDir() / "models" / "tissue_slab.obj").string();
  std::ofstream(bad) << j.dump();
  r = runCommand(cli() + " task validate " + shellQuote(bad));
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find(bad + ": /path/pieces/0/3: 37.5 mm from the surface"), std::string::npos) << r.err;

  std::ofstream(bad) << "{\"format\": \"lapdissect-task\",\n \"id\": }";
  r = runCommand(cli() + " task validate " + shellQuote(bad));
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find(bad + ":2:"), std::string::npos) << r.err;
  r = runCommand(cli() + " task validate /nonexistent/task.json");
  EXPECT_EQ(r.exitCode, 2);
  fs::remove(bad);
}

TEST(TaskCli, RunsAScriptedExpertAndNovice) {
  const std::string task = shellQuote((tasks() / "slab-straight-line.json").string());
  double scores[2] = {0, 0}, deviations[2] = {0, 0}, bands[2] = {0, 0};
  for (int level : {0, 2}) {
    const auto traj = temp("traj" + std::to_string(level) + ".csv");
    auto r = runCommand(cli() + " task script --task " + task + " --level " + std::to_string(level) +
                        " --rate 200 --out " + shellQuote(traj));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    // A still tissue: the metrics' ranking (physics: RunsWithPhysicsOnRequest).
    r = runCommand(cli() + " task run --task " + task + " --trajectory " + shellQuote(traj) + " --physics off");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["physics"]["on"], false);
    for (const char* k :
         {"deviation", "contact_time", "contact_breaks", "path_breaks", "total_time_s", "score", "passed"})
      ASSERT_TRUE(j.contains(k)) << k;
    for (const char* k : {"xy", "yz", "xz", "total"}) ASSERT_TRUE(j["deviation"].contains(k)) << k;
    for (const char* k : {"mean_s", "max_s", "total_s"}) ASSERT_TRUE(j["contact_time"].contains(k)) << k;
    EXPECT_EQ(j["task"]["id"], "slab-straight-line");
    EXPECT_EQ(j["task"]["version"], 1);
    EXPECT_EQ(j["passed"].get<bool>(), level == 0) << r.out;
    EXPECT_EQ(j["contact_breaks"].get<int>(), level);
    scores[level / 2] = j["score"].get<double>();
    deviations[level / 2] = j["deviation"]["total"].get<double>();
    bands[level / 2] = j["band_fraction"].get<double>();
    // The attempt went through the cutting engine: the tissue was cut, the drawn path
    // followed the edits without a global search.
    EXPECT_EQ(j["cutting"]["engine"], "ld::cutting::CutEngine");
    EXPECT_GT(j["cutting"]["triangles_cut"].get<long>(), 10);
    EXPECT_EQ(j["drawn_path"]["global_searches"].get<long>(), 0);
    // Each crossing breaks the drawn path; two crossings of one drawn segment break it once.
    EXPECT_LE(j["drawn_path"]["pieces"].get<int>(), 1 + j["path_breaks"].get<int>());
    EXPECT_EQ(j["drawn_path"]["pieces"].get<int>() > 1, j["path_breaks"].get<int>() > 0);
    EXPECT_FALSE(j["deviation"]["no_cut"].get<bool>());
    if (level == 2) {
      EXPECT_FALSE(j["reasons"]["failed"].empty());
    }
    fs::remove(traj);
  }
  EXPECT_GT(scores[0], scores[1]);
  EXPECT_LT(deviations[0], deviations[1]);
  EXPECT_GE(bands[0], bands[1]);
}

TEST(TaskCli, RunsWithPhysicsOnRequest) {
  // The scripted trainees grasp the slab's edge and retract it: the grasper's force
  // comes from the physics (penalty springs on the held vertices), the novice pulls
  // harder. The default (still) takes the force from the physics too, with the cut on
  // the tissue held still: the same metrics as --physics off but the force, which is
  // near the moving run's; --physics off gives the estimate; a bad value is refused.
  const std::string task = shellQuote((tasks() / "slab-straight-line.json").string());
  double maxN[2] = {0, 0};
  for (int level : {0, 2}) {
    const auto traj = temp("phys" + std::to_string(level) + ".csv");
    auto r = runCommand(cli() + " task script --task " + task + " --level " + std::to_string(level) +
                        " --rate 250 --out " + shellQuote(traj));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    r = runCommand(cli() + " task run --task " + task + " --trajectory " + shellQuote(traj) + " --physics on");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["stretch_force"]["model"], "physics");
    EXPECT_EQ(j["physics"]["on"], true);
    EXPECT_EQ(j["physics"]["grasps"].get<int>(), 1);
    EXPECT_GT(j["physics"]["held_vertices"].get<int>(), 0);
    EXPECT_GT(j["physics"]["steps"].get<long>(), 1000);
    EXPECT_EQ(j["physics"]["implicit_fallbacks"].get<long>(), 0);
    EXPECT_LT(j["physics"]["start_residual_mn"].get<double>(), 1e-9);
    EXPECT_GT(j["stretch_force"]["mean_n"].get<double>(), 0.0);
    maxN[level / 2] = j["stretch_force"]["max_n"].get<double>();
    if (level == 0) {
      r = runCommand(cli() + " task run --task " + task + " --trajectory " + shellQuote(traj));  // still by default
      ASSERT_EQ(r.exitCode, 0) << r.err;
      const auto d = nlohmann::json::parse(r.out);
      EXPECT_EQ(d["physics"]["mode"], "still");
      EXPECT_NE(d["stretch_force"]["model"].get<std::string>().find("held still"), std::string::npos);
      EXPECT_NEAR(d["stretch_force"]["mean_n"].get<double>(), j["stretch_force"]["mean_n"].get<double>(),
                  0.25 * j["stretch_force"]["mean_n"].get<double>());
      EXPECT_EQ(d["cutting"]["walk_failures"].get<long>(), 0);
      EXPECT_TRUE(d["passed"].get<bool>()) << r.out;
      r = runCommand(cli() + " task run --task " + task + " --trajectory " + shellQuote(traj) + " --physics off");
      ASSERT_EQ(r.exitCode, 0) << r.err;
      const auto e = nlohmann::json::parse(r.out);
      EXPECT_NE(e["stretch_force"]["model"].get<std::string>().find("estimate"), std::string::npos);
      EXPECT_EQ(e["physics"]["mode"], "off");
      EXPECT_LT(5 * e["stretch_force"]["max_n"].get<double>(), d["stretch_force"]["max_n"].get<double>());
      EXPECT_EQ(e["deviation"]["total"], d["deviation"]["total"]);  // the same still cut
      EXPECT_EQ(e["path_breaks"], d["path_breaks"]);
      EXPECT_EQ(e["score"], d["score"]);
      r = runCommand(cli() + " task run --task " + task + " --trajectory " + shellQuote(traj) + " --physics maybe");
      EXPECT_EQ(r.exitCode, 2);
      EXPECT_NE(r.err.find("--physics"), std::string::npos) << r.err;
    }
    fs::remove(traj);
  }
  EXPECT_LT(maxN[0], maxN[1]);
}

TEST(TaskCli, RunRefusesBadTrajectory) {
  const auto traj = temp("bad.csv");
  std::ofstream(traj) << "t,hand,tool,tip_x,tip_y,tip_z,dir_x,dir_y,dir_z,up_x,up_y,up_z,jaw,pedal\n"
                         "0,right,hook,0,0,3,0,0,-1,1,0,0,0,1\n"
                         "0.1,middle,hook,0,0,3,0,0,-1,1,0,0,0,1\n";
  const auto r = runCommand(cli() + " task run --task " + shellQuote((tasks() / "slab-straight-line.json").string()) +
                            " --trajectory " + shellQuote(traj));
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find(traj + ":3:"), std::string::npos) << r.err;
  fs::remove(traj);
}

TEST(TaskCli, RunStoresTheAttemptInTheTraineeStore) {
  const fs::path dir = temp("store");
  fs::create_directories(dir);
  const std::string url = shellQuote("sqlite://" + (dir / "store.db").string());
  const std::string db = "LAPDISSECT_INSECURE_FAST_HASH=1 " + cli() + " db ";
  auto r = runCommand(db + "init --admin boss --db " + url, "boss-password\n");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  r = runCommand(db + "user add --as boss --name kim --role resident --db " + url, "boss-password\nkim-password\n");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const std::string task = shellQuote((tasks() / "slab-straight-line.json").string());
  const auto traj = (dir / "t.csv").string();
  r = runCommand(cli() + " task script --task " + task + " --level 0 --rate 100 --out " + shellQuote(traj));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const std::string run = "LAPDISSECT_INSECURE_FAST_HASH=1 " + cli() + " task run --task " + task + " --trajectory " +
                          shellQuote(traj) + " --db " + url + " --trainee kim --physics off";  // the store's matter
  r = runCommand(run, "kim-password\n");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_TRUE(j.contains("attempt_id"));
  // The stored attempt keeps the task version and the metrics.
  r = runCommand(db + "attempts --as kim --db " + url, "kim-password\n");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto list = nlohmann::json::parse(r.out);
  const auto& attempts = list.is_array() ? list : list["attempts"];
  ASSERT_EQ(attempts.size(), 1u) << r.out;
  EXPECT_EQ(attempts[0]["task_id"], "slab-straight-line");
  EXPECT_EQ(attempts[0]["task_version"], 1);
  EXPECT_EQ(attempts[0]["passed"], j["passed"]);
  EXPECT_EQ(attempts[0]["metrics"]["deviation"]["total"], j["deviation"]["total"]);
  // A wrong password stores nothing.
  r = runCommand(run, "wrong\n");
  EXPECT_EQ(r.exitCode, 3) << r.err;
  EXPECT_EQ(
      runCommand(cli() + " task run --task " + task + " --trajectory " + shellQuote(traj) + " --db " + url).exitCode,
      2);  // --db without --trainee
  fs::remove_all(dir);
}

}  // namespace
