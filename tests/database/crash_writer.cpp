// Helper for crash_test: writes attempts in a loop until it is killed. It prints "ready"
// once logged in, then "RUN K" after each commit (unbuffered), so that the parent knows
// which attempts were committed.
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "database/store.h"
#include "tests/database/crash_payload.h"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: db_crash_writer URL RUN\n");
    return 2;
  }
  try {
    ld::db::Options o;
    o.opsLimit = 1;
    o.memLimit = 8192;
    auto store = ld::db::Store::open(argv[1], o);
    const auto session = store.login("writer", "writer-password");
    const int run = std::atoi(argv[2]);
    if (::write(1, "ready\n", 6) < 0) return 1;
    for (int k = 0;; ++k) {
      store.recordAttempt(session, ld::test::crashAttempt(run, k));
      const std::string line = std::to_string(run) + " " + std::to_string(k) + "\n";
      if (::write(1, line.data(), line.size()) < 0) return 1;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "db_crash_writer: %s\n", e.what());
    return 1;
  }
}
