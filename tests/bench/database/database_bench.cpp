// Trainee store speed: storing one attempt with 60 000 pose samples, and the dashboard
// queries over 100 000 attempts by 200 trainees. SQLite in a temp folder; set
// LD_BENCH_PG_URL=postgresql://user@host:port/emptydb to run the same on PostgreSQL.
#include <QSqlDatabase>
#include <QSqlError>
#include <QSqlQuery>
#include <QVariant>

#include <benchmark/benchmark.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <random>
#include <string>

#include "database/store.h"

namespace {

using namespace ld::db;
namespace fs = std::filesystem;

constexpr TimeMs kT0 = 1'780'000'000'000;

Options fast() {
  Options o;
  o.opsLimit = 1;
  o.memLimit = 8192;
  o.clock = [] { return kT0 + 400LL * 86'400'000; };
  return o;
}

// 60 000 samples of the trajectory format (two hands, 30 000 each, 1 kHz).
std::string poseStream(int samples) {
  std::string s = "t,hand,tool,tip_x,tip_y,tip_z,dir_x,dir_y,dir_z,up_x,up_y,up_z,jaw,pedal\n";
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0, 0.05);
  double x[2] = {0, 10}, y[2] = {0, 0}, z[2] = {5, 5};
  char buf[256];
  for (int i = 0; i < samples; ++i) {
    const int h = i % 2;
    x[h] += n(rng);
    y[h] += n(rng);
    z[h] += n(rng);
    std::snprintf(buf, sizeof buf, "%.3f,%s,%s,%.4f,%.4f,%.4f,0,0,-1,0,1,0,%.2f,%d\n", (i / 2) * 0.001,
                  h ? "right" : "left", h ? "hook" : "grasper", x[h], y[h], z[h], h ? 0.0 : 0.3, h ? (i / 200) % 2 : 0);
    s += buf;
  }
  return s;
}

