#pragma once
// Typed errors of the trainee store (ld::db). Every message is one line meant for the user.
#include <stdexcept>
#include <string>

namespace ld::db {

// Base of everything the store throws.
class DbError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The connection URL, a name, a role or another argument is malformed.
class InvalidArgument : public DbError {
 public:
  using DbError::DbError;
};

// The file is not a database of ours or is damaged; it is left as it is.
class CorruptDatabase : public DbError {
 public:
  using DbError::DbError;
};

// The schema is newer than this program; the database is left as it is.
class SchemaTooNew : public DbError {
 public:
  using DbError::DbError;
};

// Login refused. locked() tells "account locked" apart from "invalid credentials".
class AuthFailed : public DbError {
 public:
  AuthFailed(bool locked) : DbError(locked ? "locked" : "invalid credentials"), locked_(locked) {}
  [[nodiscard]] bool locked() const { return locked_; }

 private:
  bool locked_;
};

// The session's role does not allow the call.
class NotPermitted : public DbError {
 public:
  NotPermitted() : DbError("not permitted") {}
};

// A named user, task or attempt does not exist, or a name is already taken.
class NotFound : public DbError {
 public:
  using DbError::DbError;
};
class AlreadyExists : public DbError {
 public:
  using DbError::DbError;
};

// The operation does not exist for this backend (e.g. file backup of PostgreSQL).
class Unsupported : public DbError {
 public:
  using DbError::DbError;
};

}  // namespace ld::db
