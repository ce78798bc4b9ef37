// Crash safety: a writer process is killed with SIGKILL at random moments, 50 times; then
// the database is intact and every attempt is either complete or absent.
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <iostream>
#include <random>
#include <set>
#include <sstream>
#include <utility>

#include <gtest/gtest.h>

#include "database/store.h"
#include "tests/database/crash_payload.h"
#include "tests/database/db_test_support.h"

namespace {

using ld::test::Backend;

// Runs the writer and kills it `ms` milliseconds after it is ready (logged in), or after
// it started when `fromStart` (so that some kills land in open and login). Returns what
// it printed.
std::string runAndKill(const std::string& url, int run, int ms, bool fromStart) {
  int fds[2];
  if (::pipe(fds) != 0) return {};
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::dup2(fds[1], 1);
    ::close(fds[0]);
    ::close(fds[1]);
    const std::string r = std::to_string(run);
    ::execl(LD_DB_CRASH_WRITER, LD_DB_CRASH_WRITER, url.c_str(), r.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  ::close(fds[1]);
  std::string out;
  char buf[4096];
  using Clock = std::chrono::steady_clock;
  // Slow machines: a generous wait for "ready", then the random moment.
  auto deadline = Clock::now() + (fromStart ? std::chrono::milliseconds(ms) : std::chrono::milliseconds(30000));
  bool ready = fromStart;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) break;
    pollfd p{fds[0], POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(left)) > 0) {
      const ssize_t n = ::read(fds[0], buf, sizeof buf);
      if (n <= 0) break;  // the writer died by itself
      out.append(buf, std::size_t(n));
      if (!ready && out.find("ready\n") != std::string::npos) {
        ready = true;
        deadline = Clock::now() + std::chrono::milliseconds(ms);
      }
    }
  }
  ::kill(pid, SIGKILL);
  int status = 0;
  ::waitpid(pid, &status, 0);
  for (ssize_t n; (n = ::read(fds[0], buf, sizeof buf)) > 0;) out.append(buf, std::size_t(n));
  ::close(fds[0]);
  if (WIFEXITED(status)) ADD_FAILURE() << "writer exited by itself with " << WEXITSTATUS(status);
  if (!ready) ADD_FAILURE() << "writer was not ready after 30 s";
  return out;
}

class CrashTest : public ::testing::TestWithParam<Backend> {};

TEST_P(CrashTest, KilledWriterLeavesCompleteAttemptsOnly) {
  LD_OPEN_TEST_DB(tdb, GetParam());
  {
    auto store = ld::db::Store::open(tdb.url(), ld::test::fastOptions());
    auto admin = store.createFirstAdmin("admin", "admin-password");
    store.addUser(admin, "writer", ld::db::Role::Resident, "writer-password");
  }
  const unsigned seed = 20260522u;
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> delay(0, 150);  // ms
  std::set<std::pair<int, int>> committed;
  constexpr int kRuns = 50;
  for (int run = 0; run < kRuns; ++run) {
    std::istringstream lines(runAndKill(tdb.url(), run, delay(rng), /*fromStart=*/run % 5 == 4));
    for (std::string line; std::getline(lines, line);) {
      int r = 0, k = 0;
      if (std::sscanf(line.c_str(), "%d %d", &r, &k) == 2) committed.insert({r, k});
    }
  }
  SCOPED_TRACE("seed " + std::to_string(seed));
  ASSERT_GE(committed.size(), 10u) << "the writer hardly wrote anything";

  if (tdb.sqlite()) {
    ld::test::RawDb raw(tdb.url());
    EXPECT_EQ(raw.scalar("PRAGMA integrity_check").toString().toStdString(), "ok");
    EXPECT_EQ(raw.rowCount("PRAGMA foreign_key_check"), 0);
  }
  {
    ld::test::RawDb raw(tdb.url());
    EXPECT_EQ(raw.scalar("SELECT count(*) FROM attempt_samples s LEFT JOIN attempts a ON a.id = s.attempt_id"
                         " WHERE a.id IS NULL")
                  .toInt(),
              0);
    EXPECT_EQ(raw.scalar("SELECT count(*) FROM attempts a LEFT JOIN attempt_samples s ON a.id = s.attempt_id"
                         " WHERE s.attempt_id IS NULL")
                  .toInt(),
              0);
  }
  auto store = ld::db::Store::open(tdb.url(), ld::test::fastOptions());
  auto w = store.login("writer", "writer-password");
  const auto all = store.attempts(w);
  std::set<std::pair<int, int>> present;
  for (const auto& a : all) {
    const int r = a.metrics.at("run").get<int>(), k = a.metrics.at("k").get<int>();
    const auto expect = ld::test::crashAttempt(r, k);
    EXPECT_TRUE(present.insert({r, k}).second) << "attempt " << r << "/" << k << " stored twice";
    EXPECT_EQ(a.startedAt, expect.startedAt);
    EXPECT_DOUBLE_EQ(a.score, expect.score);
    EXPECT_EQ(a.samplesBytes, expect.samples.size());
    EXPECT_TRUE(store.attemptSamples(w, a.id).data == expect.samples)
        << "attempt " << r << "/" << k << ": samples differ";
  }
  for (const auto& c : committed)
    EXPECT_TRUE(present.count(c)) << "committed attempt " << c.first << "/" << c.second << " lost";
  std::cout << "runs " << kRuns << ", attempts reported committed " << committed.size() << ", stored " << present.size()
            << "\n";
  // At most one attempt per run can be committed without its report having been printed.
  EXPECT_LE(present.size(), committed.size() + kRuns);
}

INSTANTIATE_TEST_SUITE_P(Backends, CrashTest, ::testing::Values(Backend::Sqlite, Backend::Postgres),
                         ld::test::backendName);

}  // namespace
