#pragma once
// Parsing of the store's connection URL (see store.h).
#include <string>

namespace ld::db {

struct ConnectionInfo {
  enum class Kind { Sqlite, Postgres } kind = Kind::Sqlite;
  std::string path;  // SQLite file
  std::string host, user, password, database;
  int port = 5432;
  // For messages: the path, or the URL without its password.
  [[nodiscard]] std::string display() const;
};

// Throws InvalidArgument naming the URL and what is wrong with it.
ConnectionInfo parseConnectionUrl(const std::string& url);

}  // namespace ld::db