std::string tempDir(const char* tag) {
  const auto d = fs::temp_directory_path() / (std::string("ld_bench_") + tag + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d.string();
}

nlohmann::json metrics(double score, double t, double dev) {
  return {{"deviation", {{"xy", dev / 2}, {"yz", dev / 4}, {"xz", dev / 4}, {"total", dev}}},
          {"contact_time", {{"mean_s", 0.4}, {"max_s", 1.5}, {"total_s", t / 2}}},
          {"contact_breaks", 4},
          {"path_breaks", 2},
          {"total_time_s", t},
          {"score", score},
          {"passed", score >= 60}};
}

void BM_RecordAttempt60kSamples(benchmark::State& state, std::string url) {
  const bool pg = url.rfind("postgresql", 0) == 0;
  std::string dir;
  if (!pg) {
    dir = tempDir("record");
    url = "sqlite://" + dir + "/store.db";
  }
  Store st = Store::open(url, fast());
  Session admin = st.hasUsers() ? st.login("admin", "admin-password") : st.createFirstAdmin("admin", "admin-password");
  AttemptRecord a;
  a.taskId = "cut-circle";
  a.startedAt = kT0;
  a.endedAt = kT0 + 30'000;
  a.device = "bench";
  a.score = 71;
  a.metrics = metrics(71, 30, 12);
  a.samples = poseStream(60'000);
  std::int64_t id = 0;
  for (auto _ : state) id = st.recordAttempt(admin, a);
  state.counters["raw_MB"] = double(a.samples.size()) / 1e6;
  state.counters["stored_MB"] =
      double(qCompress(QByteArray::fromRawData(a.samples.data(), qsizetype(a.samples.size())), 3).size()) / 1e6;
  state.SetBytesProcessed(std::int64_t(state.iterations()) * std::int64_t(a.samples.size()));
  // Read back for replay, once, to report that too.
  const auto t0 = std::chrono::steady_clock::now();
  const Samples back = st.attemptSamples(admin, id);
  state.counters["read_back_ms"] =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  if (back.data != a.samples) state.SkipWithError("samples differ after the round trip");
  if (!dir.empty()) fs::remove_all(dir);
}

// 200 residents, 10 tasks, 100 000 attempts (500 each), 2 000 assignments.
struct Cohort {
  std::string dir, url;
  std::unique_ptr<Store> store;
  std::unique_ptr<Session> director;
  double buildSeconds = 0;
};

std::unique_ptr<Cohort> gCohort;

Cohort& cohort() {
  if (gCohort) return *gCohort;
  gCohort = std::make_unique<Cohort>([] {
    Cohort k;
    const auto t0 = std::chrono::steady_clock::now();
    k.dir = tempDir("cohort");
    k.url = "sqlite://" + k.dir + "/store.db";
    {
      Store st = Store::open(k.url, fast());
      Session admin = st.createFirstAdmin("admin", "admin-password");
      st.addUser(admin, "director", Role::Director, "director-password");
      for (int u = 0; u < 200; ++u)
        st.addUser(admin, "resident" + std::to_string(u), Role::Resident, "resident-password");
      Session d = st.login("director", "director-password");
      for (int u = 0; u < 200; ++u)
        for (int t = 0; t < 10; ++t)
          st.assign(d, "resident" + std::to_string(u), "task" + std::to_string(t), kT0 + (u + t) * 86'400'000LL, 3);
    }
    // Bulk rows through one raw transaction (the API writes one attempt per transaction,
    // with an fsync each: 100 000 of those would measure the disk, not the queries).
    {
      auto db = QSqlDatabase::addDatabase("QSQLITE", "bulk");
      db.setDatabaseName(QString::fromStdString(k.dir + "/store.db"));
      db.open();
      QSqlQuery q(db);
      q.exec("BEGIN");
      q.prepare(
          "INSERT INTO attempts (user_id, task_id, task_version, started_at, ended_at, completed, device, score, "
          "passed,"
          " metrics, duration_s, deviation_total) VALUES ((SELECT id FROM users WHERE name = ?), ?, 1, ?, ?, ?, "
          "'bench',"
          " ?, ?, ?, ?, ?)");
      QSqlQuery s(db);
      s.prepare(
          "INSERT INTO attempt_samples (attempt_id, format, raw_size, data) VALUES (last_insert_rowid(), "
          "'trajectory-csv', 0, ?)");
      std::mt19937 rng(11);
      std::uniform_real_distribution<double> U(0, 1);
      const QByteArray empty = qCompress(QByteArray());
      for (int i = 0; i < 100'000; ++i) {
        const int u = i % 200, t = (i / 200) % 10, n = i / 2000;  // n: the attempt number per trainee and task
        const double skill = 1.0 - std::exp(-n / 15.0);
        const double score = std::min(100.0, 20 + 70 * skill + 10 * U(rng));
        const double time = 60 + 240 * (1 - skill) + 20 * U(rng);
        const double dev = 5 + 80 * (1 - skill) + 5 * U(rng);
        const TimeMs start = kT0 + TimeMs(n) * 86'400'000 + u * 60'000 + t * 1000;
        q.addBindValue(QString::fromStdString("resident" + std::to_string(u)));
        q.addBindValue(QString::fromStdString("task" + std::to_string(t)));
        q.addBindValue(QVariant::fromValue<qint64>(start));
        q.addBindValue(QVariant::fromValue<qint64>(start + TimeMs(time * 1000)));
        q.addBindValue(U(rng) < 0.95 ? 1 : 0);
        q.addBindValue(score);
        q.addBindValue(score >= 60 ? 1 : 0);
        q.addBindValue(QString::fromStdString(metrics(score, time, dev).dump()));
        q.addBindValue(time);
        q.addBindValue(dev);
        if (!q.exec()) std::abort();
        s.addBindValue(empty);
        if (!s.exec()) std::abort();
      }
      QSqlQuery(db).exec("COMMIT");
      db.close();
    }
    QSqlDatabase::removeDatabase("bulk");
    k.store = std::make_unique<Store>(Store::open(k.url, fast()));
    k.director = std::make_unique<Session>(k.store->login("director", "director-password"));
    k.buildSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return k;
  }());
  return *gCohort;
}

void BM_OneTraineeOneTaskOverTime(benchmark::State& state) {
  Cohort& c = cohort();
  AttemptFilter f;
  f.trainee = "resident123";
  f.taskId = "task7";
  std::size_t n = 0;
  for (auto _ : state) n = c.store->attempts(*c.director, f).size();
  state.counters["rows"] = double(n);
}

void BM_OneTraineeAllTasks(benchmark::State& state) {
  Cohort& c = cohort();
  AttemptFilter f;
  f.trainee = "resident42";
  std::size_t n = 0;
  for (auto _ : state) n = c.store->attempts(*c.director, f).size();
  state.counters["rows"] = double(n);
}

void BM_CohortStatsPerTask(benchmark::State& state) {
  Cohort& c = cohort();
  std::size_t n = 0;
  for (auto _ : state) n = c.store->cohortStats(*c.director).size();
  state.counters["tasks"] = double(n);
}

void BM_DueAndOverdueAll(benchmark::State& state) {
  Cohort& c = cohort();
  std::size_t n = 0;
  for (auto _ : state) n = c.store->dueItems(*c.director, {}, true).size();
  state.counters["assignments"] = double(n);
}

void BM_ExportCsvOneTrainee(benchmark::State& state) {
  Cohort& c = cohort();
  AttemptFilter f;
  f.trainee = "resident7";
  std::size_t n = 0;
  for (auto _ : state) n = c.store->exportCsv(*c.director, f).size();
  state.counters["bytes"] = double(n);
}

void BM_ExportCsvAll100k(benchmark::State& state) {
  Cohort& c = cohort();
  AttemptFilter f;
  f.allTrainees = true;
  std::size_t n = 0;
  for (auto _ : state) n = c.store->exportCsv(*c.director, f).size();
  state.counters["MB"] = double(n) / 1e6;
}

void BM_OpenWithIntegrityCheck(benchmark::State& state) {
  Cohort& c = cohort();
  for (auto _ : state) {
    Store s = Store::open(c.url, fast());
    benchmark::DoNotOptimize(s.schemaVersion());
  }
  state.counters["file_MB"] = double(fs::file_size(c.dir + "/store.db")) / 1e6;
  state.counters["cohort_build_s"] = c.buildSeconds;
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::RegisterBenchmark("BM_RecordAttempt60kSamples/sqlite", BM_RecordAttempt60kSamples, std::string())
      ->Unit(benchmark::kMillisecond)
      ->MinTime(2.0);
  if (const char* pg = std::getenv("LD_BENCH_PG_URL"))
    benchmark::RegisterBenchmark("BM_RecordAttempt60kSamples/postgres", BM_RecordAttempt60kSamples, std::string(pg))
        ->Unit(benchmark::kMillisecond)
        ->MinTime(2.0);
  benchmark::RegisterBenchmark("BM_OneTraineeOneTaskOverTime", BM_OneTraineeOneTaskOverTime)
      ->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("BM_OneTraineeAllTasks", BM_OneTraineeAllTasks)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("BM_CohortStatsPerTask", BM_CohortStatsPerTask)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("BM_DueAndOverdueAll", BM_DueAndOverdueAll)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("BM_ExportCsvOneTrainee", BM_ExportCsvOneTrainee)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("BM_ExportCsvAll100k", BM_ExportCsvAll100k)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("BM_OpenWithIntegrityCheck", BM_OpenWithIntegrityCheck)->Unit(benchmark::kMillisecond);
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  if (gCohort) {
    const std::string dir = gCohort->dir;
    gCohort.reset();
    fs::remove_all(dir);
  }
  return 0;
}
