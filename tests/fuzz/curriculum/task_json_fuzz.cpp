// Fuzz target: the task and curriculum JSON loaders must refuse bad input with
// FormatError and never crash or throw anything else.
#include <cstddef>
#include <cstdint>
#include <string>

#include "curriculum/curriculum_error.h"
#include "curriculum/curriculum_plan.h"
#include "curriculum/json_check.h"
#include "curriculum/task.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace ld::curriculum;
  const std::string text(reinterpret_cast<const char*>(data), size);
  nlohmann::json j;
  try {
    j = parseJsonText(text, "fuzz.json");
  } catch (const FormatError&) {
    return 0;
  }
  try {
    const Task t = parseTask(j, "fuzz.json");
    (void)contentHash(t);
    (void)parseTask(toJson(t), "again");  // what we write we read back
  } catch (const FormatError&) {
  }
  try {
    TaskLibrary lib;
    (void)parseCurriculum(j, "fuzz.json", &lib);
  } catch (const FormatError&) {
  }
  return 0;
}
