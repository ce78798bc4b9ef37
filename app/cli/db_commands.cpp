// lapdissect-cli db ...: administration of the trainee store (contract in DESIGN.md and
// issue 5). Passwords come only on standard input, one per line, never as arguments.
#include <sys/stat.h>

#include <cstdlib>
#include <fstream>
#include <functional>
#include <iostream>
#include <string>

#include <sodium.h>

#include "app/cli/cli.h"
#include "database/store.h"

namespace ld::cli {
namespace {

// Erases itself so that a password does not linger in freed memory.
struct Secret {
  std::string value;
  Secret() = default;
  Secret(const Secret&) = delete;
  Secret& operator=(const Secret&) = delete;
  ~Secret() {
    if (!value.empty()) sodium_memzero(value.data(), value.size());
  }
};

void readSecret(Secret& s, const std::string& whose) {
  if (!std::getline(std::cin, s.value))
    throw CliError(kBadInput, "standard input: expected the password of " + whose + " on a line of its own");
  if (!s.value.empty() && s.value.back() == '\r') s.value.pop_back();
}

// LAPDISSECT_INSECURE_FAST_HASH=1 gives new password hashes the minimal Argon2id cost, so that
// the command-line tests, which create many accounts, stay fast. Never set it elsewhere:
// the weak cost stays in the stored hashes.
db::Options cliOptions() {
  db::Options o;
  const char* fast = std::getenv("LAPDISSECT_INSECURE_FAST_HASH");
  if (fast && std::string(fast) == "1") {
    std::cerr << "warning: LAPDISSECT_INSECURE_FAST_HASH=1: new password hashes use the minimal Argon2id cost "
                 "(tests only)\n";
    o.opsLimit = crypto_pwhash_OPSLIMIT_MIN;
    o.memLimit = crypto_pwhash_MEMLIMIT_MIN;
  }
  return o;
}

nlohmann::json attemptJson(const db::Attempt& a) {
  nlohmann::json j = {{"id", a.id},
                      {"trainee", a.trainee},
                      {"task_id", a.taskId},
                      {"task_version", a.taskVersion},
                      {"started_at", db::isoTime(a.startedAt)},
                      {"ended_at", db::isoTime(a.endedAt)},
                      {"started_at_ms", a.startedAt},
                      {"ended_at_ms", a.endedAt},
                      {"completed", a.completed},
                      {"device", a.device},
                      {"score", a.score},
                      {"passed", a.passed},
                      {"duration_s", a.durationS},
                      {"metrics", a.metrics},
                      {"samples_bytes", a.samplesBytes}};
  j["deviation_total"] = a.deviationTotal ? nlohmann::json(*a.deviationTotal) : nlohmann::json(nullptr);
  return j;
}

nlohmann::json summaryJson(const db::Summary& s) {
  return {{"n", s.n}, {"min", s.min}, {"q1", s.q1}, {"median", s.median}, {"q3", s.q3}, {"max", s.max}};
}

db::Session loginAs(db::Store& store, const std::string& name) {
  Secret pw;
  readSecret(pw, name);
  return store.login(name, pw.value);
}

// Without --trainee: your own attempts, or everyone's when your role reads everyone's.
db::AttemptFilter filterFrom(const Args& args, const db::Session& s) {
  db::AttemptFilter f;
  if (args.has("trainee")) f.trainee = args.get("trainee");
  if (args.has("task")) f.taskId = args.get("task");
  f.allTrainees = !f.trainee && (s.role() == db::Role::Director || s.role() == db::Role::Admin);
  return f;
}

db::AttemptRecord attemptFromFile(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw CliError(kBadInput, file + ": cannot read");
  const auto j = nlohmann::json::parse(in, nullptr, false);
  if (!j.is_object()) throw CliError(kBadInput, file + ": not a JSON object");
  db::AttemptRecord a;
  try {
    a.taskId = j.at("task_id").get<std::string>();
    a.taskVersion = j.value("task_version", 1);
    a.startedAt = j.at("started_at_ms").get<std::int64_t>();
    a.endedAt = j.at("ended_at_ms").get<std::int64_t>();
    a.completed = j.value("completed", true);
    a.device = j.value("device", std::string("unknown"));
    a.score = j.at("score").get<double>();
    a.passed = j.value("passed", false);
    a.metrics = j.value("metrics", nlohmann::json::object());
  } catch (const nlohmann::json::exception& e) {
    throw CliError(kBadInput, file + ": " + e.what());
  }
  if (j.contains("samples_file")) {
    const std::string sf = j["samples_file"].get<std::string>();
    std::ifstream s(sf, std::ios::binary);
    if (!s) throw CliError(kBadInput, file + ": samples_file '" + sf + "' cannot be read");
    a.samples.assign(std::istreambuf_iterator<char>(s), std::istreambuf_iterator<char>());
  }
  return a;
}

int dispatch(const Args& args) {
  const std::string& cmd =
      args.pos(0, "db command (init, user add, login, attempts, export, backup, record, stats, due)");
  const std::string url = args.get("db", db::Store::defaultUrl());

  if (cmd == "init") {
    auto store = db::Store::open(url, cliOptions());
    nlohmann::json out = {{"schema_version", store.schemaVersion()}, {"created", false}};
    if (!store.hasUsers()) {
      const std::string& admin = args.get("admin");
      Secret pw;
      readSecret(pw, admin);
      store.createFirstAdmin(admin, pw.value);
      out["created"] = true;
      out["admin"] = admin;
    }
    printJson(out);
    return kOk;
  }
  if (cmd == "user") {
    const std::string& sub = args.pos(1, "user command (add)");
    if (sub != "add") throw CliError(kBadInput, "unknown command 'db user " + sub + "' (add)");
    const db::Role role = db::roleFromString(args.get("role"));
    const std::string& newName = args.get("name");
    auto store = db::Store::open(url, cliOptions());
    const db::Session s = loginAs(store, args.get("as"));
    Secret pw;
    readSecret(pw, newName);
    store.addUser(s, newName, role, pw.value);
    printJson({{"user", newName}, {"role", db::toString(role)}});
    return kOk;
  }
  if (cmd == "login") {
    auto store = db::Store::open(url, cliOptions());
    const db::Session s = loginAs(store, args.get("name"));
    printJson({{"user", s.name()}, {"role", db::toString(s.role())}});
    return kOk;
  }
  if (cmd == "attempts") {
    auto store = db::Store::open(url, cliOptions());
    const db::Session s = loginAs(store, args.get("as"));
    nlohmann::json arr = nlohmann::json::array();
    for (const auto& a : store.attempts(s, filterFrom(args, s))) arr.push_back(attemptJson(a));
    printJson(arr);
    return kOk;
  }
  if (cmd == "export") {
    const std::string& file = args.get("csv");
    auto store = db::Store::open(url, cliOptions());
    const db::Session s = loginAs(store, args.get("as"));
    const auto f = filterFrom(args, s);
    const std::string csv = store.exportCsv(s, f);
    {
      // Personal records: readable by the owner only.
      const mode_t old = ::umask(077);
      std::ofstream out(file, std::ios::binary | std::ios::trunc);
      ::umask(old);
      if (!out) throw CliError(kBadInput, file + ": cannot write");
      out << csv;
      if (!out.flush()) throw CliError(kInternal, file + ": write failed");
    }
    std::size_t rows = 0;
    for (char c : csv) rows += c == '\n';
    printJson({{"csv", file}, {"rows", rows - 1}});
    return kOk;
  }
  if (cmd == "backup") {
    const std::string& file = args.get("out");
    auto store = db::Store::open(url, cliOptions());
    store.backup(file);
    struct stat st {};
    ::stat(file.c_str(), &st);
    printJson({{"backup", file},
               {"bytes", static_cast<std::int64_t>(st.st_size)},
               {"schema_version", store.schemaVersion()}});
    return kOk;
  }
  if (cmd == "record") {
    const auto rec = attemptFromFile(args.get("attempt"));
    auto store = db::Store::open(url, cliOptions());
    const db::Session s = loginAs(store, args.get("as"));
    printJson({{"attempt_id", store.recordAttempt(s, rec)}});
    return kOk;
  }
  if (cmd == "stats") {
    auto store = db::Store::open(url, cliOptions());
    const db::Session s = loginAs(store, args.get("as"));
    nlohmann::json arr = nlohmann::json::array();
    for (const auto& c : store.cohortStats(s))
      arr.push_back({{"task_id", c.taskId},
                     {"attempts", c.attempts},
                     {"trainees", c.trainees},
                     {"pass_rate", c.passRate},
                     {"score", summaryJson(c.score)},
                     {"time_s", summaryJson(c.timeS)},
                     {"deviation", summaryJson(c.deviation)}});
    printJson(arr);
    return kOk;
  }
  if (cmd == "due") {
    auto store = db::Store::open(url, cliOptions());
    const db::Session s = loginAs(store, args.get("as"));
    const auto f = filterFrom(args, s);
    nlohmann::json arr = nlohmann::json::array();
    for (const auto& d : store.dueItems(s, f.trainee, f.allTrainees))
      arr.push_back({{"trainee", d.assignment.trainee},
                     {"task_id", d.assignment.taskId},
                     {"due_at", db::isoTime(d.assignment.dueAt)},
                     {"repetitions", d.assignment.repetitions},
                     {"completed_attempts", d.completedAttempts},
                     {"state", db::toString(d.state)}});
    printJson(arr);
    return kOk;
  }
  throw CliError(kBadInput, "unknown command 'db " + cmd + "'");
}

}  // namespace

int withStoreErrors(const std::function<int()>& fn) {
  try {
    return fn();
  } catch (const db::AuthFailed& e) {
    throw CliError(kAuthFailed, e.what());
  } catch (const db::NotPermitted& e) {
    throw CliError(kNotPermitted, e.what());
  } catch (const db::InvalidArgument& e) {
    throw CliError(kBadInput, e.what());
  } catch (const db::CorruptDatabase& e) {
    throw CliError(kBadInput, e.what());
  } catch (const db::SchemaTooNew& e) {
    throw CliError(kBadInput, e.what());
  } catch (const db::NotFound& e) {
    throw CliError(kBadInput, e.what());
  } catch (const db::AlreadyExists& e) {
    throw CliError(kBadInput, e.what());
  } catch (const db::Unsupported& e) {
    throw CliError(kBadInput, e.what());
  } catch (const db::DbError& e) {
    throw CliError(kInternal, e.what());
  }
}

int runDb(const Args& args) {
  return withStoreErrors([&] { return dispatch(args); });
}

}  // namespace ld::cli
