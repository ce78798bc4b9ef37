#include <cstdint>
#include <string_view>

#include "devices/trajectory.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    ld::devices::parseTrajectoryCsv(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.csv");
  } catch (const ld::devices::ParseError&) {
  }
  return 0;
}
