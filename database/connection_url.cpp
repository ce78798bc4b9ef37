#include "database/connection_url.h"

#include <QUrl>

#include "database/db_error.h"

namespace ld::db {

std::string ConnectionInfo::display() const {
  if (kind == Kind::Sqlite) return path;
  std::string s = "postgresql://";
  if (!user.empty()) s += user + "@";
  return s + host + ":" + std::to_string(port) + "/" + database;
}

ConnectionInfo parseConnectionUrl(const std::string& url) {
  auto bad = [&](const std::string& why) { return InvalidArgument("database URL '" + url + "': " + why); };
  if (url.empty()) throw bad("empty");
  for (unsigned char c : url)
    if (c < 0x20) throw bad("contains a control character");
  ConnectionInfo ci;
  const auto scheme = url.find("://");
  if (scheme == std::string::npos) {
    if (url.find(':') != std::string::npos && url.find('/') == std::string::npos)
      throw bad("unknown form (use sqlite:///path, a file path or postgresql://user@host:port/db)");
    ci.path = url;  // a plain path
    return ci;
  }
  const std::string s = url.substr(0, scheme);
  if (s == "sqlite") {
    ci.path = url.substr(scheme + 3);
    if (ci.path.empty() || ci.path[0] != '/')
      throw bad("a sqlite URL needs an absolute path: sqlite:///path/to/file.db");
    // Keep percent-escapes usable for odd file names.
    ci.path = QUrl::fromPercentEncoding(QByteArray::fromStdString(ci.path)).toStdString();
    return ci;
  }
  if (s != "postgresql" && s != "postgres") throw bad("unknown scheme '" + s + "' (use sqlite or postgresql)");
  const QUrl u(QString::fromStdString(url), QUrl::StrictMode);
  if (!u.isValid()) throw bad(u.errorString().toStdString());
  ci.kind = ConnectionInfo::Kind::Postgres;
  ci.host = u.host().toStdString();
  ci.user = u.userName().toStdString();
  ci.password = u.password().toStdString();
  ci.port = u.port(5432);
  std::string db = u.path().toStdString();
  if (!db.empty() && db[0] == '/') db.erase(0, 1);
  ci.database = db;
  if (ci.host.empty()) throw bad("no host");
  if (ci.database.empty() || ci.database.find('/') != std::string::npos)
    throw bad("needs one database name after the host: postgresql://user@host:port/dbname");
  if (ci.port <= 0 || ci.port > 65535) throw bad("port out of range");
  return ci;
}

}  // namespace ld::db
