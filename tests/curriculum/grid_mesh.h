#pragma once
// A tiny inline mesh for the curriculum tests: n x n unit squares on z = 0, two
// triangles each (diagonal from (i, j) to (i + 1, j + 1)), x and y in [0, n]. Open: the
// cutting engine cuts it through.
#include <vector>

#include "sim/mesh/surface_mesh.h"

namespace ld::curriculum::testmesh {

inline mesh::SurfaceMesh grid(int n) {
  mesh::SurfaceMesh m;
  std::vector<mesh::Vertex> v;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) v.push_back(m.addVertex(mesh::Point(i, j, 0)));
  auto id = [&](int i, int j) { return v[static_cast<std::size_t>(j * (n + 1) + i)]; };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      m.addFace(id(i, j), id(i + 1, j), id(i + 1, j + 1));
      m.addFace(id(i, j), id(i + 1, j + 1), id(i, j + 1));
    }
  return m;
}

}  // namespace ld::curriculum::testmesh
