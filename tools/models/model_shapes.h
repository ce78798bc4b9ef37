#pragma once
// Procedural default models (tissue slab, disc, cylinder, organ) as indexed triangle
// lists, and writers for OBJ, VRML 1.0 and VRML 2.0. Plain C++ so that the generator
// builds without the rest of the project.
#include <array>
#include <cstdint>
#include <functional>
#include <ostream>
#include <string>
#include <vector>

namespace ld::models {

using Vec3 = std::array<double, 3>;
using Tri = std::array<std::uint32_t, 3>;

struct TriMesh {
  std::vector<Vec3> points;
  std::vector<Tri> triangles;  // counter-clockwise seen from outside
};

// Closed box [-sx/2, sx/2] x [-sy/2, sy/2] x [-sz/2, sz/2] made of nx x ny x nz lattice
// cells; each rectangular cell is split in two with alternating diagonals.
TriMesh makeSlab(double sx, double sy, double sz, int nx, int ny, int nz);

// Closed disc of the given radius and thickness, axis along z, centred at the origin.
// Each cap is a set of concentric rings (ring i has 6i points) so triangles stay
// close to equilateral; `rings` rings per cap, `layers` rows on the rim.
TriMesh makeDisc(double radius, double thickness, int rings, int layers);

// Closed cylinder along z (length `height`, centred), caps built like the disc's.
TriMesh makeCylinder(double radius, double height, int rings, int layers);

// A smooth closed organ-like blob about 100 x 70 x 40 mm: a subdivided icosahedron
// (frequency n, 20 n^2 triangles) mapped onto a bent, tapered, bumpy ellipsoid, then
// relaxed on that surface so the triangles are even.
TriMesh makeOrgan(int frequency, int relaxIterations);

struct MeshCheck {
  bool closed = false;    // every directed edge has exactly one reverse partner
  bool manifold = false;  // no directed edge is used twice, no repeated vertex
  bool outward = false;   // positive enclosed volume
  int components = 0;
  double volume = 0.0;
  double minAngleDeg = 0.0;  // smallest triangle angle
  double maxAspect = 0.0;    // longest edge / shortest altitude
  Vec3 min{}, max{};
  std::string problem;  // first problem found, empty if none
};
MeshCheck check(const TriMesh& m);

// The bundled models: resources/models/<name>.obj, and <name>_v1.wrl / <name>_v2.wrl
// when `vrml`.
struct ModelSpec {
  std::string name;
  std::string description;
  std::function<TriMesh()> make;
  bool vrml = false;
};
std::vector<ModelSpec> defaultModels();

void writeObj(const TriMesh& m, std::ostream& out, const std::string& comment);
void writeVrml1(const TriMesh& m, std::ostream& out, const std::string& comment);
void writeVrml2(const TriMesh& m, std::ostream& out, const std::string& comment);

}  // namespace ld::models
