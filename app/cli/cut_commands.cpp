// lapdissect-cli cut ...: not implemented yet.
#include "app/cli/cli.h"

namespace ld::cli {

int runCut(const Args&) { throw CliError(kInternal, "'cut' is not implemented yet"); }

}  // namespace ld::cli
