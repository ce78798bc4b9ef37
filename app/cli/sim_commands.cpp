// lapdissect-cli sim ...: not implemented yet.
#include "app/cli/cli.h"

namespace ld::cli {

int runSim(const Args&) { throw CliError(kInternal, "'sim' is not implemented yet"); }

}  // namespace ld::cli
