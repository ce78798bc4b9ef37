// lapdissect-cli metrics deviation: the fixed contract of DESIGN.md.
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/run_command.h"

namespace {

// test_support.h needs Eigen, which the CLI tests do not link.
::testing::AssertionResult near(double a, double b, double tol) {
  if (std::abs(a - b) <= tol) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << a << " vs " << b;
}

using ld::test::runCommand;
using ld::test::shellQuote;

std::string writeTemp(const std::string& name, const std::string& text) {
  const auto p = std::filesystem::temp_directory_path() / ("ld_metrics_cli_" + std::to_string(::getpid()) + name);
  std::ofstream(p) << text;
  return p.string();
}

std::string cli() { return shellQuote(LD_CLI); }

TEST(MetricsCli, DeviationOfAParallelOffset) {
  const auto d = writeTemp("d.csv", "x,y,z\n0,0,0\n10,0,0\n");
  const auto a = writeTemp("a.csv", "x,y,z,stop\n0,1.5,0.5,0\n4,1.5,0.5,1\n6,1.5,0.5,0\n10,1.5,0.5,1\n");
  const auto r = runCommand(cli() + " metrics deviation --drawn " + shellQuote(d) + " --cut " + shellQuote(a));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  for (const char* k : {"xy", "yz", "xz", "total"}) ASSERT_TRUE(j.contains(k)) << k;
  EXPECT_TRUE(near(j["xy"].get<double>(), 15.0, 1e-9));
  EXPECT_TRUE(near(j["xz"].get<double>(), 5.0, 1e-9));
  EXPECT_TRUE(near(j["yz"].get<double>(), 0.0, 1e-9));
  EXPECT_TRUE(near(j["total"].get<double>(), 20.0, 1e-9));
}

TEST(MetricsCli, CrossingLobesAdd) {
  const auto d = writeTemp("d2.csv", "x,y,z\n0,0,0\n10,10,0\n");
  const auto a = writeTemp("a2.csv", "x,y,z\n0,10,0\n10,0,0\n");
  const auto r = runCommand(cli() + " metrics deviation --drawn " + shellQuote(d) + " --cut " + shellQuote(a));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_TRUE(near(nlohmann::json::parse(r.out)["xy"].get<double>(), 50.0, 1e-9));
}

TEST(MetricsCli, BadCsvNamesFileAndLine) {
  const auto d = writeTemp("d3.csv", "x,y,z\n0,0,0\n10,0,0\n");
  const auto bad = writeTemp("bad.csv", "x,y,z\n0,0,0\n1,abc,0\n");
  auto r = runCommand(cli() + " metrics deviation --drawn " + shellQuote(d) + " --cut " + shellQuote(bad));
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find(bad + ":3: column y: 'abc' is not a number"), std::string::npos) << r.err;
  const auto noHeader = writeTemp("nh.csv", "0,0,0\n");
  r = runCommand(cli() + " metrics deviation --drawn " + shellQuote(noHeader) + " --cut " + shellQuote(d));
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find(noHeader + ":1: expected the header"), std::string::npos) << r.err;
  const auto badStop = writeTemp("bs.csv", "x,y,z,stop\n0,0,0,2\n");
  r = runCommand(cli() + " metrics deviation --drawn " + shellQuote(badStop) + " --cut " + shellQuote(d));
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find(":2: column stop"), std::string::npos) << r.err;
  r = runCommand(cli() + " metrics deviation --drawn /nonexistent/x.csv --cut " + shellQuote(d));
  EXPECT_EQ(r.exitCode, 2);
  r = runCommand(cli() + " metrics deviation --drawn " + shellQuote(d));
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find("--cut"), std::string::npos);
}

}  // namespace
