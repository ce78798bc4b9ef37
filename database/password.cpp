#include "database/password.h"

#include <sodium.h>

#include "database/db_error.h"

namespace ld::db {
namespace {

void initSodium() {
  static const int rc = sodium_init();
  if (rc < 0) throw DbError("libsodium failed to initialise");
}

}  // namespace

std::string hashPassword(const std::string& password, unsigned long long opsLimit, std::size_t memLimit) {
  initSodium();
  char out[crypto_pwhash_STRBYTES];
  if (crypto_pwhash_str_alg(out, password.data(), password.size(), opsLimit, memLimit, crypto_pwhash_ALG_ARGON2ID13) !=
      0)
    throw DbError("password hashing failed (out of memory?)");
  return std::string(out);
}

bool verifyPassword(const std::string& hash, const std::string& password) {
  initSodium();
  if (hash.size() >= crypto_pwhash_STRBYTES) return false;
  return crypto_pwhash_str_verify(hash.c_str(), password.data(), password.size()) == 0;
}

bool hashNeedsRehash(const std::string& hash, unsigned long long opsLimit, std::size_t memLimit) {
  initSodium();
  return crypto_pwhash_str_needs_rehash(hash.c_str(), opsLimit, memLimit) != 0;
}

void verifyDummy(const std::string& password, unsigned long long opsLimit, std::size_t memLimit) {
  // A hash of a random secret with the current cost: verification fails in the usual time.
  static thread_local std::string dummy;
  static thread_local unsigned long long dOps = 0;
  static thread_local std::size_t dMem = 0;
  if (dummy.empty() || dOps != opsLimit || dMem != memLimit) {
    unsigned char secret[16];
    initSodium();
    randombytes_buf(secret, sizeof secret);
    dummy = hashPassword(std::string(reinterpret_cast<char*>(secret), sizeof secret), opsLimit, memLimit);
    dOps = opsLimit;
    dMem = memLimit;
  }
  (void)verifyPassword(dummy, password);
}

}  // namespace ld::db
