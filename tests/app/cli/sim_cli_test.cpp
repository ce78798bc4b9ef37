// lapdissect-cli sim bench / sim chart on the real binary.
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/run_command.h"

namespace {

namespace fs = std::filesystem;
using ld::test::CommandResult;
using ld::test::runCommand;
using ld::test::shellQuote;

CommandResult cli(const std::string& args) { return runCommand(shellQuote(LD_CLI) + " " + args); }

nlohmann::json benchJson(const std::string& args) {
  const CommandResult r = cli("sim bench " + args);
  EXPECT_EQ(r.exitCode, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  for (const char* key : {"method", "dt", "steps", "us_per_step", "error_rms", "error_max", "stable"})
    EXPECT_TRUE(j.contains(key)) << key << " missing in " << r.out;
  return j;
}

class SimCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("ld_simcli_" + std::to_string(::getpid()) + "_" + std::to_string(std::rand()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(SimCli, OscillatorAgainstTheAnalyticSolution) {
  const auto j = benchJson("--scene oscillator --method rk4 --dt 0.01 --duration 1");
  EXPECT_EQ(j["method"], "rk4");
  EXPECT_EQ(j["steps"], 100);
  EXPECT_EQ(j["stable"], true);
  EXPECT_LT(j["error_max"].get<double>(), 1e-5);
  // Explicit Euler is first order: halving dt about halves the error.
  const double e1 = benchJson("--scene oscillator --method explicit_euler --dt 0.002 --duration 1")["error_max"];
  const double e2 = benchJson("--scene oscillator --method explicit_euler --dt 0.001 --duration 1")["error_max"];
  EXPECT_GT(e1 / e2, 1.7);
  EXPECT_LT(e1 / e2, 2.3);
}

TEST_F(SimCli, XpbdByName) {
  // Stable at a step where the explicit methods need the monitor; first order on the
  // oscillator (one home constraint), so it is close but not exact.
  const auto j = benchJson("--scene oscillator --method xpbd --dt 0.01 --duration 1");
  EXPECT_EQ(j["method"], "xpbd");
  EXPECT_EQ(j["stable"], true);
  EXPECT_LT(j["error_max"].get<double>(), 0.6);
  EXPECT_GT(j["error_max"].get<double>(), 1e-6);
}

TEST_F(SimCli, PatchReleaseAndSliver) {
  const auto p = benchJson("--scene patch-release --method symplectic_euler --dt 0.001 --duration 0.02");
  EXPECT_EQ(p["stable"], true);
  EXPECT_EQ(p["steps"], 20);
  EXPECT_GT(p["triangles"].get<int>(), 1000);
  EXPECT_GT(p["error_max"].get<double>(), 0.0);  // not the reference itself
  EXPECT_LT(p["error_max"].get<double>(), 5.0);
  // 10 ms steps on sliver triangles: explicit diverges, implicit does not.
  EXPECT_EQ(benchJson("--scene sliver --method symplectic_euler --dt 0.01 --duration 0.05")["stable"], false);
  EXPECT_EQ(benchJson("--scene sliver --method implicit_euler --dt 0.01 --duration 0.05")["stable"], true);
  // With the monitor on the same explicit run stays finite and counts warnings.
  const auto m = benchJson("--scene sliver --method symplectic_euler --dt 0.01 --duration 0.05 --monitor on");
  EXPECT_GT(m["stability_warnings"].get<int>(), 0);
}

TEST_F(SimCli, ActiveRegionComparison) {
  const auto j = benchJson("--scene patch-release --method symplectic_euler --dt 0.001 --duration 0.05 --active on");
  ASSERT_TRUE(j.contains("active"));
  const auto& a = j["active"];
  EXPECT_GT(a["work_fraction"].get<double>(), 0.0);
  EXPECT_LE(a["work_fraction"].get<double>(), 1.0);
  EXPECT_GE(a["max_difference_mm"].get<double>(), 0.0);
  EXPECT_LT(a["max_difference_mm"].get<double>(), 1.0);
  EXPECT_EQ(a["steps"], 50);
}

TEST_F(SimCli, ModelFileScene) {
  const fs::path obj = dir_ / "box.obj";
  std::ofstream(obj) << "v 0 0 0\nv 10 0 0\nv 10 10 0\nv 0 10 0\nv 0 0 10\nv 10 0 10\nv 10 10 10\nv 0 10 10\n"
                        "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\n"
                        "f 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";
  const auto j = benchJson("--scene " + shellQuote(obj.string()) + " --method verlet --dt 0.0005 --duration 0.01");
  EXPECT_EQ(j["triangles"], 12);
  EXPECT_EQ(j["stable"], true);
}

TEST_F(SimCli, BadInputIsExitCode2) {
  for (const std::string args :
       {"sim bench --scene oscillator --method leapfrog --dt 0.01 --duration 1",
        "sim bench --scene oscillator --method rk4 --duration 1",
        "sim bench --scene oscillator --method rk4 --dt -1 --duration 1",
        "sim bench --scene oscillator --method rk4 --dt abc --duration 1",
        "sim bench --scene /no/such/file.obj --method rk4 --dt 0.01 --duration 1", "sim frobnicate", "sim chart"}) {
    const CommandResult r = cli(args);
    EXPECT_EQ(r.exitCode, 2) << args << ": " << r.err;
    EXPECT_FALSE(r.err.empty()) << args;
    EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "one line: " << r.err;
  }
  const fs::path bad = dir_ / "bad.obj";
  std::ofstream(bad) << "v 0 0 0\nv 1 0 0\nf 1 2 x\n";
  const CommandResult r =
      cli("sim bench --scene " + shellQuote(bad.string()) + " --method rk4 --dt 0.01 --duration 0.1");
  EXPECT_EQ(r.exitCode, 2) << r.err;
  EXPECT_NE(r.err.find("bad.obj:"), std::string::npos) << r.err;
}

TEST_F(SimCli, ChartWritesCsvAndPng) {
  const CommandResult r = cli("sim chart --out " + shellQuote(dir_.string()));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  for (const char* f : {"speed_accuracy.csv", "speed_accuracy.png", "stability.csv", "stability.png"})
    ASSERT_TRUE(fs::exists(dir_ / f)) << f;
  EXPECT_GT(fs::file_size(dir_ / "speed_accuracy.png"), 20000u);
  EXPECT_GT(fs::file_size(dir_ / "stability.png"), 20000u);
  std::ifstream csv(dir_ / "speed_accuracy.csv");
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line.rfind("scene,method,dt_s", 0), 0u);
  int rows = 0, unstable = 0;
  while (std::getline(csv, line)) {
    ++rows;
    unstable += line.find(",false,") != std::string::npos;
  }
  EXPECT_EQ(rows, 3 * 5 * 8);  // scenes × methods × dt ladder
  EXPECT_GT(unstable, 0);      // the ladder goes past the explicit limits
  std::ifstream st(dir_ / "stability.csv");
  std::getline(st, line);
  EXPECT_EQ(line, "sweep,x,method,largest_stable_dt_s,capped");
  rows = 0;
  while (std::getline(st, line)) ++rows;
  EXPECT_EQ(rows, 2 * 7 * 5);
}

}  // namespace
