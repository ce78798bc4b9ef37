// lapdissect-cli metrics ...: the assessment metrics on their own.
//   metrics deviation --drawn CSV --cut CSV  ->  {"xy","yz","xz","total"}
#include "app/cli/cli.h"
#include "curriculum/curriculum_error.h"
#include "curriculum/metrics/deviation.h"
#include "curriculum/polyline_csv.h"

namespace ld::cli {
namespace {

curriculum::Polyline readPolyline(const std::string& file) {
  try {
    return curriculum::readPolylineCsv(file);
  } catch (const curriculum::FormatError& e) {
    throw CliError(kBadInput, e.problems().empty() ? std::string(e.what()) : e.problems().front());
  }
}

nlohmann::json deviationJson(const curriculum::Deviation& d) {
  return {{"xy", d.xy}, {"yz", d.yz}, {"xz", d.xz}, {"total", d.total()}};
}

}  // namespace

int runMetrics(const Args& args) {
  const std::string& cmd = args.pos(0, "metrics command (deviation)");
  if (cmd != "deviation") throw CliError(kBadInput, "unknown command 'metrics " + cmd + "' (deviation)");
  const curriculum::Polyline drawn = readPolyline(args.get("drawn"));
  const curriculum::Polyline cut = readPolyline(args.get("cut"));
  nlohmann::json j = deviationJson(curriculum::deviation(drawn, cut));
  j["thesis"] = deviationJson(curriculum::deviationThesis(drawn, cut));
  printJson(j);
  return kOk;
}

}  // namespace ld::cli
