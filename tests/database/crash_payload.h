#pragma once
// The attempts db_crash_writer writes; crash_test checks each stored one against these.
#include <cstdint>
#include <string>

#include "database/store.h"

namespace ld::test {

inline std::string crashSamples(int run, int k) {
  // Between 2 KB and 200 KB so that kills land inside transactions of varied length.
  std::uint64_t x = 0x9E3779B97F4A7C15ull * std::uint64_t(run * 100003 + k + 1);
  const std::size_t n = 2000 + std::size_t(x % 198000);
  std::string s(n, '\0');
  for (std::size_t i = 0; i < n; ++i) {
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    s[i] = static_cast<char>('a' + (x % 16));  // compressible, but not trivially
  }
  return s;
}

inline db::AttemptRecord crashAttempt(int run, int k) {
  db::AttemptRecord a;
  a.taskId = "crash-task";
  a.taskVersion = 1;
  a.startedAt = 1'780'000'000'000 + run * 1'000'000 + k;
  a.endedAt = a.startedAt + 1000;
  a.device = "crash-writer";
  a.score = k;
  a.passed = (k % 2) == 0;
  a.samples = crashSamples(run, k);
  a.metrics = {{"run", run}, {"k", k}, {"samples_size", a.samples.size()}, {"total_time_s", 1.0}};
  return a;
}

}  // namespace ld::test
