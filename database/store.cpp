#include "database/store.h"

#include <QByteArray>
#include <QCoreApplication>
#include <QDateTime>
#include <QDir>
#include <QFileInfo>
#include <QSqlDatabase>
#include <QSqlDriver>
#include <QSqlError>
#include <QSqlQuery>
#include <QStandardPaths>
#include <QVariant>

#include <sodium.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <set>
#include <thread>

#ifdef LD_DB_HAVE_SQLITE3
#include <sqlite3.h>
#endif

#include "database/connection_url.h"
#include "database/csv.h"
#include "database/password.h"
#include "database/schema.h"
#include "database/stats.h"

namespace ld::db {

std::string toString(Role r) {
  switch (r) {
    case Role::Resident:
      return "resident";
    case Role::Director:
      return "director";
    case Role::Author:
      return "author";
    case Role::Admin:
      return "admin";
  }
  return "resident";
}

Role roleFromString(const std::string& s) {
  if (s == "resident") return Role::Resident;
  if (s == "director") return Role::Director;
  if (s == "author") return Role::Author;
  if (s == "admin") return Role::Admin;
  throw InvalidArgument("unknown role '" + s + "' (resident, director, author or admin)");
}

std::string toString(DueState s) {
  switch (s) {
    case DueState::Done:
      return "done";
    case DueState::Due:
      return "due";
    case DueState::Overdue:
      return "overdue";
  }
  return "due";
}

std::string isoTime(TimeMs t) {
  return QDateTime::fromMSecsSinceEpoch(t, Qt::UTC).toString(Qt::ISODateWithMs).toStdString();
}

namespace {

std::atomic<std::uint64_t> gConnections{0};

QString qs(const std::string& s) { return QString::fromStdString(s); }
std::string ss(const QVariant& v) { return v.toString().toStdString(); }

void checkName(const std::string& what, const std::string& name, std::size_t maxLen) {
  if (name.empty() || name.size() > maxLen)
    throw InvalidArgument(what + " must have 1 to " + std::to_string(maxLen) + " bytes");
  for (unsigned char c : name)
    if (c < 0x20 || c == 0x7f) throw InvalidArgument(what + " contains a control character");
  if (name.find_first_not_of(' ') == std::string::npos) throw InvalidArgument(what + " is blank");
  const QByteArray bytes(name.data(), qsizetype(name.size()));
  if (QString::fromUtf8(bytes).toUtf8() != bytes) throw InvalidArgument(what + " is not valid UTF-8");
}

void checkPassword(const std::string& pw) {
  if (pw.size() < 8) throw InvalidArgument("a password needs at least 8 characters");
  if (pw.size() > 4096) throw InvalidArgument("password too long");
}

// Reads the SQLite header of an existing file; refuses files that are not SQLite or are
// shorter than the header says (only checked when no WAL could hold the missing pages).
void checkSqliteFile(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw DbError(path + ": cannot read the database file");
  f.seekg(0, std::ios::end);
  const auto size = static_cast<std::uint64_t>(f.tellg());
  if (size == 0) return;  // SQLite treats an empty file as a new database
  if (size < 100) throw CorruptDatabase(path + ": truncated database file (" + std::to_string(size) + " bytes)");
  unsigned char h[100];
  f.seekg(0);
  f.read(reinterpret_cast<char*>(h), 100);
  if (std::memcmp(h, "SQLite format 3\0", 16) != 0)
    throw CorruptDatabase(path + ": not a SQLite database (bad header); the file was left untouched");
  auto be32 = [&](int o) {
    return (std::uint32_t(h[o]) << 24) | (std::uint32_t(h[o + 1]) << 16) | (std::uint32_t(h[o + 2]) << 8) |
           std::uint32_t(h[o + 3]);
  };
  std::uint32_t pageSize = (std::uint32_t(h[16]) << 8) | h[17];
  if (pageSize == 1) pageSize = 65536;
  if (pageSize < 512 || (pageSize & (pageSize - 1)) != 0)
    throw CorruptDatabase(path + ": damaged database header (page size " + std::to_string(pageSize) + ")");
  const std::uint32_t pages = be32(28);
  const bool sizeValid = pages != 0 && be32(24) == be32(92);
  const auto walSize = QFileInfo(qs(path + "-wal")).exists() ? QFileInfo(qs(path + "-wal")).size() : 0;
  if (sizeValid && walSize == 0 && size < std::uint64_t(pages) * pageSize)
    throw CorruptDatabase(path + ": truncated database file (" + std::to_string(size) + " bytes, the header says " +
                          std::to_string(std::uint64_t(pages) * pageSize) + "); the file was left untouched");
}

}  // namespace

struct Store::Impl {
  ConnectionInfo ci;
  Options opt;
  QString connName;
  QSqlDatabase db;
  int version = 0;
  std::uint64_t token = 0;
  std::string where;  // for messages

  ~Impl() {
    if (db.isValid()) {
      db.close();
      db = QSqlDatabase();
      QSqlDatabase::removeDatabase(connName);
    }
  }

  [[nodiscard]] bool sqlite() const { return ci.kind == ConnectionInfo::Kind::Sqlite; }
  [[nodiscard]] schema::Dialect dialect() const {
    return sqlite() ? schema::Dialect::Sqlite : schema::Dialect::Postgres;
  }
  [[nodiscard]] TimeMs now() const {
    if (opt.clock) return opt.clock();
    return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
        .count();
  }

