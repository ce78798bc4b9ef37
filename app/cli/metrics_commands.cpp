// lapdissect-cli metrics ...: not implemented yet.
#include "app/cli/cli.h"

namespace ld::cli {

int runMetrics(const Args&) { throw CliError(kInternal, "'metrics' is not implemented yet"); }

}  // namespace ld::cli
