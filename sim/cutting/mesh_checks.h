#pragma once
// Checks the cutter promises to keep: manifold vertices (one fan of faces each),
// closedness, finite positions, and the size of the smallest triangle.
#include "sim/mesh/surface_mesh.h"

namespace ld::cutting {

struct MeshQuality {
  double minArea = 0.0;          // smallest triangle area [mm²]
  double minAngleDeg = 0.0;      // smallest triangle angle [degrees]
  double minEdge = 0.0;          // shortest edge [mm]
  bool manifoldVertices = true;  // every vertex's faces form one fan (no pinched vertex)
  bool closed = false;           // no boundary edge
  bool finite = true;            // no NaN or infinite position
  int components = 0;
};

// One pass over the mesh (O(size)); for tests, the CLI and reports, not per sample.
MeshQuality measureQuality(const mesh::SurfaceMesh& m);

// True when the faces around v form a single fan (connected through edges at v).
bool isManifoldVertex(const mesh::SurfaceMesh& m, mesh::Vertex v);

}  // namespace ld::cutting