  [[noreturn]] void fail(const QSqlError& e, const std::string& what) const {
    const std::string text = e.text().toStdString();
    const QString code = e.nativeErrorCode();
    if (sqlite() && (code == "11" || code == "26" || text.find("malformed") != std::string::npos ||
                     text.find("not a database") != std::string::npos))
      throw CorruptDatabase(where + ": the database file is damaged (" + text + "); it was left untouched");
    throw DbError(where + ": " + what + ": " + text);
  }

  QSqlQuery prepare(const std::string& sql) const {
    QSqlQuery q(db);
    q.setForwardOnly(true);
    if (!q.prepare(qs(sql))) fail(q.lastError(), "prepare failed");
    return q;
  }
  void run(QSqlQuery& q) const {
    if (!q.exec()) fail(q.lastError(), "query failed");
  }
  void execRaw(const std::string& sql) const {
    QSqlQuery q(db);
    if (!q.exec(qs(sql))) fail(q.lastError(), "'" + sql + "' failed");
  }
  // Binds in order: each argument becomes the next positional value.
  template <class... A>
  QSqlQuery query(const std::string& sql, const A&... args) const {
    QSqlQuery q = prepare(sql);
    (q.addBindValue(QVariant::fromValue(args)), ...);
    run(q);
    return q;
  }

  // A write transaction; rolled back unless commit() ran.
  class Tx {
   public:
    explicit Tx(const Impl& i) : impl_(i) {
      impl_.execRaw(impl_.sqlite() ? "BEGIN IMMEDIATE" : "BEGIN");
      if (!impl_.sqlite()) impl_.execRaw("SELECT pg_advisory_xact_lock(74150051)");
    }
    Tx(const Tx&) = delete;
    Tx& operator=(const Tx&) = delete;
    ~Tx() {
      if (!done_) {
        QSqlQuery q(impl_.db);
        q.exec("ROLLBACK");
      }
    }
    void commit() {
      impl_.execRaw("COMMIT");
      done_ = true;
    }

   private:
    const Impl& impl_;
    bool done_ = false;
  };

  void audit(std::optional<std::int64_t> actor, const std::string& action, const std::string& target,
             const std::string& detail) const {
    QSqlQuery q =
        prepare("INSERT INTO audit_log (happened_at, actor_id, action, target, detail) VALUES (?, ?, ?, ?, ?)");
    q.addBindValue(QVariant::fromValue<qint64>(now()));
    q.addBindValue(actor ? QVariant::fromValue<qint64>(*actor) : QVariant(QMetaType::fromType<qint64>()));
    q.addBindValue(qs(action));
    q.addBindValue(qs(target));
    q.addBindValue(qs(detail));
    run(q);
  }

  bool tableExists(const std::string& name) const {
    QSqlQuery q = sqlite() ? query("SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name = ?", qs(name))
                           : query(
                                 "SELECT count(*) FROM information_schema.tables WHERE table_schema = current_schema() "
                                 "AND table_name = ?",
                                 qs(name));
    return q.next() && q.value(0).toLongLong() > 0;
  }
  std::int64_t otherTables() const {
    QSqlQuery q = sqlite()
                      ? query("SELECT count(*) FROM sqlite_master WHERE name NOT LIKE 'sqlite_%'")
                      : query("SELECT count(*) FROM information_schema.tables WHERE table_schema = current_schema()");
    return q.next() ? q.value(0).toLongLong() : 0;
  }
  // -1: no schema table (an empty database).
  int readVersion() const {
    if (!tableExists("ld_schema")) {
      // A workstation migrating at this moment commits ld_schema together with the
      // other tables, possibly between the two queries: look again before calling the
      // database foreign.
      const bool others = otherTables() > 0;
      if (!tableExists("ld_schema")) {
        if (others)
          throw CorruptDatabase(where + ": not a lapdissect database (it has other tables); it was left untouched");
        return -1;
      }
    }
    QSqlQuery q = query("SELECT version FROM ld_schema");
    if (!q.next()) throw CorruptDatabase(where + ": the schema version is missing; the database was left untouched");
    return q.value(0).toInt();
  }

  void migrate() {
    const int target = opt.migrateTo > 0 ? std::min(opt.migrateTo, schema::latestVersion()) : schema::latestVersion();
    if (version >= target) return;
    Tx tx(*this);
    int v = readVersion();  // again, under the lock: another workstation may have migrated
    if (v > schema::latestVersion()) tooNew(v);
    if (v >= target) {
      tx.commit();
      version = v;
      return;
    }
    const int from = v;
    if (v < 0) {
      execRaw("CREATE TABLE ld_schema (version INTEGER NOT NULL)");
      execRaw("INSERT INTO ld_schema (version) VALUES (0)");
      v = 0;
    }
    for (const auto& m : schema::migrations()) {
      if (m.version <= v || m.version > target) continue;
      for (const auto& st : m.statements) execRaw(schema::render(st, dialect()));
      if (m.code) m.code(db, dialect());
      v = m.version;
    }
    query("UPDATE ld_schema SET version = ?", v);
    audit(std::nullopt, "schema.migrate", "database",
          "from " + std::to_string(std::max(from, 0)) + " to " + std::to_string(v));
    tx.commit();
    version = v;
  }

  [[noreturn]] void tooNew(int v) const {
    throw SchemaTooNew(where + ": the database has schema version " + std::to_string(v) +
                       ", newer than this program knows (" + std::to_string(schema::latestVersion()) +
                       "); update lapdissect. The database was left untouched");
  }

