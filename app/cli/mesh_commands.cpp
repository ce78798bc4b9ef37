// lapdissect-cli mesh ...: not implemented yet.
#include "app/cli/cli.h"

namespace ld::cli {

int runMesh(const Args&) { throw CliError(kInternal, "'mesh' is not implemented yet"); }

}  // namespace ld::cli
