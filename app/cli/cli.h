#pragma once
// lapdissect-cli: argument handling shared by the command groups. Each group lives
// in its own file (mesh_commands.cpp, sim_commands.cpp, ...) and receives the
// arguments after the group word.
#include <functional>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace ld::cli {

// Exit codes fixed by DESIGN.md (3 and 4 by the trainee store's commands).
enum ExitCode : int { kOk = 0, kInternal = 1, kBadInput = 2, kAuthFailed = 3, kNotPermitted = 4 };

// Thrown by commands; main prints what() on one line to stderr and exits with code().
class CliError : public std::runtime_error {
 public:
  CliError(int code, const std::string& msg) : std::runtime_error(msg), code_(code) {}
  [[nodiscard]] int code() const { return code_; }

 private:
  int code_;
};

struct Args {
  std::vector<std::string> positional;         // words that are not options
  std::map<std::string, std::string> options;  // --name value (name without dashes)

  // Every "--name" takes the next word as its value.
  static Args parse(const std::vector<std::string>& words);
  [[nodiscard]] bool has(const std::string& name) const { return options.count(name) > 0; }
  // Throws CliError(kBadInput) when the option is missing.
  [[nodiscard]] const std::string& get(const std::string& name) const;
  [[nodiscard]] std::string get(const std::string& name, const std::string& fallback) const;
  [[nodiscard]] double getDouble(const std::string& name) const;
  [[nodiscard]] double getDouble(const std::string& name, double fallback) const;
  // The i-th positional word, or throws CliError(kBadInput) naming `what`.
  [[nodiscard]] const std::string& pos(std::size_t i, const std::string& what) const;
};

// Prints compact JSON and a newline on stdout.
void printJson(const nlohmann::json& j);

// Runs fn, turning the trainee store's exceptions into CliError with the fixed exit
// codes (3 failed login, 4 not permitted, 2 bad input, 1 internal).
int withStoreErrors(const std::function<int()>& fn);

int runMesh(const Args& args);
int runSim(const Args& args);
int runCut(const Args& args);
int runMetrics(const Args& args);
int runTask(const Args& args);
int runDb(const Args& args);

}  // namespace ld::cli
