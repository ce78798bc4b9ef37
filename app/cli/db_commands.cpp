// lapdissect-cli db ...: not implemented yet.
#include "app/cli/cli.h"

namespace ld::cli {

int runDb(const Args&) { throw CliError(kInternal, "'db' is not implemented yet"); }

}  // namespace ld::cli
