#pragma once
// The trainee store: accounts, roles, tasks, assignments, attempts and their samples.
//
// One code path for SQLite (the default, a file in the user's application-data folder)
// and PostgreSQL (many workstations), chosen by a connection URL:
//   sqlite:///abs/path/file.db | /abs/or/relative/path.db | postgresql://user[:pw]@host[:port]/dbname
//
// Typical use by another module (e.g. `task run --db`):
//   auto store = ld::db::Store::open(url);                 // migrates, or throws
//   ld::db::Session s = store.login(name, password);       // throws AuthFailed
//   ld::db::AttemptRecord a; ... fill ...;
//   std::int64_t id = store.recordAttempt(s, a);           // one transaction
//
// Roles are enforced here, on every call, against the user's current row (a role change
// or a disabled account takes effect on the next call): a resident reads only their own
// attempts; a director reads everyone's; an author edits tasks; an admin manages users
// and may do everything the others may. Errors are the typed exceptions of db_error.h.
// A Store is a single connection: use it from the thread that opened it.
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "database/db_error.h"

namespace ld::db {

enum class Role { Resident, Director, Author, Admin };
std::string toString(Role r);
Role roleFromString(const std::string& s);  // throws InvalidArgument

// Milliseconds since the Unix epoch (UTC); all times in the store use it.
using TimeMs = std::int64_t;
std::string isoTime(TimeMs t);  // "2026-01-31T12:00:00.000Z"

struct Options {
  // Argon2id cost for new hashes; the defaults are libsodium's "interactive" limits.
  // Tests may lower them (crypto_pwhash_OPSLIMIT_MIN / MEMLIMIT_MIN) to stay fast.
  unsigned long long opsLimit = 2;             // crypto_pwhash_OPSLIMIT_INTERACTIVE
  std::size_t memLimit = 64u * 1024u * 1024u;  // crypto_pwhash_MEMLIMIT_INTERACTIVE
  std::function<TimeMs()> clock;               // empty: the system clock
  int maxFailedLogins = 5;
  TimeMs lockoutMs = 15 * 60 * 1000;
  // Run SQLite's quick_check at open so that damage is reported before anything is written.
  bool checkIntegrityOnOpen = true;
  // Apply migrations up to this version only (tests of old schemas); 0 = the latest.
  int migrateTo = 0;
};

// Who is logged in. Only Store creates sessions; the role is re-read on every call.
class Session {
 public:
  [[nodiscard]] std::int64_t userId() const { return userId_; }
  [[nodiscard]] const std::string& name() const { return name_; }
  [[nodiscard]] Role role() const { return role_; }

 private:
  friend class Store;
  Session(std::uint64_t store, std::int64_t id, std::string name, Role role)
      : store_(store), userId_(id), name_(std::move(name)), role_(role) {}
  std::uint64_t store_;
  std::int64_t userId_;
  std::string name_;
  Role role_;
};

struct User {
  std::int64_t id = 0;
  std::string name;
  Role role = Role::Resident;
  bool disabled = false;
  int failedLogins = 0;
  std::optional<TimeMs> lockedUntil;
};

struct TaskRecord {
  std::string id;
  int version = 1;
  nlohmann::json json;   // the task file's content
  std::string author;    // filled by the store on read
  TimeMs updatedAt = 0;  // filled by the store on read
};

// What a finished (or abandoned) task run stores.
struct AttemptRecord {
  std::string taskId;
  int taskVersion = 1;
  TimeMs startedAt = 0;
  TimeMs endedAt = 0;
  bool completed = true;  // false: abandoned
  std::string device;     // e.g. "scripted", "keyboard", "phantom-omni"
  double score = 0.0;
  bool passed = false;
  nlohmann::json metrics = nlohmann::json::object();  // the `task run` metrics object
  std::string samples;                                // the pose stream / metric series, any bytes; stored compressed
  std::string samplesFormat = "trajectory-csv";
};

struct Attempt {
  std::int64_t id = 0;
  std::string trainee;
  std::string taskId;
  int taskVersion = 1;
  TimeMs startedAt = 0;
  TimeMs endedAt = 0;
  bool completed = true;
  std::string device;
  double score = 0.0;
  bool passed = false;
  double durationS = 0.0;                // metrics.total_time_s, else end - start
  std::optional<double> deviationTotal;  // metrics.deviation.total when present
  nlohmann::json metrics;
  std::size_t samplesBytes = 0;  // uncompressed size of the stored samples
};

struct AttemptFilter {
  std::optional<std::string> trainee;  // empty: the session's own attempts
  std::optional<std::string> taskId;
  bool allTrainees = false;  // director/admin: everyone's
};

struct Samples {
  std::string format;
  std::string data;
};

// Quartiles by linear interpolation between order statistics (R type 7).
struct Summary {
  std::size_t n = 0;
  double q1 = 0, median = 0, q3 = 0, min = 0, max = 0;
};

struct CohortStats {
  std::string taskId;
  std::size_t attempts = 0;  // completed attempts by residents
  std::size_t trainees = 0;
  Summary score, timeS, deviation;  // deviation over attempts that report one
  double passRate = 0.0;
};

struct Assignment {
  std::int64_t id = 0;
  std::string trainee;
  std::string taskId;
  TimeMs assignedAt = 0;
  TimeMs dueAt = 0;
  int repetitions = 1;
};

enum class DueState { Done, Due, Overdue };
std::string toString(DueState s);

struct DueItem {
  Assignment assignment;
  int completedAttempts = 0;  // completed attempts on the task since it was assigned
  DueState state = DueState::Due;
};

struct AuditEntry {
  std::int64_t id = 0;
  TimeMs at = 0;
  std::string actor;  // empty: the system
  std::string action;
  std::string target;
  std::string detail;
};

class Store {
 public:
  // Opens (creating a SQLite file when absent, mode 0600) and migrates. Throws
  // InvalidArgument (bad URL), CorruptDatabase, SchemaTooNew or DbError.
  static Store open(const std::string& url, Options options = {});
  // sqlite:// URL of the default file in the user's application-data folder.
  static std::string defaultUrl();
  static int latestSchemaVersion();

