// lapdissect-cli db ...: the fixed command-line contract of the trainee store, run on the
// real binary against SQLite files and (one scenario) a throwaway PostgreSQL server.
#include <sys/stat.h>
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

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

class DbCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("ld_dbcli_" + std::to_string(::getpid()) + "_" + std::to_string(std::rand()));
    fs::create_directories(dir_);
    path_ = dir_ / "store.db";
    url_ = "sqlite://" + path_.string();
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Minimal Argon2 cost for new accounts (many are made here); one test keeps the real one.
  CommandResult db(const std::string& args, const std::string& stdinText = "") const {
    return runCommand(std::string(fastHash_ ? "LAPDISSECT_INSECURE_FAST_HASH=1 " : "") + LD_CLI + " db " + args,
                      stdinText);
  }
  CommandResult dbAt(const std::string& url, const std::string& args, const std::string& stdinText = "") const {
    return db(args + " --db " + shellQuote(url), stdinText);
  }
  static nlohmann::json json(const CommandResult& r) {
    auto j = nlohmann::json::parse(r.out, nullptr, false);
    EXPECT_FALSE(j.is_discarded()) << "stdout is not JSON: " << r.out << " / stderr: " << r.err;
    return j;
  }
  // admin "boss", director "dora", resident "kim" and "lee".
  void populate(const std::string& url) const {
    auto r = dbAt(url, "init --admin boss", "boss-password\n");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    for (auto [name, role] : {std::pair{"dora", "director"}, {"kim", "resident"}, {"lee", "resident"}}) {
      r = dbAt(url, std::string("user add --as boss --name ") + name + " --role " + role,
               "boss-password\n" + std::string(name) + "-password\n");
      ASSERT_EQ(r.exitCode, 0) << r.err;
      EXPECT_EQ(json(r), (nlohmann::json{{"user", name}, {"role", role}}));
    }
  }
  void record(const std::string& url, const std::string& who, const std::string& task, double score) const {
    const fs::path f = dir_ / "attempt.json";
    std::ofstream(f) << nlohmann::json{{"task_id", task},
                                       {"task_version", 1},
                                       {"started_at_ms", 1780000000000},
                                       {"ended_at_ms", 1780000042000},
                                       {"score", score},
                                       {"passed", score > 50},
                                       {"metrics", {{"deviation", {{"total", 3.25}}}, {"total_time_s", 42}}}}
                            .dump();
    const auto r = dbAt(url, "record --as " + who + " --attempt " + shellQuote(f.string()), who + "-password\n");
    ASSERT_EQ(r.exitCode, 0) << r.err;
  }

  fs::path dir_, path_;
  std::string url_;
  bool fastHash_ = true;
};

