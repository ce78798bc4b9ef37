// The trainee store, run against SQLite and against a real PostgreSQL server.
#include "database/store.h"

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "database/schema.h"
#include "tests/database/db_test_support.h"

namespace {

using namespace ld::db;
using ld::test::Backend;
using ld::test::fastOptions;
using ld::test::RawDb;

constexpr TimeMs kT0 = 1'780'000'000'000;  // 2026

AttemptRecord makeAttempt(const std::string& task, TimeMs start, double score, double timeS, double deviation,
                          bool completed = true) {
  AttemptRecord a;
  a.taskId = task;
  a.taskVersion = 2;
  a.startedAt = start;
  a.endedAt = start + static_cast<TimeMs>(timeS * 1000);
  a.completed = completed;
  a.device = "scripted";
  a.score = score;
  a.passed = score >= 50;
  a.metrics = {
      {"deviation", {{"xy", deviation / 2}, {"yz", deviation / 4}, {"xz", deviation / 4}, {"total", deviation}}},
      {"contact_time", {{"mean_s", 0.5}, {"max_s", 1.25}, {"total_s", 10.0}}},
      {"contact_breaks", 3},
      {"path_breaks", 1},
      {"total_time_s", timeS},
      {"score", score},
      {"passed", score >= 50}};
  std::string s = "t,hand,tool,tip_x,tip_y,tip_z,dir_x,dir_y,dir_z,up_x,up_y,up_z,jaw,pedal\n";
  for (int i = 0; i < 200; ++i) s += std::to_string(i * 0.001) + ",right,hook,1,2,3,0,0,-1,0,1,0,0,1\n";
  a.samples = s;
  return a;
}

class StoreTest : public ::testing::TestWithParam<Backend> {
 protected:
  TimeMs now_ = kT0;
  Options opts() {
    return fastOptions([this] { return now_; });
  }
};

// A store with one user of each role (passwords are "<name>-password").
struct Cast {
  Store store;
  Session admin, director, author, resident, resident2;
};

Cast makeCast(const std::string& url, const Options& o) {
  Store st = Store::open(url, o);
  Session admin = st.createFirstAdmin("admin", "admin-password");
  st.addUser(admin, "director", Role::Director, "director-password");
  st.addUser(admin, "author", Role::Author, "author-password");
  st.addUser(admin, "resident", Role::Resident, "resident-password");
  st.addUser(admin, "resident2", Role::Resident, "resident2-password");
  Session d = st.login("director", "director-password");
  Session au = st.login("author", "author-password");
  Session r = st.login("resident", "resident-password");
  Session r2 = st.login("resident2", "resident2-password");
  return Cast{std::move(st), admin, d, au, r, r2};
}

TEST_P(StoreTest, MigratesAnEmptyDatabaseToTheLatestVersion) {
  LD_OPEN_TEST_DB(tdb, GetParam());
  {
    Store st = Store::open(tdb.url(), opts());
    EXPECT_EQ(st.schemaVersion(), Store::latestSchemaVersion());
    EXPECT_GE(Store::latestSchemaVersion(), 2);
    EXPECT_FALSE(st.hasUsers());
  }
  RawDb raw(tdb.url());
  EXPECT_EQ(raw.scalar("SELECT version FROM ld_schema").toInt(), Store::latestSchemaVersion());
  for (const char* t : {"users", "tasks", "assignments", "attempts", "attempt_samples", "audit_log"})
    EXPECT_EQ(raw.scalar(std::string("SELECT count(*) FROM ") + t).toInt(), std::string(t) == "audit_log" ? 1 : 0) << t;
  // Opening again does not migrate twice.
  Store again = Store::open(tdb.url(), opts());
  EXPECT_EQ(again.schemaVersion(), Store::latestSchemaVersion());
}

TEST_P(StoreTest, MigratesFromEveryEarlierVersionKeepingTheData) {
  for (int v = 1; v < Store::latestSchemaVersion(); ++v) {
    SCOPED_TRACE("from version " + std::to_string(v));
    LD_OPEN_TEST_DB(tdb, GetParam());
    {
      Options o = opts();
      o.migrateTo = v;
      Store old = Store::open(tdb.url(), o);
      ASSERT_EQ(old.schemaVersion(), v);
      Session admin = old.createFirstAdmin("admin", "admin-password");
      old.addUser(admin, "resident", Role::Resident, "resident-password");
      Session r = old.login("resident", "resident-password");
      old.recordAttempt(r, makeAttempt("cut-circle", kT0, 70, 42.5, 12.25));
      old.recordAttempt(r, makeAttempt("cut-line", kT0 + 1000, 30, 80, 99.5));
    }
    Store st = Store::open(tdb.url(), opts());
    EXPECT_EQ(st.schemaVersion(), Store::latestSchemaVersion());
    Session r = st.login("resident", "resident-password");
    const auto a = st.attempts(r);
    ASSERT_EQ(a.size(), 2u);
    EXPECT_EQ(a[0].taskId, "cut-circle");
    EXPECT_DOUBLE_EQ(a[0].durationS, 42.5);
    ASSERT_TRUE(a[0].deviationTotal.has_value());  // filled by the v2 migration from the metrics
    EXPECT_DOUBLE_EQ(*a[0].deviationTotal, 12.25);
    EXPECT_DOUBLE_EQ(*a[1].deviationTotal, 99.5);
    EXPECT_EQ(st.attemptSamples(r, a[0].id).data, makeAttempt("x", 0, 0, 1, 0).samples);
    RawDb raw(tdb.url());
    EXPECT_DOUBLE_EQ(raw.scalar("SELECT deviation_total FROM attempts WHERE task_id = 'cut-line'").toDouble(), 99.5);
  }
}

// Several workstations (processes) starting at once on a new database: one migrates.
TEST_P(StoreTest, ConcurrentFirstOpensMigrateOnce) {
  LD_OPEN_TEST_DB(tdb, GetParam());
  std::vector<pid_t> kids;
  for (int i = 0; i < 4; ++i) {
    const pid_t pid = ::fork();
    if (pid == 0) {
      int rc = 0;
      try {
        Store st = Store::open(tdb.url(), fastOptions());
        rc = st.schemaVersion() == Store::latestSchemaVersion() ? 0 : 3;
      } catch (const std::exception& e) {
        std::fprintf(stderr, "child %d: %s\n", i, e.what());
        rc = 2;
      }
      std::fflush(stderr);
      ::_exit(rc);
    }
    kids.push_back(pid);
  }
  for (pid_t k : kids) {
    int status = 0;
    ::waitpid(k, &status, 0);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "a concurrent open failed";
  }
  RawDb raw(tdb.url());
  EXPECT_EQ(raw.scalar("SELECT count(*) FROM audit_log WHERE action = 'schema.migrate'").toInt(), 1);
  EXPECT_EQ(raw.scalar("SELECT count(*) FROM ld_schema").toInt(), 1);
}

TEST_P(StoreTest, RefusesANewerSchemaAndLeavesItUntouched) {
  LD_OPEN_TEST_DB(tdb, GetParam());
  {
    Store st = Store::open(tdb.url(), opts());
    st.createFirstAdmin("admin", "admin-password");
  }
  {
    RawDb raw(tdb.url());
    raw.exec("UPDATE ld_schema SET version = " + std::to_string(Store::latestSchemaVersion() + 1));
  }
  const std::string before = tdb.sqlite() ? ld::test::slurpFile(tdb.path()) : "";
  try {
    Store::open(tdb.url(), opts());
    FAIL() << "a newer schema was accepted";
  } catch (const SchemaTooNew& e) {
    EXPECT_NE(std::string(e.what()).find("newer"), std::string::npos) << e.what();
  }
  RawDb raw(tdb.url());
  EXPECT_EQ(raw.scalar("SELECT version FROM ld_schema").toInt(), Store::latestSchemaVersion() + 1);
  EXPECT_EQ(raw.scalar("SELECT count(*) FROM audit_log").toInt(), 2);  // migrate + first admin, nothing more
  if (tdb.sqlite()) {
    EXPECT_EQ(ld::test::slurpFile(tdb.path()), before);
  }
}

TEST_P(StoreTest, RefusesADatabaseThatIsNotOurs) {
  LD_OPEN_TEST_DB(tdb, GetParam());
  {
    RawDb raw(tdb.url());
    raw.exec("CREATE TABLE payroll (id INTEGER, amount INTEGER)");
  }
  EXPECT_THROW(Store::open(tdb.url(), opts()), CorruptDatabase);
  RawDb raw(tdb.url());
  EXPECT_EQ(raw.scalar("SELECT count(*) FROM payroll").toInt(), 0);
}

TEST_P(StoreTest, FirstAdministratorOnlyOnce) {
  LD_OPEN_TEST_DB(tdb, GetParam());
  Store st = Store::open(tdb.url(), opts());
  Session a = st.createFirstAdmin("root", "root-password");
  EXPECT_EQ(a.role(), Role::Admin);
  EXPECT_THROW(st.createFirstAdmin("other", "other-password"), AlreadyExists);
  EXPECT_THROW(st.login("other", "other-password"), AuthFailed);
  EXPECT_THROW(st.createFirstAdmin("x", "short"), InvalidArgument);
}

// Every API call, for every role: allowed ones succeed, the others throw NotPermitted.
TEST_P(StoreTest, EnforcesRolesOnEveryCall) {
  LD_OPEN_TEST_DB(tdb, GetParam());
  Cast c = makeCast(tdb.url(), opts());
  const std::int64_t otherAttempt = c.store.recordAttempt(c.resident2, makeAttempt("cut-line", kT0, 60, 30, 5));
  int counter = 0;
  using R = Role;
  struct Case {
    std::string name;
    std::set<Role> allowed;
    std::function<void(const Session&)> call;
  };
  const std::vector<Case> cases = {
      {"addUser",
       {R::Admin},
       [&](const Session& s) { c.store.addUser(s, "new" + std::to_string(++counter), R::Resident, "password-123"); }},
      {"setRole", {R::Admin}, [&](const Session& s) { c.store.setRole(s, "resident2", R::Resident); }},
      {"setDisabled", {R::Admin}, [&](const Session& s) { c.store.setDisabled(s, "resident2", false); }},
      {"unlock", {R::Admin}, [&](const Session& s) { c.store.unlock(s, "resident2"); }},
      {"setPassword(other)",
       {R::Admin},
       [&](const Session& s) { c.store.setPassword(s, "resident2", "resident2-password"); }},
      {"users", {R::Director, R::Admin}, [&](const Session& s) { (void)c.store.users(s); }},
      {"saveTask",
       {R::Author, R::Admin},
       [&](const Session& s) {
         c.store.saveTask(s, {"cut-line", 1, {{"title", "Line"}}, "", 0});
       }},
      {"assign",
       {R::Director, R::Admin},
       [&](const Session& s) { c.store.assign(s, "resident2", "cut-line", kT0 + 86'400'000); }},
      {"dueItems(other)",
       {R::Director, R::Admin},
       [&](const Session& s) { (void)c.store.dueItems(s, std::string("resident2")); }},
      {"dueItems(all)", {R::Director, R::Admin}, [&](const Session& s) { (void)c.store.dueItems(s, {}, true); }},
      {"attempts(other)",
       {R::Director, R::Admin},
       [&](const Session& s) {
         AttemptFilter f;
         f.trainee = "resident2";
         (void)c.store.attempts(s, f);
       }},
      {"attempts(all)",
       {R::Director, R::Admin},
       [&](const Session& s) {
         AttemptFilter f;
         f.allTrainees = true;
         (void)c.store.attempts(s, f);
       }},
      {"attemptSamples(other)",
       {R::Director, R::Admin},
       [&](const Session& s) { (void)c.store.attemptSamples(s, otherAttempt); }},
      {"exportCsv(other)",
       {R::Director, R::Admin},
       [&](const Session& s) {
         AttemptFilter f;
         f.trainee = "resident2";
         (void)c.store.exportCsv(s, f);
       }},
      {"cohortStats", {R::Director, R::Admin}, [&](const Session& s) { (void)c.store.cohortStats(s); }},
      {"auditLog", {R::Admin}, [&](const Session& s) { (void)c.store.auditLog(s); }},
      // Everyone may do these for themselves.
      {"recordAttempt(own)",
       {R::Resident, R::Director, R::Author, R::Admin},
       [&](const Session& s) { c.store.recordAttempt(s, makeAttempt("cut-line", kT0, 50, 10, 1)); }},
      {"attempts(own)",
       {R::Resident, R::Director, R::Author, R::Admin},
       [&](const Session& s) { (void)c.store.attempts(s); }},
      {"dueItems(own)",
       {R::Resident, R::Director, R::Author, R::Admin},
       [&](const Session& s) { (void)c.store.dueItems(s); }},
      {"exportCsv(own)",
       {R::Resident, R::Director, R::Author, R::Admin},
       [&](const Session& s) { (void)c.store.exportCsv(s); }},
      {"setPassword(own)",
       {R::Resident, R::Director, R::Author, R::Admin},
       [&](const Session& s) { c.store.setPassword(s, s.name(), s.name() + "-password"); }},
      {"tasks", {R::Resident, R::Director, R::Author, R::Admin}, [&](const Session& s) { (void)c.store.tasks(s); }},
  };
  const std::vector<const Session*> sessions = {&c.resident, &c.director, &c.author, &c.admin};
  for (const auto& k : cases) {
    for (const Session* s : sessions) {
      SCOPED_TRACE(k.name + " as " + toString(s->role()));
      if (k.allowed.count(s->role()))
        EXPECT_NO_THROW(k.call(*s));
      else
        EXPECT_THROW(k.call(*s), NotPermitted);
    }
  }
  // A resident never sees another resident's rows through the own-attempts view.
  for (const auto& a : c.store.attempts(c.resident)) EXPECT_EQ(a.trainee, "resident");
}

TEST_P(StoreTest, RoleChangesAndDisablingTakeEffectOnTheNextCall) {
  LD_OPEN_TEST_DB(tdb, GetParam());
  Cast c = makeCast(tdb.url(), opts());
  AttemptFilter all;
  all.allTrainees = true;
  EXPECT_THROW(c.store.attempts(c.resident, all), NotPermitted);
  c.store.setRole(c.admin, "resident", Role::Director);
  EXPECT_NO_THROW(c.store.attempts(c.resident, all));
  c.store.setDisabled(c.admin, "resident", true);
  EXPECT_THROW(c.store.attempts(c.resident), NotPermitted);
  EXPECT_THROW(c.store.login("resident", "resident-password"), AuthFailed);
  c.store.setDisabled(c.admin, "resident", false);
  EXPECT_NO_THROW(c.store.login("resident", "resident-password"));
  // A session of another store (another open of the same file) is refused.
  Store other = Store::open(tdb.url(), opts());
  EXPECT_THROW(other.attempts(c.admin), NotPermitted);
}

TEST_P(StoreTest, SqlInjectionInNamesIsStoredAsNames) {
  LD_OPEN_TEST_DB(tdb, GetParam());
  Cast c = makeCast(tdb.url(), opts());
  const std::vector<std::string> evil = {"Robert'); DROP TABLE users;--", "x' OR '1'='1",
                                         "\"; DELETE FROM attempts; --", "admin'--",
                                         "a\\'; UPDATE users SET role='admin' WHERE '1'='1"};
  for (const auto& n : evil) c.store.addUser(c.admin, n, Role::Resident, "evil-password");
  for (const auto& n : evil) {
    Session s = c.store.login(n, "evil-password");
    EXPECT_EQ(s.name(), n);
    EXPECT_EQ(s.role(), Role::Resident);
    c.store.recordAttempt(s, makeAttempt(n, kT0, 10, 5, 1));  // as a task id too
    const auto mine = c.store.attempts(s);
    ASSERT_EQ(mine.size(), 1u);
    EXPECT_EQ(mine[0].taskId, n);
    EXPECT_EQ(mine[0].trainee, n);
  }
  EXPECT_THROW(c.store.login("x' OR '1'='1", "resident-password"), AuthFailed);
  EXPECT_THROW(c.store.login("admin'--", "admin-password"), AuthFailed);
  const auto users = c.store.users(c.admin);
  EXPECT_EQ(users.size(), 5u + evil.size());
  for (const auto& u : users)
    if (u.name != "admin") {
      EXPECT_NE(u.role, Role::Admin) << u.name;
    }
  AttemptFilter f;
  f.trainee = "nobody' OR '1'='1";
  EXPECT_THROW(c.store.attempts(c.director, f), NotFound);
  EXPECT_EQ(c.store.attempts(c.director, AttemptFilter{std::nullopt, std::nullopt, true}).size(), evil.size());
}

TEST_P(StoreTest, StoresArgon2idHashesAndNoPassword) {
  LD_OPEN_TEST_DB(tdb, GetParam());
  const std::string secret = "Zebra-Correct-Horse-91";
  {
    Store st = Store::open(tdb.url(), opts());
    Session a = st.createFirstAdmin("admin", "admin-password");
    st.addUser(a, "kim", Role::Resident, secret);
    Session k = st.login("kim", secret);
    st.setPassword(k, "kim", secret + "!");
    EXPECT_THROW(st.login("kim", secret), AuthFailed);
    EXPECT_NO_THROW(st.login("kim", secret + "!"));
  }
  RawDb raw(tdb.url());
  const std::string hash = raw.scalar("SELECT password_hash FROM users WHERE name = 'kim'").toString().toStdString();
  EXPECT_EQ(hash.rfind("$argon2id$", 0), 0u) << hash;
  EXPECT_EQ(hash.find(secret), std::string::npos);
  if (!tdb.sqlite() && std::getenv("LD_PG_DIR")) {
    // Every file of the server (data, WAL, log) after a checkpoint.
    raw.exec("CHECKPOINT");
    std::size_t files = 0;
    bool sawHash = false;
    std::vector<std::string> leaks;
    // The server is shared with tests running beside this one, which create and drop
    // databases: a directory can vanish under the walk, so the walk is retried whole.
    for (int attempt = 0; attempt < 5; ++attempt) {
      files = 0;
      sawHash = false;
      leaks.clear();
      try {
        for (const auto& e : std::filesystem::recursive_directory_iterator(std::getenv("LD_PG_DIR"))) {
          std::error_code ec;
          if (!e.is_regular_file(ec)) continue;
          ++files;
          const std::string bytes = ld::test::slurpFile(e.path());
          if (bytes.find(secret) != std::string::npos) leaks.push_back(e.path().string());
          sawHash |= bytes.find(hash) != std::string::npos;
        }
        break;
      } catch (const std::filesystem::filesystem_error&) {
        continue;
      }
    }
    EXPECT_TRUE(leaks.empty()) << "the password is in " << (leaks.empty() ? "" : leaks.front());
    EXPECT_GT(files, 100u);
    EXPECT_TRUE(sawHash) << "the scan did not reach the table data";
  }
  if (tdb.sqlite()) {
    // Every byte on disk: the file and any journal next to it.
    bool sawHash = false;
    for (const auto& e : std::filesystem::directory_iterator(tdb.dir())) {
      const std::string bytes = ld::test::slurpFile(e.path());
      EXPECT_EQ(bytes.find(secret), std::string::npos) << e.path();
      EXPECT_EQ(bytes.find("admin-password"), std::string::npos) << e.path();
      sawHash |= bytes.find(hash) != std::string::npos;
    }
    EXPECT_TRUE(sawHash) << "the scan did not reach the table data";
  }
}

TEST_P(StoreTest, LocksAfterFiveFailuresAndReleasesAfterFifteenMinutes) {
  LD_OPEN_TEST_DB(tdb, GetParam());
  Cast c = makeCast(tdb.url(), opts());
  for (int i = 0; i < 5; ++i) {
    try {
      c.store.login("resident", "wrong-password");
      FAIL();
    } catch (const AuthFailed& e) {
      EXPECT_FALSE(e.locked()) << "failure " << i + 1;
      EXPECT_STREQ(e.what(), "invalid credentials");
    }
  }
  try {
    c.store.login("resident", "resident-password");  // right password, but locked
    FAIL();
  } catch (const AuthFailed& e) {
    EXPECT_TRUE(e.locked());
    EXPECT_STREQ(e.what(), "locked");
  }
  now_ += 15 * 60 * 1000 - 1;
  EXPECT_THROW(c.store.login("resident", "resident-password"), AuthFailed);
  now_ += 1;
  EXPECT_NO_THROW(c.store.login("resident", "resident-password"));
  // The count starts again after a success: four failures do not lock.
  for (int i = 0; i < 4; ++i) EXPECT_THROW(c.store.login("resident", "nope-nope"), AuthFailed);
  EXPECT_NO_THROW(c.store.login("resident", "resident-password"));
  // Another user is not affected, and an admin can unlock early.
  for (int i = 0; i < 5; ++i) EXPECT_THROW(c.store.login("resident2", "nope-nope"), AuthFailed);
  EXPECT_NO_THROW(c.store.login("director", "director-password"));
  EXPECT_THROW(c.store.login("resident2", "resident2-password"), AuthFailed);
  c.store.unlock(c.admin, "resident2");
  EXPECT_NO_THROW(c.store.login("resident2", "resident2-password"));
  bool sawLock = false;
  for (const auto& e : c.store.auditLog(c.admin)) sawLock |= e.action == "user.locked" && e.target == "resident2";
  EXPECT_TRUE(sawLock);
  EXPECT_THROW(c.store.login("nobody", "resident-password"), AuthFailed);
}

TEST_P(StoreTest, AttemptRoundTripWithCompressedSamples) {
  LD_OPEN_TEST_DB(tdb, GetParam());
  Cast c = makeCast(tdb.url(), opts());
  AttemptRecord a = makeAttempt("cut-circle", kT0, 77.5, 61.25, 14.5, false);
  a.device = "phantom omni";
  const std::int64_t id = c.store.recordAttempt(c.resident, a);
  const auto got = c.store.attempts(c.resident);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].id, id);
  EXPECT_EQ(got[0].taskVersion, 2);
  EXPECT_EQ(got[0].startedAt, a.startedAt);
  EXPECT_EQ(got[0].endedAt, a.endedAt);
  EXPECT_FALSE(got[0].completed);
  EXPECT_EQ(got[0].device, "phantom omni");
  EXPECT_DOUBLE_EQ(got[0].score, 77.5);
  EXPECT_TRUE(got[0].passed);
  EXPECT_EQ(got[0].metrics, a.metrics);
  EXPECT_EQ(got[0].samplesBytes, a.samples.size());
  const Samples s = c.store.attemptSamples(c.resident, id);
  EXPECT_EQ(s.format, "trajectory-csv");
  EXPECT_EQ(s.data, a.samples);
  RawDb raw(tdb.url());
  const auto stored = raw.scalar("SELECT data FROM attempt_samples").toByteArray();
  EXPECT_LT(stored.size(), qsizetype(a.samples.size()) / 4) << "samples are not compressed";
  EXPECT_THROW(c.store.recordAttempt(c.resident, makeAttempt("", kT0, 1, 1, 1)), InvalidArgument);
  AttemptRecord backwards = a;
  backwards.endedAt = a.startedAt - 1;
  EXPECT_THROW(c.store.recordAttempt(c.resident, backwards), InvalidArgument);
}

