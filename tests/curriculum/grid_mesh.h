#pragma once
// A tiny inline mesh for the curriculum tests: n x n unit squares on z = 0, two
// triangles each (diagonal from (i, j) to (i + 1, j + 1)), x and y in [0, n]. Open: the
// cutting engine cuts it through. The mesh tests' grid.
#include "tests/sim/mesh/grid_mesh.h"

namespace ld::curriculum::testmesh {

using mesh::test::grid;

}  // namespace ld::curriculum::testmesh
