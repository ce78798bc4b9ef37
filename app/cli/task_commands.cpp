// lapdissect-cli task ...: tasks and curricula.
//   task validate FILE
//   task run --task JSON --trajectory CSV [--physics still|on|off] [--db URL --trainee NAME]   (password on stdin)
//     --physics still (default): the grasper's stretch force is the force of its penalty
//     springs on the simulated (mass-spring) tissue, while the blade and the drawn path
//     see the tissue held still, as the window holds it while the blade is in it (the
//     cutter loses tracks on tissue moving under the blade, sim/cutting/README.md, which
//     would count against the trainee). on: the tissue moves under the blade too. off:
//     no physics; the force is the estimate home stiffness x grasper displacement.
//   task script --task JSON --level 0..3 [--seed N] [--rate HZ] --out CSV   (scripted trainee)
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <utility>

#include "app/cli/cli.h"
#include "curriculum/curriculum_error.h"
#include "curriculum/curriculum_plan.h"
#include "curriculum/json_check.h"
#include "curriculum/scripted_trainee.h"
#include "curriculum/task.h"
#include "curriculum/task_runner.h"
#include "curriculum/tissue_path.h"
#include "database/store.h"
#include "devices/trajectory.h"
#include "sim/io/mesh_io.h"

namespace ld::cli {
namespace {

namespace fs = std::filesystem;
using namespace ld::curriculum;

[[noreturn]] void badInput(const std::vector<std::string>& problems, const std::string& file) {
  // Every problem on its own line; the last line (from main) sums up.
  for (std::size_t i = 0; i + 1 < problems.size(); ++i) std::cerr << problems[i] << "\n";
  if (problems.empty()) throw CliError(kBadInput, file + ": invalid");
  throw CliError(kBadInput, problems.back());
}

mesh::SurfaceMesh loadModel(const Task& t, const std::string& taskFile, std::vector<std::string>& problems,
                            bool& found) {
  found = false;
  const fs::path model = resolveModel(t, taskFile);
  if (model.empty()) {
    problems.push_back(taskFile + ": /model/file: '" + t.model +
                       "' not found (looked above the task file's folder and in the working directory)");
    return {};
  }
  try {
    mesh::SurfaceMesh m = io::readMesh(model);
    const double scale = t.units == "cm" ? 10.0 : t.units == "m" ? 1000.0 : 1.0;
    if (scale != 1.0)
      for (mesh::Vertex v : m.vertices()) m.position(v) *= scale;
    found = true;
    return m;
  } catch (const io::ParseError& e) {
    problems.push_back(e.what());
  } catch (const io::IoError& e) {
    problems.push_back(e.what());
  }
  return {};
}

// The task and its model, or exit 2 naming what is wrong.
std::pair<Task, mesh::SurfaceMesh> loadTaskAndModel(const std::string& taskFile) {
  Task task;
  try {
    task = loadTask(taskFile);
  } catch (const FormatError& e) {
    badInput(e.problems(), taskFile);
  }
  std::vector<std::string> problems;
  bool found = false;
  mesh::SurfaceMesh m = loadModel(task, taskFile, problems, found);
  if (!found) badInput(problems, taskFile);
  return {std::move(task), std::move(m)};
}

int validate(const std::string& file) {
  nlohmann::json j;
  try {
    j = readJsonFile(file);
  } catch (const FormatError& e) {
    badInput(e.problems(), file);
  }
  const std::string format = j.is_object() && j.contains("format") && j["format"].is_string()
                                 ? j["format"].get<std::string>()
                                 : std::string("lapdissect-task");
  if (format == "lapdissect-curriculum") {
    // Task references are checked against the task folder next to the curriculum's.
    const fs::path tasks = fs::absolute(file).parent_path().parent_path() / "tasks";
    std::optional<TaskLibrary> lib;
    std::vector<std::string> problems;
    if (fs::is_directory(tasks)) {
      try {
        lib = TaskLibrary::loadFolder(tasks);
      } catch (const FormatError& e) {
        problems = e.problems();
      }
    }
    const auto errs = validateCurriculum(j, file, lib ? &*lib : nullptr);
    problems.insert(problems.end(), errs.begin(), errs.end());
    if (!problems.empty()) badInput(problems, file);
    const Curriculum c = parseCurriculum(j, file, lib ? &*lib : nullptr);
    printJson({{"valid", true},
               {"kind", "curriculum"},
               {"id", c.id},
               {"version", c.version},
               {"modules", c.modules.size()},
               {"tasks_checked", lib.has_value()}});
    return kOk;
  }
  std::vector<std::string> problems = validateTask(j, file);
  if (!problems.empty()) badInput(problems, file);
  const Task t = parseTask(j, file);
  bool found = false;
  const mesh::SurfaceMesh m = loadModel(t, file, problems, found);
  if (found) {
    // Every point of the path must lie on the model's surface.
    std::size_t piece = 0, k = 0;
    for (const auto& q : t.path) {
      double d = 0.0;
      closestLocation(m, q.p, &d);
      if (d > 0.5) {
        std::ostringstream os;
        os << file << ": /path/pieces/" << piece << "/" << k << ": " << d << " mm from the surface of " << t.model
           << " (at most 0.5 mm)";
        problems.push_back(os.str());
      }
      ++k;
      if (q.stop) {
        ++piece;
        k = 0;
      }
    }
  }
  if (!problems.empty()) badInput(problems, file);
  printJson({{"valid", true},
             {"kind", "task"},
             {"id", t.id},
             {"version", t.version},
             {"hash", contentHash(t)},
             {"pieces", pieces(t.path).size()},
             {"points", t.path.size()}});
  return kOk;
}

std::string readPassword(const std::string& whose) {
  std::string pw;
  if (!std::getline(std::cin, pw))
    throw CliError(kBadInput, "standard input: expected the password of " + whose + " on a line of its own");
  if (!pw.empty() && pw.back() == '\r') pw.pop_back();
  return pw;
}

int run(const Args& args) {
  const std::string& taskFile = args.get("task");
  const std::string& trajFile = args.get("trajectory");
  if (args.has("db") != args.has("trainee")) throw CliError(kBadInput, "--db and --trainee go together");
  const std::string physicsMode = args.get("physics", "still");
  if (physicsMode != "still" && physicsMode != "on" && physicsMode != "off")
    throw CliError(kBadInput, "option --physics: expected 'still', 'on' or 'off', found '" + physicsMode + "'");
  RunOptions options;
  options.physics = physicsMode != "off";
  options.holdUnderBlade = physicsMode == "still";
  const auto loaded = loadTaskAndModel(taskFile);
  const Task& task = loaded.first;
  const mesh::SurfaceMesh& m = loaded.second;
  devices::Trajectory tr;
  std::string trajText;
  try {
    std::ifstream in(trajFile, std::ios::binary);
    if (!in) throw CliError(kBadInput, trajFile + ":0: cannot be read");
    std::ostringstream ss;
    ss << in.rdbuf();
    trajText = ss.str();
    tr = devices::parseTrajectoryCsv(trajText, trajFile);
  } catch (const devices::ParseError& e) {
    throw CliError(kBadInput, e.what());
  }
  RunResult r;
  try {
    r = runTask(task, m, tr, options);
  } catch (const PathError& e) {
    throw CliError(kBadInput, taskFile + ": /path: " + e.what());
  }
  nlohmann::json out = runJson(task, r);
  if (args.has("db")) {
    const std::string& trainee = args.get("trainee");
    withStoreErrors([&] {
      auto store = db::Store::open(args.get("db"));
      const std::string pw = readPassword(trainee);
      const db::Session s = store.login(trainee, pw);
      db::AttemptRecord rec;
      rec.taskId = task.id;
      rec.taskVersion = task.version;
      const auto nowMs =
          std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
              .count();
      rec.endedAt = nowMs;
      rec.startedAt = nowMs - static_cast<db::TimeMs>(std::llround(r.metrics.totalTimeS * 1000.0));
      rec.completed = true;
      rec.device = "scripted";
      rec.score = r.assessment.score;
      rec.passed = r.assessment.passed;
      rec.metrics = out;
      rec.samples = trajText;
      rec.samplesFormat = "trajectory-csv";
      out["attempt_id"] = store.recordAttempt(s, rec);
      return kOk;
    });
  }
  printJson(out);
  return kOk;
}

// Writes a scripted trainee's trajectory (level 0 = expert, 1..3 = novices).
int script(const Args& args) {
  const std::string& taskFile = args.get("task");
  const auto loaded = loadTaskAndModel(taskFile);
  const Task& task = loaded.first;
  const mesh::SurfaceMesh& m = loaded.second;
  const double level = args.getDouble("level", 0.0), seed = args.getDouble("seed", 1.0),
               rate = args.getDouble("rate", 250.0);
  if (level < 0 || level > 3 || level != std::floor(level))
    throw CliError(kBadInput, "option --level: must be 0 (expert) to 3");
  if (!(rate >= 1 && rate <= 100000)) throw CliError(kBadInput, "option --rate: must be 1 to 100000 Hz");
  if (seed < 0 || seed > 4294967295.0 || seed != std::floor(seed))
    throw CliError(kBadInput, "option --seed: must be a whole number");
  const auto profile = traineeProfile(static_cast<int>(level), static_cast<unsigned>(seed));
  const devices::Trajectory tr = scriptedAttempt(task, m, profile, rate);
  const std::string& outFile = args.get("out");
  std::ofstream out(outFile);
  if (!out) throw CliError(kBadInput, outFile + ": cannot be written");
  devices::writeTrajectoryCsv(tr, out);
  if (!out) throw CliError(kInternal, outFile + ": write failed");
  printJson({{"trajectory", outFile},
             {"profile", profile.name},
             {"samples", tr.samples.size()},
             {"duration_s", tr.duration()}});
  return kOk;
}

}  // namespace

int runTask(const Args& args) {
  const std::string& cmd = args.pos(0, "task command (validate, run, script)");
  if (cmd == "validate") return validate(args.pos(1, "task or curriculum file"));
  if (cmd == "run") return run(args);
  if (cmd == "script") return script(args);
  throw CliError(kBadInput, "unknown command 'task " + cmd + "' (validate, run, script)");
}

}  // namespace ld::cli