  // --- sessions ---
  struct Current {
    std::int64_t id;
    std::string name;
    Role role;
  };
  Current current(const Session& s) const {
    if (s.store_ != token) throw NotPermitted();
    QSqlQuery q = query("SELECT name, role, disabled FROM users WHERE id = ?", qint64(s.userId_));
    if (!q.next() || q.value(2).toInt() != 0) throw NotPermitted();
    return {s.userId_, ss(q.value(0)), roleFromString(ss(q.value(1)))};
  }
  Current require(const Session& s, std::initializer_list<Role> roles) const {
    Current c = current(s);
    if (std::find(roles.begin(), roles.end(), c.role) == roles.end()) throw NotPermitted();
    return c;
  }
  std::int64_t userId(const std::string& name) const {
    QSqlQuery q = query("SELECT id FROM users WHERE name = ?", qs(name));
    if (!q.next()) throw NotFound("no user named '" + name + "'");
    return q.value(0).toLongLong();
  }
  static bool readsEveryone(Role r) { return r == Role::Director || r == Role::Admin; }

  // Whose attempts a filter asks for: empty = everyone (checked against the role).
  std::optional<std::int64_t> attemptOwner(const Session& s, const AttemptFilter& f) const {
    const Current c = current(s);
    if (f.allTrainees) {
      if (!readsEveryone(c.role)) throw NotPermitted();
      return std::nullopt;
    }
    if (!f.trainee || *f.trainee == c.name) return c.id;
    if (!readsEveryone(c.role)) throw NotPermitted();  // before revealing whether the name exists
    return userId(*f.trainee);
  }

