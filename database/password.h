#pragma once
// Argon2id password hashes (libsodium's crypto_pwhash_str), verified in constant time.
#include <cstddef>
#include <string>

namespace ld::db {

// "$argon2id$v=19$m=...". Throws DbError when libsodium fails (out of memory).
std::string hashPassword(const std::string& password, unsigned long long opsLimit, std::size_t memLimit);
bool verifyPassword(const std::string& hash, const std::string& password);
bool hashNeedsRehash(const std::string& hash, unsigned long long opsLimit, std::size_t memLimit);
// Burns the same time as a real verification, for unknown user names.
void verifyDummy(const std::string& password, unsigned long long opsLimit, std::size_t memLimit);

}  // namespace ld::db