// A failure in the middle of writing an attempt leaves nothing behind.
TEST_P(StoreTest, AnAttemptIsWrittenWhollyOrNotAtAll) {
  LD_OPEN_TEST_DB(tdb, GetParam());
  Cast c = makeCast(tdb.url(), opts());
  c.store.recordAttempt(c.resident, makeAttempt("cut-line", kT0, 50, 10, 1));
  {
    RawDb raw(tdb.url());
    if (tdb.sqlite()) {
      raw.exec(
          "CREATE TRIGGER no_samples BEFORE INSERT ON attempt_samples BEGIN SELECT RAISE(ABORT, 'disk full'); END");
    } else {
      raw.exec(
          "CREATE FUNCTION no_samples() RETURNS trigger AS $$ BEGIN RAISE EXCEPTION 'disk full'; END $$ LANGUAGE "
          "plpgsql");
      raw.exec("CREATE TRIGGER no_samples BEFORE INSERT ON attempt_samples FOR EACH ROW EXECUTE FUNCTION no_samples()");
    }
  }
  EXPECT_THROW(c.store.recordAttempt(c.resident, makeAttempt("cut-line", kT0 + 5000, 60, 10, 1)), DbError);
  RawDb raw(tdb.url());
  EXPECT_EQ(raw.scalar("SELECT count(*) FROM attempts").toInt(), 1);
  EXPECT_EQ(raw.scalar("SELECT count(*) FROM attempt_samples").toInt(), 1);
  // The store is still usable.
  raw.exec("DROP TRIGGER no_samples" + std::string(tdb.sqlite() ? "" : " ON attempt_samples"));
  c.store.recordAttempt(c.resident, makeAttempt("cut-line", kT0 + 9000, 70, 10, 1));
  EXPECT_EQ(c.store.attempts(c.resident).size(), 2u);
}