TEST_F(DbCli, InitCreatesTheAdministratorOnceAndAPrivateFile) {
  fastHash_ = false;
  auto r = dbAt(url_, "init --admin boss", "boss-password\n");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto j = json(r);
  EXPECT_GE(j.at("schema_version").get<int>(), 2);
  EXPECT_EQ(j.at("created"), true);
  struct stat st {};
  ASSERT_EQ(::stat(path_.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  // Again, with another name: migrates, no second administrator.
  r = dbAt(url_, "init --admin mallory", "mallory-password\n");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(json(r).at("created"), false);
  EXPECT_EQ(json(r).at("schema_version"), j.at("schema_version"));
  r = dbAt(url_, "login --name mallory", "mallory-password\n");
  EXPECT_EQ(r.exitCode, 3);
  r = dbAt(url_, "login --name boss", "boss-password\n");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(json(r), (nlohmann::json{{"user", "boss"}, {"role", "admin"}}));
  // A plain path reaches the same file.
  EXPECT_EQ(db("login --name boss --db " + shellQuote(path_.string()), "boss-password\n").exitCode, 0);
  // The hash is Argon2id; no password is anywhere in the files.
  for (const auto& e : fs::directory_iterator(dir_)) {
    const std::string bytes = slurp(e.path());
    EXPECT_EQ(bytes.find("boss-password"), std::string::npos) << e.path();
    EXPECT_EQ(bytes.find("mallory-password"), std::string::npos) << e.path();
  }
  // libsodium's interactive cost: 64 MiB, 2 passes.
  EXPECT_NE(slurp(path_).find("$argon2id$v=19$m=65536,t=2,p=1$"), std::string::npos);
}

TEST_F(DbCli, UserAddNeedsAnAdministrator) {
  populate(url_);
  auto r = dbAt(url_, "user add --as dora --name eve --role resident", "dora-password\neve-password\n");
  EXPECT_EQ(r.exitCode, 4);
  EXPECT_NE(r.err.find("not permitted"), std::string::npos) << r.err;
  r = dbAt(url_, "user add --as kim --name eve --role admin", "kim-password\neve-password\n");
  EXPECT_EQ(r.exitCode, 4);
  r = dbAt(url_, "user add --as boss --name eve --role resident", "wrong-password\neve-password\n");
  EXPECT_EQ(r.exitCode, 3);
  EXPECT_NE(r.err.find("invalid credentials"), std::string::npos) << r.err;
  r = dbAt(url_, "user add --as boss --name eve --role emperor", "boss-password\neve-password\n");
  EXPECT_EQ(r.exitCode, 2);
  r = dbAt(url_, "user add --as boss --name kim --role resident", "boss-password\nkim-password2\n");
  EXPECT_EQ(r.exitCode, 2) << "a second kim";
  r = dbAt(url_, "user add --as boss --name eve --role resident", "boss-password\n");
  EXPECT_EQ(r.exitCode, 2) << "no password line for the new user";
  EXPECT_EQ(dbAt(url_, "login --name eve", "eve-password\n").exitCode, 3);
  // Names are names, whatever SQL they contain.
  const std::string evil = "x'); DROP TABLE users;--";
  r = dbAt(url_, "user add --as boss --role resident --name " + shellQuote(evil), "boss-password\nevil-password\n");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  r = dbAt(url_, "login --name " + shellQuote(evil), "evil-password\n");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(json(r).at("user"), evil);
  EXPECT_EQ(dbAt(url_, "login --name kim", "kim-password\n").exitCode, 0);
}

TEST_F(DbCli, LoginLocksAfterFiveFailures) {
  populate(url_);
  for (int i = 0; i < 5; ++i) {
    const auto r = dbAt(url_, "login --name kim", "guess-" + std::to_string(i) + "\n");
    EXPECT_EQ(r.exitCode, 3);
    EXPECT_NE(r.err.find("invalid credentials"), std::string::npos) << r.err;
    EXPECT_TRUE(r.out.empty());
  }
  const auto r = dbAt(url_, "login --name kim", "kim-password\n");
  EXPECT_EQ(r.exitCode, 3);
  EXPECT_NE(r.err.find("locked"), std::string::npos) << r.err;
  EXPECT_EQ(dbAt(url_, "login --name lee", "lee-password\n").exitCode, 0);
  EXPECT_EQ(dbAt(url_, "login --name nobody", "kim-password\n").exitCode, 3);
}

TEST_F(DbCli, AttemptsAndExportFollowTheRoles) {
  populate(url_);
  record(url_, "kim", "cut-line", 75);
  record(url_, "lee", "cut-circle", 25);
  auto r = dbAt(url_, "attempts --as kim", "kim-password\n");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  auto j = json(r);
  ASSERT_TRUE(j.is_array());
  ASSERT_EQ(j.size(), 1u);
  EXPECT_EQ(j[0].at("trainee"), "kim");
  EXPECT_EQ(j[0].at("task_id"), "cut-line");
  EXPECT_EQ(j[0].at("score"), 75.0);
  EXPECT_EQ(j[0].at("metrics").at("deviation").at("total"), 3.25);

  r = dbAt(url_, "attempts --as kim --trainee lee", "kim-password\n");
  EXPECT_EQ(r.exitCode, 4);
  EXPECT_NE(r.err.find("not permitted"), std::string::npos);
  EXPECT_TRUE(r.out.empty());
  r = dbAt(url_, "attempts --as kim --trainee nobody", "kim-password\n");
  EXPECT_EQ(r.exitCode, 4) << "a resident learns nothing about other names";
  r = dbAt(url_, "attempts --as dora --trainee lee", "dora-password\n");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  ASSERT_EQ(json(r).size(), 1u);
  EXPECT_EQ(json(r)[0].at("trainee"), "lee");
  r = dbAt(url_, "attempts --as dora", "dora-password\n");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(json(r).size(), 2u);
  r = dbAt(url_, "attempts --as dora", "wrong-password\n");
  EXPECT_EQ(r.exitCode, 3);

  const fs::path csv = dir_ / "out.csv";
  r = dbAt(url_, "export --as kim --trainee lee --csv " + shellQuote(csv.string()), "kim-password\n");
  EXPECT_EQ(r.exitCode, 4);
  EXPECT_FALSE(fs::exists(csv));
  r = dbAt(url_, "export --as dora --csv " + shellQuote(csv.string()), "dora-password\n");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(json(r).at("rows"), 2);
  const std::string text = slurp(csv);
  EXPECT_EQ(text.rfind("attempt_id,trainee,task_id,", 0), 0u) << text;
  EXPECT_NE(text.find("metrics.deviation.total"), std::string::npos);
  EXPECT_NE(text.find(",lee,cut-circle,"), std::string::npos);
  r = dbAt(url_, "export --as kim --csv " + shellQuote(csv.string()), "kim-password\n");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(slurp(csv).find(",lee,"), std::string::npos);
  struct stat st {};
  ASSERT_EQ(::stat(csv.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0077, 0u) << "the export is readable by others";
}

TEST_F(DbCli, BackupIsAWorkingCopy) {
  populate(url_);
  record(url_, "kim", "cut-line", 60);
  const fs::path out = dir_ / "copy.db";
  auto r = dbAt(url_, "backup --out " + shellQuote(out.string()));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_GT(json(r).at("bytes").get<long>(), 0);
  r = dbAt("sqlite://" + out.string(), "attempts --as kim", "kim-password\n");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(json(r).size(), 1u);
  r = dbAt(url_, "backup --out " + shellQuote(path_.string()));
  EXPECT_EQ(r.exitCode, 2) << "backup onto the database itself";
}

TEST_F(DbCli, BadInputIsRefusedAndDamagedFilesAreKept) {
  EXPECT_EQ(dbAt("mysql://u@h/db", "login --name x", "x\n").exitCode, 2);
  EXPECT_EQ(dbAt("sqlite://relative.db", "login --name x", "x\n").exitCode, 2);
  EXPECT_EQ(dbAt(url_, "frobnicate").exitCode, 2);
  populate(url_);
  EXPECT_EQ(dbAt(url_, "login --name kim").exitCode, 2) << "no password on stdin";
  // Truncated: refused, named, not overwritten.
  fs::resize_file(path_, fs::file_size(path_) / 2);
  const std::string before = slurp(path_);
  auto r = dbAt(url_, "init --admin boss", "boss-password\n");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find(path_.string()), std::string::npos) << r.err;
  EXPECT_EQ(slurp(path_), before);
  // Not a database at all.
  { std::ofstream(path_, std::ios::trunc) << std::string(4096, 'z'); }
  r = dbAt(url_, "login --name kim", "kim-password\n");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.err.find(path_.string()), std::string::npos) << r.err;
  EXPECT_EQ(slurp(path_), std::string(4096, 'z'));
}

// The same commands against a real PostgreSQL server started for this test.
TEST_F(DbCli, WorksAgainstPostgreSQL) {
  const std::string script = std::string(LD_SOURCE_DIR) + "/scripts/pg-test-server.sh";
  const fs::path pgdir = fs::path("/tmp") / ("ld-pgcli-" + std::to_string(::getpid()));
  const auto start = runCommand(shellQuote(script) + " start " + shellQuote(pgdir.string()));
  struct Stop {
    std::string cmd;
    ~Stop() { runCommand(cmd); }
  } stop{shellQuote(script) + " stop " + shellQuote(pgdir.string())};
  if (fs::exists(pgdir / "unavailable"))
    GTEST_SKIP() << "PostgreSQL is not available: " << slurp(pgdir / "unavailable");
  ASSERT_EQ(start.exitCode, 0) << start.err;
  std::string url = start.out;
  while (!url.empty() && (url.back() == '\n' || url.back() == '\r')) url.pop_back();
  ASSERT_EQ(url.rfind("postgresql://", 0), 0u) << url;
  populate(url);
  record(url, "kim", "cut-line", 80);
  auto r = dbAt(url, "attempts --as kim --trainee lee", "kim-password\n");
  EXPECT_EQ(r.exitCode, 4);
  r = dbAt(url, "attempts --as dora --trainee kim", "dora-password\n");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  ASSERT_EQ(json(r).size(), 1u);
  EXPECT_EQ(json(r)[0].at("score"), 80.0);
  r = dbAt(url, "init --admin other", "other-password\n");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(json(r).at("created"), false);
  const fs::path csv = dir_ / "pg.csv";
  EXPECT_EQ(dbAt(url, "export --as dora --csv " + shellQuote(csv.string()), "dora-password\n").exitCode, 0);
  EXPECT_NE(slurp(csv).find(",kim,cut-line,"), std::string::npos);
  EXPECT_EQ(dbAt(url, "backup --out " + shellQuote((dir_ / "pg.db").string())).exitCode, 2) << "use pg_dump";
  EXPECT_EQ(dbAt(url, "login --name kim", "nope-nope\n").exitCode, 3);
}

}  // namespace
