// Stand-in for libFuzzer when the compiler has none: runs every file of a seed
// corpus, then a fixed number of seeded random mutations of them (byte flips,
// truncations, insertions, splices). A crash or sanitizer report fails the test.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

std::vector<std::uint8_t> readFile(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void mutate(std::vector<std::uint8_t>& d, std::mt19937_64& rng, const std::vector<std::vector<std::uint8_t>>& corpus) {
  static const char* tokens[] = {"{", "}", "[", "]", ",", "nan", "-1", "1e308", "\n", "#", "999999999", "0", " "};
  const int ops = 1 + static_cast<int>(rng() % 4);
  for (int k = 0; k < ops; ++k) {
    const std::size_t pos = d.empty() ? 0 : rng() % (d.size() + 1);
    switch (rng() % 6) {
      case 0:
        if (!d.empty()) d[rng() % d.size()] ^= static_cast<std::uint8_t>(1u << (rng() % 8));
        break;
      case 1:
        d.resize(pos);
        break;
      case 2: {
        const char* t = tokens[rng() % std::size(tokens)];
        d.insert(d.begin() + static_cast<std::ptrdiff_t>(pos), t, t + std::strlen(t));
        break;
      }
      case 3:
        if (!d.empty()) d.erase(d.begin() + static_cast<std::ptrdiff_t>(pos == d.size() ? pos - 1 : pos));
        break;
      case 4:
        if (!d.empty()) d[rng() % d.size()] = static_cast<std::uint8_t>(rng());
        break;
      case 5: {
        const auto& other = corpus[rng() % corpus.size()];
        if (!other.empty()) {
          const std::size_t from = rng() % other.size();
          const std::size_t len = std::min<std::size_t>(other.size() - from, 1 + rng() % 64);
          d.insert(d.begin() + static_cast<std::ptrdiff_t>(pos), other.begin() + static_cast<std::ptrdiff_t>(from),
                   other.begin() + static_cast<std::ptrdiff_t>(from + len));
        }
        break;
      }
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::filesystem::path> inputs;
  long iterations = 1000;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--iterations" && i + 1 < argc) {
      iterations = std::stol(argv[++i]);
    } else if (std::filesystem::is_directory(a)) {
      for (const auto& e : std::filesystem::recursive_directory_iterator(a))
        if (e.is_regular_file()) inputs.push_back(e.path());
    } else if (std::filesystem::is_regular_file(a)) {
      inputs.push_back(a);
    }
  }
  std::sort(inputs.begin(), inputs.end());
  std::vector<std::vector<std::uint8_t>> corpus;
  for (const auto& p : inputs) corpus.push_back(readFile(p));
  if (corpus.empty()) corpus.emplace_back();
  for (const auto& c : corpus) LLVMFuzzerTestOneInput(c.data(), c.size());
  std::mt19937_64 rng(12345);
  for (long i = 0; i < iterations; ++i) {
    auto d = corpus[rng() % corpus.size()];
    mutate(d, rng, corpus);
    LLVMFuzzerTestOneInput(d.data(), d.size());
  }
  std::printf("fuzz driver: %zu seeds, %ld mutations, no crash\n", corpus.size(), iterations);
  return 0;
}