  std::vector<Attempt> readAttempts(std::optional<std::int64_t> owner, const std::optional<std::string>& task) const {
    const bool v2 = version >= 2;
    std::string sql = std::string(
                          "SELECT a.id, u.name, a.task_id, a.task_version, a.started_at, a.ended_at, a.completed,"
                          " a.device, a.score, a.passed, a.metrics, ") +
                      (v2 ? "a.duration_s, a.deviation_total, " : "NULL, NULL, ") +
                      "(SELECT raw_size FROM attempt_samples s WHERE s.attempt_id = a.id)"
                      " FROM attempts a JOIN users u ON u.id = a.user_id WHERE 1 = 1";
    QVariantList binds;
    if (owner) {
      sql += " AND a.user_id = ?";
      binds << QVariant::fromValue<qint64>(*owner);
    }
    if (task) {
      sql += " AND a.task_id = ?";
      binds << qs(*task);
    }
    sql += " ORDER BY u.name, a.task_id, a.started_at, a.id";
    QSqlQuery q = prepare(sql);
    for (const auto& b : binds) q.addBindValue(b);
    run(q);
    std::vector<Attempt> out;
    while (q.next()) {
      Attempt a;
      a.id = q.value(0).toLongLong();
      a.trainee = ss(q.value(1));
      a.taskId = ss(q.value(2));
      a.taskVersion = q.value(3).toInt();
      a.startedAt = q.value(4).toLongLong();
      a.endedAt = q.value(5).toLongLong();
      a.completed = q.value(6).toInt() != 0;
      a.device = ss(q.value(7));
      a.score = q.value(8).toDouble();
      a.passed = q.value(9).toInt() != 0;
      a.metrics = nlohmann::json::parse(q.value(10).toString().toStdString(), nullptr, false);
      if (a.metrics.is_discarded()) a.metrics = nlohmann::json::object();
      if (!q.value(11).isNull()) {
        a.durationS = q.value(11).toDouble();
      } else {
        a.durationS = double(a.endedAt - a.startedAt) / 1000.0;
        if (a.metrics.contains("total_time_s") && a.metrics["total_time_s"].is_number())
          a.durationS = a.metrics["total_time_s"].get<double>();
      }
      if (!q.value(12).isNull()) a.deviationTotal = q.value(12).toDouble();
      a.samplesBytes = q.value(13).isNull() ? 0 : std::size_t(q.value(13).toLongLong());
      out.push_back(std::move(a));
    }
    return out;
  }
};

// ------------------------------------------------------------------------------------

Store::Store(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Store::Store(Store&&) noexcept = default;
Store& Store::operator=(Store&&) noexcept = default;
Store::~Store() = default;

int Store::latestSchemaVersion() { return schema::latestVersion(); }
int Store::schemaVersion() const { return impl_->version; }
bool Store::isSqlite() const { return impl_->sqlite(); }
const std::string& Store::location() const { return impl_->where; }

std::string Store::defaultUrl() {
  QString dir = QStandardPaths::writableLocation(QStandardPaths::AppDataLocation);
  if (QCoreApplication::applicationName().isEmpty() || dir.isEmpty())
    dir = QStandardPaths::writableLocation(QStandardPaths::GenericDataLocation) + "/lapdissect";
  return "sqlite://" + (dir + "/lapdissect.db").toStdString();
}

Store Store::open(const std::string& url, Options options) {
  auto impl = std::make_unique<Impl>();
  impl->ci = parseConnectionUrl(url);
  impl->opt = std::move(options);
  impl->where = impl->ci.display();
  do {
    randombytes_buf(&impl->token, sizeof impl->token);
  } while (impl->token == 0);
  impl->connName = QString("ld_db_%1").arg(++gConnections);

  if (impl->sqlite()) {
    const QFileInfo fi(qs(impl->ci.path));
    const std::string path = fi.absoluteFilePath().toStdString();
    impl->ci.path = path;
    impl->where = path;
    if (fi.isDir()) throw InvalidArgument(path + ": is a directory, not a database file");
    if (!fi.exists()) {
      QDir().mkpath(fi.absolutePath());
      const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
      if (fd >= 0) {
        ::close(fd);
      } else if (errno == EEXIST) {
        checkSqliteFile(path);  // another process created it just now
      } else {
        throw DbError(path + ": cannot create the database file: " + std::strerror(errno));
      }
    } else {
      checkSqliteFile(path);
    }
    impl->db = QSqlDatabase::addDatabase("QSQLITE", impl->connName);
    if (!impl->db.isValid()) throw DbError("the Qt SQLite driver (QSQLITE) is not available");
    impl->db.setDatabaseName(qs(path));
    impl->db.setConnectOptions("QSQLITE_BUSY_TIMEOUT=10000");
  } else {
    impl->db = QSqlDatabase::addDatabase("QPSQL", impl->connName);
    if (!impl->db.isValid()) throw DbError("the Qt PostgreSQL driver (QPSQL) is not available");
    impl->db.setHostName(qs(impl->ci.host));
    impl->db.setPort(impl->ci.port);
    impl->db.setDatabaseName(qs(impl->ci.database));
    if (!impl->ci.user.empty()) impl->db.setUserName(qs(impl->ci.user));
    if (!impl->ci.password.empty()) impl->db.setPassword(qs(impl->ci.password));
    impl->db.setConnectOptions("connect_timeout=10;application_name=lapdissect");
  }
  if (!impl->db.open()) {
    const std::string err = impl->db.lastError().text().toStdString();
    throw DbError(impl->where + ": cannot open the database: " + err);
  }

  // Read-only checks first: a damaged or newer database must not be written to.
  if (impl->sqlite() && impl->opt.checkIntegrityOnOpen) {
    QSqlQuery q(impl->db);
    if (!q.exec("PRAGMA quick_check")) impl->fail(q.lastError(), "integrity check failed");
    std::string first;
    int rows = 0;
    while (q.next()) {
      if (rows++ == 0) first = ss(q.value(0));
    }
    if (rows != 1 || first != "ok")
      throw CorruptDatabase(impl->where + ": the database file is damaged (" + first + "); it was left untouched");
  }
  impl->version = std::max(impl->readVersion(), 0);
  if (impl->version > schema::latestVersion()) impl->tooNew(impl->version);

  if (impl->sqlite()) {
    // Another workstation opening the same new file may hold its lock for a moment.
    bool wal = false;
    for (int attempt = 0; attempt < 100 && !wal; ++attempt) {
      QSqlQuery q(impl->db);
      wal = q.exec("PRAGMA journal_mode = WAL") && q.next() && q.value(0).toString() == "wal";
      if (!wal) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    if (!wal) throw DbError(impl->where + ": cannot switch the database to WAL mode");
    impl->execRaw("PRAGMA foreign_keys = ON");
    impl->execRaw("PRAGMA synchronous = FULL");  // a committed attempt survives a power cut
    impl->execRaw("PRAGMA secure_delete = ON");
  }
  impl->migrate();
  if (impl->sqlite()) ::chmod(impl->ci.path.c_str(), 0600);
  return Store(std::move(impl));
}

// --- accounts ---------------------------------------------------------------------

bool Store::hasUsers() const {
  QSqlQuery q = impl_->query("SELECT count(*) FROM users");
  return q.next() && q.value(0).toLongLong() > 0;
}

Session Store::createFirstAdmin(const std::string& name, const std::string& password) {
  checkName("user name", name, 64);
  checkPassword(password);
  const std::string hash = hashPassword(password, impl_->opt.opsLimit, impl_->opt.memLimit);
  Impl::Tx tx(*impl_);
  if (hasUsers()) throw AlreadyExists("the database already has users; no second first administrator");
  QSqlQuery q =
      impl_->query("INSERT INTO users (name, role, password_hash, created_at) VALUES (?, 'admin', ?, ?) RETURNING id",
                   qs(name), qs(hash), qint64(impl_->now()));
  if (!q.next()) throw DbError(impl_->where + ": insert returned no id");
  const std::int64_t id = q.value(0).toLongLong();
  q.finish();
  impl_->audit(id, "user.create", name, "role admin (first administrator)");
  tx.commit();
  return Session(impl_->token, id, name, Role::Admin);
}

Session Store::login(const std::string& name, const std::string& password) {
  Impl& I = *impl_;
  QSqlQuery q = I.query(
      "SELECT id, role, password_hash, disabled, failed_logins, locked_until FROM users WHERE name = ?", qs(name));
  if (!q.next()) {
    verifyDummy(password, I.opt.opsLimit, I.opt.memLimit);
    throw AuthFailed(false);
  }
  const std::int64_t id = q.value(0).toLongLong();
  const std::string role = ss(q.value(1));
  const std::string hash = ss(q.value(2));
  const bool disabled = q.value(3).toInt() != 0;
  int failed = q.value(4).toInt();
  const std::optional<TimeMs> lockedUntil =
      q.value(5).isNull() ? std::nullopt : std::optional<TimeMs>(q.value(5).toLongLong());
  q.finish();
  const TimeMs now = I.now();
  if (lockedUntil && *lockedUntil > now) throw AuthFailed(true);
  if (lockedUntil) failed = 0;  // the lock has run out: a fresh count
  const bool ok = verifyPassword(hash, password);
  if (ok && !disabled) {
    if (failed > 0 || lockedUntil)
      I.query("UPDATE users SET failed_logins = 0, locked_until = NULL WHERE id = ?", qint64(id));
    return Session(I.token, id, name, roleFromString(role));
  }
  if (!ok) {
    ++failed;
    if (failed >= I.opt.maxFailedLogins) {
      Impl::Tx tx(I);
      I.query("UPDATE users SET failed_logins = ?, locked_until = ? WHERE id = ?", failed,
              qint64(now + I.opt.lockoutMs), qint64(id));
      I.audit(std::nullopt, "user.locked", name, std::to_string(failed) + " failed logins");
      tx.commit();
    } else {
      I.query("UPDATE users SET failed_logins = ?, locked_until = NULL WHERE id = ?", failed, qint64(id));
    }
  }
  throw AuthFailed(false);
}

void Store::addUser(const Session& s, const std::string& name, Role role, const std::string& password) {
  const auto c = impl_->require(s, {Role::Admin});
  checkName("user name", name, 64);
  checkPassword(password);
  const std::string hash = hashPassword(password, impl_->opt.opsLimit, impl_->opt.memLimit);
  Impl::Tx tx(*impl_);
  if (impl_->query("SELECT 1 FROM users WHERE name = ?", qs(name)).next())
    throw AlreadyExists("a user named '" + name + "' exists already");
  impl_->query("INSERT INTO users (name, role, password_hash, created_at) VALUES (?, ?, ?, ?)", qs(name),
               qs(toString(role)), qs(hash), qint64(impl_->now()));
  impl_->audit(c.id, "user.create", name, "role " + toString(role));
  tx.commit();
}

void Store::setRole(const Session& s, const std::string& name, Role role) {
  const auto c = impl_->require(s, {Role::Admin});
  Impl::Tx tx(*impl_);
  const std::int64_t id = impl_->userId(name);
  impl_->query("UPDATE users SET role = ? WHERE id = ?", qs(toString(role)), qint64(id));
  impl_->audit(c.id, "user.role", name, "role " + toString(role));
  tx.commit();
}

void Store::setDisabled(const Session& s, const std::string& name, bool disabled) {
  const auto c = impl_->require(s, {Role::Admin});
  Impl::Tx tx(*impl_);
  const std::int64_t id = impl_->userId(name);
  impl_->query("UPDATE users SET disabled = ? WHERE id = ?", disabled ? 1 : 0, qint64(id));
  impl_->audit(c.id, disabled ? "user.disable" : "user.enable", name, "");
  tx.commit();
}

void Store::unlock(const Session& s, const std::string& name) {
  const auto c = impl_->require(s, {Role::Admin});
  Impl::Tx tx(*impl_);
  const std::int64_t id = impl_->userId(name);
  impl_->query("UPDATE users SET failed_logins = 0, locked_until = NULL WHERE id = ?", qint64(id));
  impl_->audit(c.id, "user.unlock", name, "");
  tx.commit();
}

void Store::setPassword(const Session& s, const std::string& name, const std::string& password) {
  const auto c = impl_->current(s);
  if (c.role != Role::Admin && c.name != name) throw NotPermitted();
  checkPassword(password);
  const std::string hash = hashPassword(password, impl_->opt.opsLimit, impl_->opt.memLimit);
  Impl::Tx tx(*impl_);
  const std::int64_t id = impl_->userId(name);
  impl_->query("UPDATE users SET password_hash = ?, failed_logins = 0, locked_until = NULL WHERE id = ?", qs(hash),
               qint64(id));
  impl_->audit(c.id, "user.password", name, "");
  tx.commit();
}

std::vector<User> Store::users(const Session& s) const {
  impl_->require(s, {Role::Director, Role::Admin});
  QSqlQuery q = impl_->query("SELECT id, name, role, disabled, failed_logins, locked_until FROM users ORDER BY name");
  std::vector<User> out;
  while (q.next()) {
    User u;
    u.id = q.value(0).toLongLong();
    u.name = ss(q.value(1));
    u.role = roleFromString(ss(q.value(2)));
    u.disabled = q.value(3).toInt() != 0;
    u.failedLogins = q.value(4).toInt();
    if (!q.value(5).isNull()) u.lockedUntil = q.value(5).toLongLong();
    out.push_back(std::move(u));
  }
  return out;
}

// --- tasks ------------------------------------------------------------------------

void Store::saveTask(const Session& s, const TaskRecord& t) {
  const auto c = impl_->require(s, {Role::Author, Role::Admin});
  checkName("task id", t.id, 128);
  if (t.version < 1) throw InvalidArgument("task version must be at least 1");
  if (!t.json.is_object()) throw InvalidArgument("task JSON must be an object");
  Impl::Tx tx(*impl_);
  impl_->query(
      "INSERT INTO tasks (id, version, json, author_id, updated_at) VALUES (?, ?, ?, ?, ?)"
      " ON CONFLICT (id, version) DO UPDATE SET json = excluded.json, author_id = excluded.author_id,"
      " updated_at = excluded.updated_at",
      qs(t.id), t.version, qs(t.json.dump()), qint64(c.id), qint64(impl_->now()));
  impl_->audit(c.id, "task.save", t.id, "version " + std::to_string(t.version));
  tx.commit();
}

namespace {
TaskRecord readTask(QSqlQuery& q) {
  TaskRecord t;
  t.id = ss(q.value(0));
  t.version = q.value(1).toInt();
  t.json = nlohmann::json::parse(q.value(2).toString().toStdString(), nullptr, false);
  t.author = ss(q.value(3));
  t.updatedAt = q.value(4).toLongLong();
  return t;
}
}  // namespace

std::optional<TaskRecord> Store::task(const Session& s, const std::string& id, int version) const {
  impl_->current(s);
  QSqlQuery q = impl_->query(
      "SELECT t.id, t.version, t.json, COALESCE(u.name, ''), t.updated_at FROM tasks t"
      " LEFT JOIN users u ON u.id = t.author_id WHERE t.id = ? AND t.version = ?",
      qs(id), version);
  if (!q.next()) return std::nullopt;
  return readTask(q);
}

std::vector<TaskRecord> Store::tasks(const Session& s) const {
  impl_->current(s);
  QSqlQuery q = impl_->query(
      "SELECT t.id, t.version, t.json, COALESCE(u.name, ''), t.updated_at FROM tasks t"
      " LEFT JOIN users u ON u.id = t.author_id"
      " WHERE t.version = (SELECT max(version) FROM tasks t2 WHERE t2.id = t.id) ORDER BY t.id");
  std::vector<TaskRecord> out;
  while (q.next()) out.push_back(readTask(q));
  return out;
}

// --- assignments ------------------------------------------------------------------

std::int64_t Store::assign(const Session& s, const std::string& trainee, const std::string& taskId, TimeMs dueAt,
                           int repetitions) {
  const auto c = impl_->require(s, {Role::Director, Role::Admin});
  checkName("task id", taskId, 128);
  if (repetitions < 1) throw InvalidArgument("repetitions must be at least 1");
  Impl::Tx tx(*impl_);
  const std::int64_t uid = impl_->userId(trainee);
  QSqlQuery q = impl_->query(
      "INSERT INTO assignments (user_id, task_id, assigned_at, due_at, repetitions, assigned_by) VALUES (?, ?, ?, ?, "
      "?, ?)"
      " RETURNING id",
      qint64(uid), qs(taskId), qint64(impl_->now()), qint64(dueAt), repetitions, qint64(c.id));
  if (!q.next()) throw DbError(impl_->where + ": insert returned no id");
  const std::int64_t id = q.value(0).toLongLong();
  q.finish();
  impl_->audit(c.id, "assignment.create", trainee, taskId + " due " + isoTime(dueAt));
  tx.commit();
  return id;
}

std::vector<DueItem> Store::dueItems(const Session& s, const std::optional<std::string>& trainee,
                                     bool allTrainees) const {
  AttemptFilter f;
  f.trainee = trainee;
  f.allTrainees = allTrainees;
  const auto owner = impl_->attemptOwner(s, f);
  std::string sql =
      "SELECT s.id, u.name, s.task_id, s.assigned_at, s.due_at, s.repetitions,"
      " (SELECT count(*) FROM attempts a WHERE a.user_id = s.user_id AND a.task_id = s.task_id AND a.completed = 1"
      "  AND a.started_at >= s.assigned_at)"
      " FROM assignments s JOIN users u ON u.id = s.user_id";
  if (owner) sql += " WHERE s.user_id = ?";
  sql += " ORDER BY s.due_at, u.name, s.task_id";
  QSqlQuery q = impl_->prepare(sql);
  if (owner) q.addBindValue(QVariant::fromValue<qint64>(*owner));
  impl_->run(q);
  const TimeMs now = impl_->now();
  std::vector<DueItem> out;
  while (q.next()) {
    DueItem d;
    d.assignment.id = q.value(0).toLongLong();
    d.assignment.trainee = ss(q.value(1));
    d.assignment.taskId = ss(q.value(2));
    d.assignment.assignedAt = q.value(3).toLongLong();
    d.assignment.dueAt = q.value(4).toLongLong();
    d.assignment.repetitions = q.value(5).toInt();
    d.completedAttempts = q.value(6).toInt();
    d.state = d.completedAttempts >= d.assignment.repetitions ? DueState::Done
              : d.assignment.dueAt < now                      ? DueState::Overdue
                                                              : DueState::Due;
    out.push_back(std::move(d));
  }
  return out;
}

// --- attempts ---------------------------------------------------------------------

std::int64_t Store::recordAttempt(const Session& s, const AttemptRecord& a) {
  Impl& I = *impl_;
  const auto c = I.current(s);
  checkName("task id", a.taskId, 128);
  if (a.taskVersion < 1) throw InvalidArgument("task version must be at least 1");
  if (a.endedAt < a.startedAt) throw InvalidArgument("an attempt cannot end before it starts");
  if (!std::isfinite(a.score)) throw InvalidArgument("the score is not a finite number");
  if (!a.metrics.is_object()) throw InvalidArgument("attempt metrics must be a JSON object");
  if (a.device.size() > 256) throw InvalidArgument("device name too long");
  double duration = double(a.endedAt - a.startedAt) / 1000.0;
  if (a.metrics.contains("total_time_s") && a.metrics["total_time_s"].is_number())
    duration = a.metrics["total_time_s"].get<double>();
  QVariant deviation(QMetaType::fromType<double>());
  if (a.metrics.contains("deviation") && a.metrics["deviation"].is_object() &&
      a.metrics["deviation"].contains("total") && a.metrics["deviation"]["total"].is_number())
    deviation = a.metrics["deviation"]["total"].get<double>();
  // Compressed outside the transaction so that the write lock is held briefly.
  const QByteArray packed = qCompress(QByteArray::fromRawData(a.samples.data(), qsizetype(a.samples.size())), 3);

  Impl::Tx tx(I);
  QSqlQuery q = I.prepare(I.version >= 2 ? "INSERT INTO attempts (user_id, task_id, task_version, started_at, ended_at,"
                                           " completed, device, score, passed, metrics, duration_s, deviation_total)"
                                           " VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?) RETURNING id"
                                         : "INSERT INTO attempts (user_id, task_id, task_version, started_at, ended_at,"
                                           " completed, device, score, passed, metrics)"
                                           " VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?) RETURNING id");
  q.addBindValue(QVariant::fromValue<qint64>(c.id));
  q.addBindValue(qs(a.taskId));
  q.addBindValue(a.taskVersion);
  q.addBindValue(QVariant::fromValue<qint64>(a.startedAt));
  q.addBindValue(QVariant::fromValue<qint64>(a.endedAt));
  q.addBindValue(a.completed ? 1 : 0);
  q.addBindValue(qs(a.device));
  q.addBindValue(a.score);
  q.addBindValue(a.passed ? 1 : 0);
  q.addBindValue(qs(a.metrics.dump()));
  if (I.version >= 2) {
    q.addBindValue(duration);
    q.addBindValue(deviation);
  }
  I.run(q);
  if (!q.next()) throw DbError(I.where + ": insert returned no id");
  const std::int64_t id = q.value(0).toLongLong();
  q.finish();
  QSqlQuery qs2 = I.prepare("INSERT INTO attempt_samples (attempt_id, format, raw_size, data) VALUES (?, ?, ?, ?)");
  qs2.addBindValue(QVariant::fromValue<qint64>(id));
  qs2.addBindValue(qs(a.samplesFormat));
  qs2.addBindValue(QVariant::fromValue<qint64>(qint64(a.samples.size())));
  qs2.addBindValue(packed);
  I.run(qs2);
  tx.commit();
  return id;
}

std::vector<Attempt> Store::attempts(const Session& s, const AttemptFilter& f) const {
  return impl_->readAttempts(impl_->attemptOwner(s, f), f.taskId);
}

Samples Store::attemptSamples(const Session& s, std::int64_t attemptId) const {
  const auto c = impl_->current(s);
  QSqlQuery q = impl_->query(
      "SELECT a.user_id, s.format, s.raw_size, s.data FROM attempts a LEFT JOIN attempt_samples s ON s.attempt_id = "
      "a.id"
      " WHERE a.id = ?",
      qint64(attemptId));
  if (!q.next()) {
    if (!Impl::readsEveryone(c.role)) throw NotPermitted();
    throw NotFound("no attempt " + std::to_string(attemptId));
  }
  if (q.value(0).toLongLong() != c.id && !Impl::readsEveryone(c.role)) throw NotPermitted();
  Samples out;
  if (q.value(1).isNull()) return out;
  out.format = ss(q.value(1));
  const QByteArray raw = qUncompress(q.value(3).toByteArray());
  if (raw.size() != q.value(2).toLongLong())
    throw CorruptDatabase(impl_->where + ": the samples of attempt " + std::to_string(attemptId) + " are damaged");
  out.data.assign(raw.constData(), std::size_t(raw.size()));
  return out;
}

std::vector<CohortStats> Store::cohortStats(const Session& s) const {
  impl_->require(s, {Role::Director, Role::Admin});
  const bool v2 = impl_->version >= 2;
  QSqlQuery q = impl_->query(std::string("SELECT a.task_id, a.user_id, a.score, ") +
                             (v2 ? "a.duration_s, a.deviation_total" : "(a.ended_at - a.started_at) / 1000.0, NULL") +
                             ", a.passed FROM attempts a JOIN users u ON u.id = a.user_id"
                             " WHERE a.completed = 1 AND u.role = 'resident' ORDER BY a.task_id");
  struct Acc {
    std::vector<double> score, time, dev;
    std::set<std::int64_t> users;
    std::size_t passed = 0;
  };
  std::map<std::string, Acc> acc;
  while (q.next()) {
    Acc& a = acc[ss(q.value(0))];
    a.users.insert(q.value(1).toLongLong());
    a.score.push_back(q.value(2).toDouble());
    a.time.push_back(q.value(3).toDouble());
    if (!q.value(4).isNull()) a.dev.push_back(q.value(4).toDouble());
    a.passed += q.value(5).toInt() != 0;
  }
  std::vector<CohortStats> out;
  for (auto& [task, a] : acc) {
    CohortStats c;
    c.taskId = task;
    c.attempts = a.score.size();
    c.trainees = a.users.size();
    c.passRate = c.attempts ? double(a.passed) / double(c.attempts) : 0.0;
    c.score = summarize(std::move(a.score));
    c.timeS = summarize(std::move(a.time));
    c.deviation = summarize(std::move(a.dev));
    out.push_back(std::move(c));
  }
  return out;
}

std::string Store::exportCsv(const Session& s, const AttemptFilter& f) const {
  const auto rows = attempts(s, f);
  std::vector<std::vector<std::pair<std::string, nlohmann::json>>> flat(rows.size());
  std::set<std::string> keys;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    flattenJson(rows[i].metrics, "", flat[i]);
    for (const auto& [k, v] : flat[i]) keys.insert(k);
  }
  std::vector<std::string> header = {"attempt_id", "trainee",  "task_id",    "task_version",
                                     "started_at", "ended_at", "completed",  "device",
                                     "score",      "passed",   "duration_s", "deviation_total"};
  for (const auto& k : keys) header.push_back(csvText("metrics." + k));
  std::string out = csvRow(header);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const Attempt& a = rows[i];
    std::vector<std::string> cells = {
        std::to_string(a.id),          csvText(a.trainee),     csvText(a.taskId),
        std::to_string(a.taskVersion), isoTime(a.startedAt),   isoTime(a.endedAt),
        a.completed ? "1" : "0",       csvText(a.device),      csvNumber(a.score),
        a.passed ? "1" : "0",          csvNumber(a.durationS), a.deviationTotal ? csvNumber(*a.deviationTotal) : ""};
    std::map<std::string, const nlohmann::json*> byKey;
    for (const auto& [k, v] : flat[i]) byKey[k] = &v;
    for (const auto& k : keys) {
      auto it = byKey.find(k);
      if (it == byKey.end() || it->second->is_null()) {
        cells.emplace_back();
      } else if (it->second->is_number()) {
        cells.push_back(csvNumber(it->second->get<double>()));
      } else if (it->second->is_boolean()) {
        cells.emplace_back(it->second->get<bool>() ? "1" : "0");
      } else if (it->second->is_string()) {
        cells.push_back(csvText(it->second->get<std::string>()));
      } else {
        cells.push_back(csvText(it->second->dump()));
      }
    }
    out += csvRow(cells);
  }
  return out;
}

// --- administration ---------------------------------------------------------------

std::vector<AuditEntry> Store::auditLog(const Session& s, int limit) const {
  impl_->require(s, {Role::Admin});
  QSqlQuery q = impl_->query(
      "SELECT l.id, l.happened_at, COALESCE(u.name, ''), l.action, l.target, l.detail"
      " FROM audit_log l LEFT JOIN users u ON u.id = l.actor_id ORDER BY l.id DESC LIMIT ?",
      limit);
  std::vector<AuditEntry> out;
  while (q.next())
    out.push_back({q.value(0).toLongLong(), q.value(1).toLongLong(), ss(q.value(2)), ss(q.value(3)), ss(q.value(4)),
                   ss(q.value(5))});
  return out;
}

void Store::backup(const std::string& path) const {
  const Impl& I = *impl_;
  if (!I.sqlite()) throw Unsupported("backup of a PostgreSQL database: use pg_dump");
  const QFileInfo out(qs(path));
  if (out.isDir()) throw InvalidArgument(path + ": is a directory");
  if (out.exists() && out.canonicalFilePath() == QFileInfo(qs(I.ci.path)).canonicalFilePath())
    throw InvalidArgument(path + ": is the database itself");
  if (!out.absoluteDir().exists()) throw InvalidArgument(path + ": the folder does not exist");
  const std::string tmp = out.absoluteFilePath().toStdString() + ".part-" + std::to_string(::getpid());
  ::unlink(tmp.c_str());
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd < 0) throw DbError(tmp + ": cannot create: " + std::strerror(errno));
  ::close(fd);
  struct Cleanup {
    std::string p;
    bool keep = false;
    ~Cleanup() {
      if (!keep) ::unlink(p.c_str());
    }
  } cleanup{tmp};
#ifdef LD_DB_HAVE_SQLITE3
  const QVariant h = I.db.driver()->handle();
  if (!h.isValid() || std::strcmp(h.typeName(), "sqlite3*") != 0) throw DbError("no SQLite handle for the backup");
  sqlite3* src = *static_cast<sqlite3* const*>(h.constData());
  sqlite3* dst = nullptr;
  if (sqlite3_open_v2(tmp.c_str(), &dst, SQLITE_OPEN_READWRITE, nullptr) != SQLITE_OK) {
    const std::string err = dst ? sqlite3_errmsg(dst) : "out of memory";
    sqlite3_close(dst);
    throw DbError(tmp + ": " + err);
  }
  sqlite3_backup* b = sqlite3_backup_init(dst, "main", src, "main");
  if (!b) {
    const std::string err = sqlite3_errmsg(dst);
    sqlite3_close(dst);
    throw DbError(path + ": backup failed: " + err);
  }
  int rc;
  // Small steps let other connections write between them (online backup).
  while ((rc = sqlite3_backup_step(b, 256)) == SQLITE_OK || rc == SQLITE_BUSY || rc == SQLITE_LOCKED)
    if (rc != SQLITE_OK) sqlite3_sleep(5);
  sqlite3_backup_finish(b);
  const int final = sqlite3_errcode(dst);
  sqlite3_close(dst);
  if (rc != SQLITE_DONE || final != SQLITE_OK)
    throw DbError(path + ": backup failed (SQLite code " + std::to_string(rc) + ")");
#else
  ::unlink(tmp.c_str());
  QSqlQuery q(I.db);
  q.prepare("VACUUM INTO ?");
  q.addBindValue(qs(tmp));
  if (!q.exec()) I.fail(q.lastError(), "backup failed");
  ::chmod(tmp.c_str(), 0600);
#endif
  {
    const int f = ::open(tmp.c_str(), O_RDONLY | O_CLOEXEC);
    if (f >= 0) {
      ::fsync(f);
      ::close(f);
    }
  }
  if (::rename(tmp.c_str(), out.absoluteFilePath().toStdString().c_str()) != 0)
    throw DbError(path + ": cannot move the backup in place: " + std::strerror(errno));
  cleanup.keep = true;
  const int d = ::open(out.absolutePath().toStdString().c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (d >= 0) {
    ::fsync(d);
    ::close(d);
  }
}

}  // namespace ld::db
