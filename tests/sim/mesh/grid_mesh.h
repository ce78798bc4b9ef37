#pragma once
#include "sim/mesh/surface_mesh.h"

namespace ld::mesh::test {

// n x n grid of quads on [0,n]^2, each split into two triangles (vertex (i, j) is
// j·(n+1)+i).
inline SurfaceMesh grid(int n) {
  SurfaceMesh m;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) m.addVertex({double(i), double(j), 0.0});
  auto v = [&](int i, int j) { return Vertex(j * (n + 1) + i); };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      m.addFace(v(i, j), v(i + 1, j), v(i + 1, j + 1));
      m.addFace(v(i, j), v(i + 1, j + 1), v(i, j + 1));
    }
  return m;
}

}  // namespace ld::mesh::test
