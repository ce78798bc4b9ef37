// Fuzz target: the ply reader and the processing chain behind it.
#include "tests/fuzz/io/fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return ld::io::fuzz::run(ld::io::Format::Ply, data, size);
}