TEST_P(StoreTest, DashboardQueries) {
  LD_OPEN_TEST_DB(tdb, GetParam());
  Cast c = makeCast(tdb.url(), opts());
  // resident: five circle attempts with scores 10..50 (time 100..60 s, deviation 5..1).
  for (int i = 0; i < 5; ++i)
    c.store.recordAttempt(c.resident,
                          makeAttempt("cut-circle", kT0 + (5 - i) * 60'000, 10.0 * (i + 1), 100 - 10 * i, 5 - i));
  c.store.recordAttempt(c.resident2, makeAttempt("cut-circle", kT0, 90, 20, 0.5, /*completed=*/false));  // abandoned
  c.store.recordAttempt(c.resident2, makeAttempt("cut-line", kT0, 80, 30, 2));
  c.store.recordAttempt(c.director, makeAttempt("cut-line", kT0, 99, 1, 0));  // not a resident: not in the cohort

  // Attempts over time per task, ordered by start.
  AttemptFilter f;
  f.trainee = "resident";
  f.taskId = "cut-circle";
  const auto series = c.store.attempts(c.director, f);
  ASSERT_EQ(series.size(), 5u);
  for (std::size_t i = 1; i < series.size(); ++i) EXPECT_LT(series[i - 1].startedAt, series[i].startedAt);
  EXPECT_DOUBLE_EQ(series.front().score, 50);

  const auto stats = c.store.cohortStats(c.director);
  ASSERT_EQ(stats.size(), 2u);
  const CohortStats& circle = stats[0];
  EXPECT_EQ(circle.taskId, "cut-circle");
  EXPECT_EQ(circle.attempts, 5u);
  EXPECT_EQ(circle.trainees, 1u);
  EXPECT_DOUBLE_EQ(circle.score.q1, 20);
  EXPECT_DOUBLE_EQ(circle.score.median, 30);
  EXPECT_DOUBLE_EQ(circle.score.q3, 40);
  EXPECT_DOUBLE_EQ(circle.timeS.median, 80);
  EXPECT_DOUBLE_EQ(circle.deviation.q1, 2);
  EXPECT_DOUBLE_EQ(circle.deviation.q3, 4);
  EXPECT_DOUBLE_EQ(circle.passRate, 0.2);
  EXPECT_EQ(stats[1].taskId, "cut-line");
  EXPECT_EQ(stats[1].attempts, 1u);
  EXPECT_DOUBLE_EQ(stats[1].score.median, 80);

  // Due and overdue against the injected clock.
  now_ = kT0 + 10 * 60'000;
  c.store.assign(c.director, "resident", "cut-circle", kT0 + 86'400'000, 1);    // due tomorrow
  c.store.assign(c.director, "resident2", "cut-circle", kT0 + 20 * 60'000, 1);  // due in 10 min
  c.store.assign(c.director, "resident2", "cut-line", kT0 + 86'400'000, 2);     // needs two
  c.store.recordAttempt(c.resident, makeAttempt("cut-circle", now_ + 1000, 70, 30, 1));
  now_ += 60 * 60'000;  // an hour later
  const auto due = c.store.dueItems(c.director, {}, true);
  ASSERT_EQ(due.size(), 3u);
  EXPECT_EQ(due[0].assignment.trainee, "resident2");
  EXPECT_EQ(due[0].state, DueState::Overdue);
  EXPECT_EQ(due[1].assignment.trainee, "resident");
  EXPECT_EQ(due[1].state, DueState::Done);
  EXPECT_EQ(due[1].completedAttempts, 1);
  EXPECT_EQ(due[2].state, DueState::Due);  // the earlier cut-line attempt predates the assignment
  EXPECT_EQ(due[2].completedAttempts, 0);
  EXPECT_EQ(c.store.dueItems(c.resident).size(), 1u);
}

TEST_P(StoreTest, ExportsCsvWithMetricColumns) {
  LD_OPEN_TEST_DB(tdb, GetParam());
  Cast c = makeCast(tdb.url(), opts());
  c.store.addUser(c.admin, "=cmd|' /C calc'!A0", Role::Resident, "formula-password");
  Session evil = c.store.login("=cmd|' /C calc'!A0", "formula-password");
  c.store.recordAttempt(evil, makeAttempt("cut, \"quoted\"", kT0, 12.5, 3, 4));
  c.store.recordAttempt(c.resident, makeAttempt("cut-line", kT0, 50, 10, 1));
  AttemptFilter all;
  all.allTrainees = true;
  const std::string csv = c.store.exportCsv(c.director, all);
  std::vector<std::string> lines;
  std::istringstream in(csv);
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  ASSERT_EQ(lines.size(), 3u) << csv;
  EXPECT_EQ(
      lines[0].rfind("attempt_id,trainee,task_id,task_version,started_at,ended_at,completed,device,score,passed", 0),
      0u);
  EXPECT_NE(lines[0].find("metrics.deviation.total"), std::string::npos);
  EXPECT_NE(lines[0].find("metrics.contact_time.mean_s"), std::string::npos);
  EXPECT_NE(csv.find("'=cmd|' /C calc'!A0"), std::string::npos);  // shown as text, not run
  EXPECT_NE(csv.find("\"cut, \"\"quoted\"\"\""), std::string::npos);
  EXPECT_EQ(c.store.exportCsv(c.resident).find("=cmd"), std::string::npos);
}

TEST_P(StoreTest, AuditLogRecordsWhoChangedWhat) {
  LD_OPEN_TEST_DB(tdb, GetParam());
  Cast c = makeCast(tdb.url(), opts());
  c.store.setRole(c.admin, "resident2", Role::Author);
  c.store.saveTask(c.author, {"cut-line", 3, {{"title", "Line"}}, "", 0});
  const auto log = c.store.auditLog(c.admin);
  ASSERT_GE(log.size(), 7u);
  EXPECT_EQ(log[0].action, "task.save");
  EXPECT_EQ(log[0].actor, "author");
  EXPECT_EQ(log[1].action, "user.role");
  EXPECT_EQ(log[1].actor, "admin");
  EXPECT_EQ(log[1].target, "resident2");
  const auto t = c.store.task(c.resident, "cut-line", 3);
  ASSERT_TRUE(t.has_value());
  EXPECT_EQ(t->author, "author");
  EXPECT_EQ(t->json["title"], "Line");
}

INSTANTIATE_TEST_SUITE_P(Backends, StoreTest, ::testing::Values(Backend::Sqlite, Backend::Postgres),
                         ld::test::backendName);

// ---- SQLite only: the file itself ---------------------------------------------------

class SqliteFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string why;
    ASSERT_TRUE(tdb_.create(Backend::Sqlite, why));
    Cast c = makeCast(tdb_.url(), fastOptions());
    for (int i = 0; i < 40; ++i) c.store.recordAttempt(c.resident, makeAttempt("cut-line", kT0 + i, i, 10, 1));
  }
  void expectRefusedAndUntouched(const std::string& what) {
    const std::string before = ld::test::slurpFile(tdb_.path());
    try {
      Store::open(tdb_.url(), fastOptions());
      ADD_FAILURE() << what << ": accepted";
    } catch (const CorruptDatabase& e) {
      EXPECT_NE(std::string(e.what()).find(tdb_.path().string()), std::string::npos) << e.what();
    }
    EXPECT_EQ(ld::test::slurpFile(tdb_.path()), before) << what << ": the file was modified";
  }
  ld::test::TestDb tdb_;
};

TEST_F(SqliteFileTest, FileIsPrivateAndInWalMode) {
  struct stat st {};
  ASSERT_EQ(::stat(tdb_.path().c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  RawDb raw(tdb_.url());
  EXPECT_EQ(raw.scalar("PRAGMA journal_mode").toString().toStdString(), "wal");
}

TEST_F(SqliteFileTest, TruncatedFileIsRefused) {
  std::filesystem::resize_file(tdb_.path(), std::filesystem::file_size(tdb_.path()) / 2);
  expectRefusedAndUntouched("half the file");
  std::filesystem::resize_file(tdb_.path(), 60);
  expectRefusedAndUntouched("60 bytes");
}

TEST_F(SqliteFileTest, DamagedHeaderIsRefused) {
  {
    std::fstream f(tdb_.path(), std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(0);
    f.write("NOT A DATABASE!!", 16);
  }
  expectRefusedAndUntouched("garbage header");
}

TEST_F(SqliteFileTest, DamagedPagesAreRefused) {
  const auto size = std::filesystem::file_size(tdb_.path());
  {
    std::fstream f(tdb_.path(), std::ios::in | std::ios::out | std::ios::binary);
    std::string junk(8192, '\x5a');
    f.seekp(static_cast<std::streamoff>(size / 2));
    f.write(junk.data(), static_cast<std::streamsize>(std::min<std::uintmax_t>(junk.size(), size / 2)));
  }
  expectRefusedAndUntouched("overwritten pages");
}

TEST_F(SqliteFileTest, TextFileIsRefused) {
  { std::ofstream(tdb_.path(), std::ios::trunc) << "name,score\nkim,10\n" << std::string(500, 'x'); }
  expectRefusedAndUntouched("a text file");
}

TEST_F(SqliteFileTest, OnlineBackupIsACompleteCopy) {
  Store st = Store::open(tdb_.url(), fastOptions());
  const auto out = tdb_.dir() / "backup.db";
  st.backup(out.string());
  st.recordAttempt(st.login("resident", "resident-password"), makeAttempt("after", kT0, 1, 1, 1));
  struct stat sb {};
  ASSERT_EQ(::stat(out.c_str(), &sb), 0);
  EXPECT_EQ(sb.st_mode & 0777, 0600u);
  EXPECT_FALSE(std::filesystem::exists(out.string() + ".part-" + std::to_string(::getpid())));
  Store copy = Store::open("sqlite://" + out.string(), fastOptions());
  Session r = copy.login("resident", "resident-password");
  const auto a = copy.attempts(r);
  ASSERT_EQ(a.size(), 40u);
  EXPECT_EQ(copy.attemptSamples(r, a[7].id).data, makeAttempt("x", 0, 0, 1, 0).samples);
  EXPECT_THROW(st.backup(tdb_.path().string()), InvalidArgument);
  EXPECT_THROW(st.backup((tdb_.dir() / "no" / "such" / "dir.db").string()), InvalidArgument);
}

TEST(StoreUrl, ParsesAndRefusesUrls) {
  EXPECT_THROW(Store::open("mysql://u@h/db"), InvalidArgument);
  EXPECT_THROW(Store::open("sqlite://relative/path.db"), InvalidArgument);
  EXPECT_THROW(Store::open("postgresql://user@/db"), InvalidArgument);
  EXPECT_THROW(Store::open("postgresql://user@host:5432/"), InvalidArgument);
  EXPECT_THROW(Store::open(""), InvalidArgument);
  EXPECT_THROW(Store::open("/tmp"), InvalidArgument);  // a directory
  try {
    Store::open("postgresql://postgres@127.0.0.1:1/nothing", fastOptions());  // nobody listens on port 1
    ADD_FAILURE() << "connected to port 1";
  } catch (const InvalidArgument&) {
    ADD_FAILURE() << "a well-formed URL was called malformed";
  } catch (const DbError& e) {
    EXPECT_NE(std::string(e.what()).find("127.0.0.1:1/nothing"), std::string::npos) << e.what();
  }
  // Plain paths and sqlite URLs reach the same file.
  const auto dir = std::filesystem::temp_directory_path() / ("ld_url_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  {
    Store a = Store::open((dir / "x.db").string(), fastOptions());
    a.createFirstAdmin("admin", "admin-password");
  }
  {
    Store b = Store::open("sqlite://" + (dir / "x.db").string(), fastOptions());
    EXPECT_TRUE(b.hasUsers());
  }
  std::filesystem::remove_all(dir);
}

TEST(StoreUrl, DefaultLivesInTheUserDataFolder) {
  const auto dir = std::filesystem::temp_directory_path() / ("ld_xdg_" + std::to_string(::getpid()));
  ::setenv("XDG_DATA_HOME", dir.c_str(), 1);
  const std::string url = Store::defaultUrl();
  EXPECT_EQ(url, "sqlite://" + (dir / "lapdissect" / "lapdissect.db").string());
  {
    Store s = Store::open(url, fastOptions());  // created on first start, folder included
    EXPECT_FALSE(s.hasUsers());
  }
  EXPECT_TRUE(std::filesystem::exists(dir / "lapdissect" / "lapdissect.db"));
  std::filesystem::remove_all(dir);
}

}  // namespace
