// lapdissect-cli: the headless command-line tool (contract in DESIGN.md).
#include <cmath>
#include <exception>
#include <iostream>
#include <string>
#include <vector>

#include "app/cli/cli.h"

namespace ld::cli {

Args Args::parse(const std::vector<std::string>& words) {
  Args a;
  for (std::size_t i = 0; i < words.size(); ++i) {
    const std::string& w = words[i];
    if (w.size() > 2 && w.rfind("--", 0) == 0) {
      if (i + 1 >= words.size()) throw CliError(kBadInput, "option " + w + " needs a value");
      a.options[w.substr(2)] = words[++i];
    } else {
      a.positional.push_back(w);
    }
  }
  return a;
}

const std::string& Args::get(const std::string& name) const {
  auto it = options.find(name);
  if (it == options.end()) throw CliError(kBadInput, "missing option --" + name);
  return it->second;
}

std::string Args::get(const std::string& name, const std::string& fallback) const {
  auto it = options.find(name);
  return it == options.end() ? fallback : it->second;
}

double Args::getDouble(const std::string& name) const {
  const std::string& s = get(name);
  try {
    std::size_t used = 0;
    double v = std::stod(s, &used);
    if (used != s.size() || !std::isfinite(v)) throw std::invalid_argument(s);
    return v;
  } catch (const std::exception&) {
    throw CliError(kBadInput, "option --" + name + ": '" + s + "' is not a number");
  }
}

double Args::getDouble(const std::string& name, double fallback) const {
  return has(name) ? getDouble(name) : fallback;
}

const std::string& Args::pos(std::size_t i, const std::string& what) const {
  if (i >= positional.size()) throw CliError(kBadInput, "missing " + what);
  return positional[i];
}

void printJson(const nlohmann::json& j) { std::cout << j.dump() << std::endl; }

}  // namespace ld::cli

namespace {

const char* kUsage =
    "usage: lapdissect-cli GROUP ...\n"
    "  mesh info FILE | mesh convert IN OUT | mesh slab --triangles N --out FILE\n"
    "  cut --mesh FILE --trajectory CSV [--physics off|on [--active-region off|on] [--collision-margin MM]]"
    " [--out FILE]\n"
    "  sim bench --scene NAME|FILE --method NAME --dt S --duration S | sim chart --out DIR\n"
    "  metrics deviation --drawn CSV --cut CSV\n"
    "  task validate FILE | task run --task JSON --trajectory CSV [--physics still|on|off] [--db URL --trainee NAME]\n"
    "  db init|user add|login|attempts|export|backup ...\n";

}  // namespace

int main(int argc, char** argv) {
  using namespace ld::cli;
  std::vector<std::string> words(argv + 1, argv + argc);
  if (words.empty() || words[0] == "--help" || words[0] == "-h") {
    std::cerr << kUsage;
    return words.empty() ? kBadInput : kOk;
  }
  const std::string group = words[0];
  words.erase(words.begin());
  try {
    const Args args = Args::parse(words);
    if (group == "mesh") return runMesh(args);
    if (group == "sim") return runSim(args);
    if (group == "cut") return runCut(args);
    if (group == "metrics") return runMetrics(args);
    if (group == "task") return runTask(args);
    if (group == "db") return runDb(args);
    std::cerr << "unknown command group '" << group << "'\n" << kUsage;
    return kBadInput;
  } catch (const CliError& e) {
    std::cerr << e.what() << "\n";
    return e.code();
  } catch (const std::exception& e) {
    std::cerr << "internal error: " << e.what() << "\n";
    return kInternal;
  }
}