  Store(Store&&) noexcept;
  Store& operator=(Store&&) noexcept;
  ~Store();

  [[nodiscard]] int schemaVersion() const;
  [[nodiscard]] bool isSqlite() const;
  [[nodiscard]] const std::string& location() const;  // file path or URL without password

  // --- accounts -------------------------------------------------------------------
  [[nodiscard]] bool hasUsers() const;
  // The first start: creates the administrator; AlreadyExists when any user exists.
  Session createFirstAdmin(const std::string& name, const std::string& password);
  // Throws AuthFailed (invalid credentials, or locked after too many failures).
  Session login(const std::string& name, const std::string& password);
  void addUser(const Session& s, const std::string& name, Role role, const std::string& password);  // admin
  void setRole(const Session& s, const std::string& name, Role role);                               // admin
  void setDisabled(const Session& s, const std::string& name, bool disabled);                       // admin
  void unlock(const Session& s, const std::string& name);                                           // admin
  void setPassword(const Session& s, const std::string& name, const std::string& password);         // admin or self
  [[nodiscard]] std::vector<User> users(const Session& s) const;                                    // director, admin

  // --- tasks ----------------------------------------------------------------------
  void saveTask(const Session& s, const TaskRecord& t);  // author, admin
  [[nodiscard]] std::optional<TaskRecord> task(const Session& s, const std::string& id, int version) const;
  [[nodiscard]] std::vector<TaskRecord> tasks(const Session& s) const;  // latest version of each

  // --- curriculum assignments -----------------------------------------------------
  std::int64_t assign(const Session& s, const std::string& trainee, const std::string& taskId, TimeMs dueAt,
                      int repetitions = 1);  // director, admin
  // Own items for anyone; trainee/all for director and admin (allTrainees or a name).
  [[nodiscard]] std::vector<DueItem> dueItems(const Session& s, const std::optional<std::string>& trainee = {},
                                              bool allTrainees = false) const;

  // --- attempts -------------------------------------------------------------------
  // Stores an attempt of the session's user, all of it or nothing. Returns its id.
  std::int64_t recordAttempt(const Session& s, const AttemptRecord& a);
  // Ordered by task, then start time (a trainee's attempts over time per task).
  [[nodiscard]] std::vector<Attempt> attempts(const Session& s, const AttemptFilter& f = {}) const;
  [[nodiscard]] Samples attemptSamples(const Session& s, std::int64_t attemptId) const;
  // Per task, over completed attempts of residents: director, admin.
  [[nodiscard]] std::vector<CohortStats> cohortStats(const Session& s) const;
  // CSV of attempts (same permissions as attempts()), one column per metric (dotted keys).
  [[nodiscard]] std::string exportCsv(const Session& s, const AttemptFilter& f = {}) const;

  // --- administration -------------------------------------------------------------
  [[nodiscard]] std::vector<AuditEntry> auditLog(const Session& s, int limit = 1000) const;  // admin
  // Online backup of a SQLite store to `path` (written beside it, then renamed; 0600).
  // Unsupported for PostgreSQL (use pg_dump).
  void backup(const std::string& path) const;

  struct Impl;

 private:
  explicit Store(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace ld::db
