#pragma once
// Mesh generators for tests, benchmarks and the command line's built-in scenes.
// Lengths in millimetres; all triangles counter-clockwise seen from outside.
#include <span>
#include <vector>

#include <Eigen/Core>

#include "sim/mesh/surface_mesh.h"

namespace ld::physics {

// Flat nx × ny-cell patch in the z = 0 plane, spacing h, normals +z.
[[nodiscard]] mesh::SurfaceMesh makeGrid(int nx, int ny, double h);

// The same patch with a slit: the first `slitCells` edges of row ny/2, starting at
// the boundary x = 0, are cut (their vertices duplicated for the faces below).
[[nodiscard]] mesh::SurfaceMesh makeSlitGrid(int nx, int ny, double h, int slitCells);

// Closed box surface over the lattice xs × ys × zs (strictly increasing coordinates).
[[nodiscard]] mesh::SurfaceMesh makeBox(std::span<const double> xs, std::span<const double> ys,
                                        std::span<const double> zs);

// The default tissue: an sx × sy × sz closed slab with edge spacing about h.
[[nodiscard]] mesh::SurfaceMesh makeSlab(double sx = 80.0, double sy = 60.0, double sz = 5.0, double h = 4.0);

// A slab with a line of sliver triangles: an extra lattice column `sliverWidth`
// next to the middle one.
[[nodiscard]] mesh::SurfaceMesh makeSliverSlab(double sx, double sy, double sz, double h, double sliverWidth);

// A slab of about `triangles` triangles (4:3 footprint, 5 mm thick).
[[nodiscard]] mesh::SurfaceMesh makeSlabWithTriangles(int triangles);

// The live vertex nearest p.
[[nodiscard]] mesh::Vertex nearestVertex(const mesh::SurfaceMesh& m, const Eigen::Vector3d& p);
// The vertex on top (largest z) nearest the centre of the bounding box in x and y.
[[nodiscard]] mesh::Vertex topCentreVertex(const mesh::SurfaceMesh& m);

}  // namespace ld::physics
