// lapdissect-cli task ...: not implemented yet.
#include "app/cli/cli.h"

namespace ld::cli {

int runTask(const Args&) { throw CliError(kInternal, "'task' is not implemented yet"); }

}  // namespace ld::cli
