#pragma once
// Fresh databases for the store tests, on SQLite (a temp file) or on the throwaway
// PostgreSQL server that scripts/pg-test-server.sh starts (ctest fixture "ld_pg").
#include <QSqlDatabase>
#include <QSqlError>
#include <QSqlQuery>
#include <QVariant>

#include <sodium.h>

#include <unistd.h>
#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <random>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "database/store.h"

namespace ld::test {

enum class Backend { Sqlite, Postgres };

inline void PrintTo(Backend b, std::ostream* os) { *os << (b == Backend::Sqlite ? "sqlite" : "postgres"); }

inline std::string backendName(const ::testing::TestParamInfo<Backend>& i) {
  return i.param == Backend::Sqlite ? "Sqlite" : "Postgres";
}

inline std::string slurpFile(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// The server's URL, or empty with `why` set.
inline std::string pgServerUrl(std::string& why) {
  if (const char* u = std::getenv("LD_PG_URL"); u && *u) return u;
  const char* dir = std::getenv("LD_PG_DIR");
  if (!dir) {
    why = "LD_PG_DIR is not set (run through ctest, whose fixture starts the server)";
    return {};
  }
  const std::filesystem::path d(dir);
  if (std::filesystem::exists(d / "unavailable")) {
    why = "PostgreSQL is not available: " + slurpFile(d / "unavailable");
    return {};
  }
  if (!std::filesystem::exists(d / "url")) {
    why = "the PostgreSQL test server did not start (no " + (d / "url").string() + ")";
    return {};
  }
  std::string url = slurpFile(d / "url");
  while (!url.empty() && (url.back() == '\n' || url.back() == '\r')) url.pop_back();
  return url;
}

// A raw Qt connection for what the store API does not offer (tests only).
class RawDb {
 public:
  RawDb(const std::string& url) : name_("raw_" + std::to_string(::getpid()) + "_" + std::to_string(++counter())) {
    if (url.rfind("postgresql://", 0) == 0) {
      // postgresql://user@host:port/db
      const auto at = url.find('@'), colon = url.rfind(':'), slash = url.rfind('/');
      db_ = QSqlDatabase::addDatabase("QPSQL", QString::fromStdString(name_));
      db_.setUserName(QString::fromStdString(url.substr(13, at - 13)));
      db_.setHostName(QString::fromStdString(url.substr(at + 1, colon - at - 1)));
      db_.setPort(std::stoi(url.substr(colon + 1, slash - colon - 1)));
      db_.setDatabaseName(QString::fromStdString(url.substr(slash + 1)));
    } else {
      db_ = QSqlDatabase::addDatabase("QSQLITE", QString::fromStdString(name_));
      db_.setDatabaseName(QString::fromStdString(url.rfind("sqlite://", 0) == 0 ? url.substr(9) : url));
    }
    if (!db_.open()) ADD_FAILURE() << "raw open failed: " << db_.lastError().text().toStdString();
  }
  ~RawDb() {
    db_.close();
    db_ = QSqlDatabase();
    QSqlDatabase::removeDatabase(QString::fromStdString(name_));
  }
  RawDb(const RawDb&) = delete;
  RawDb& operator=(const RawDb&) = delete;

  bool exec(const std::string& sql) {
    QSqlQuery q(db_);
    const bool ok = q.exec(QString::fromStdString(sql));
    if (!ok) ADD_FAILURE() << sql << ": " << q.lastError().text().toStdString();
    return ok;
  }
  QVariant scalar(const std::string& sql) {
    QSqlQuery q(db_);
    if (!q.exec(QString::fromStdString(sql)) || !q.next()) {
      ADD_FAILURE() << sql << ": " << q.lastError().text().toStdString();
      return {};
    }
    return q.value(0);
  }
  int rowCount(const std::string& sql) {
    QSqlQuery q(db_);
    if (!q.exec(QString::fromStdString(sql))) ADD_FAILURE() << sql << ": " << q.lastError().text().toStdString();
    int n = 0;
    while (q.next()) ++n;
    return n;
  }
  QSqlDatabase& db() { return db_; }

 private:
  static std::atomic<int>& counter() {
    static std::atomic<int> c{0};
    return c;
  }
  std::string name_;
  QSqlDatabase db_;
};

// One empty database for one test; dropped or deleted afterwards.
class TestDb {
 public:
  // Returns false (with why) when the backend is not available.
  bool create(Backend b, std::string& why) {
    backend_ = b;
    unsigned char rnd[6];
    randombytes_buf(rnd, sizeof rnd);
    std::string tag;
    for (unsigned char c : rnd) tag += "0123456789abcdef"[c & 15];
    tag += std::to_string(::getpid());
    if (b == Backend::Sqlite) {
      dir_ = std::filesystem::temp_directory_path() / ("ld_dbtest_" + tag);
      std::filesystem::create_directories(dir_);
      path_ = dir_ / "store.db";
      url_ = "sqlite://" + path_.string();
      return true;
    }
    server_ = pgServerUrl(why);
    if (server_.empty()) return false;
    dbName_ = "ld_test_" + tag;
    {
      RawDb admin(server_);
      if (!admin.exec("CREATE DATABASE " + dbName_)) {
        why = "cannot create a test database";
        return false;
      }
    }
    url_ = server_.substr(0, server_.rfind('/') + 1) + dbName_;
    return true;
  }
  ~TestDb() {
    if (!dir_.empty()) std::filesystem::remove_all(dir_);
    if (!dbName_.empty()) {
      RawDb admin(server_);
      admin.exec("DROP DATABASE IF EXISTS " + dbName_ + " WITH (FORCE)");
    }
  }
  [[nodiscard]] const std::string& url() const { return url_; }
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }
  [[nodiscard]] const std::filesystem::path& dir() const { return dir_; }
  [[nodiscard]] bool sqlite() const { return backend_ == Backend::Sqlite; }

 private:
  Backend backend_ = Backend::Sqlite;
  std::string url_, server_, dbName_;
  std::filesystem::path dir_, path_;
};

// Fast Argon2 for tests (the format and the algorithm are the same).
inline db::Options fastOptions(std::function<db::TimeMs()> clock = {}) {
  db::Options o;
  o.opsLimit = 1;     // crypto_pwhash_OPSLIMIT_MIN
  o.memLimit = 8192;  // crypto_pwhash_MEMLIMIT_MIN
  o.clock = std::move(clock);
  return o;
}

}  // namespace ld::test

#define LD_OPEN_TEST_DB(var, backend)                     \
  ::ld::test::TestDb var;                                 \
  {                                                       \
    std::string why_;                                     \
    if (!var.create(backend, why_)) GTEST_SKIP() << why_; \
  }
