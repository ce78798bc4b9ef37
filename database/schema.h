#pragma once
// Versioned schema of the store. Each migration moves the schema one version up; all the
// pending ones run in one transaction at open, so a failure leaves the old version intact.
#include <functional>
#include <string>
#include <vector>

class QSqlDatabase;

namespace ld::db::schema {

enum class Dialect { Sqlite, Postgres };

struct Migration {
  int version;                          // the version reached after it
  std::vector<std::string> statements;  // with {ID}, {REAL}, {BLOB} placeholders
  // Data changes that need code (run after the statements, inside the transaction).
  std::function<void(QSqlDatabase&, Dialect)> code;
};

const std::vector<Migration>& migrations();
int latestVersion();
// Replaces the type placeholders for the dialect.
std::string render(const std::string& sql, Dialect d);

}  // namespace ld::db::schema
