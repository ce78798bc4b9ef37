#pragma once
// The tissue's physical data, stored as properties of the surface mesh so that the
// cutter, the renderer and the integrators share one source of truth:
//   vertex "v:home"     Eigen::Vector3d  home (undeformed) position  [mm]
//   vertex "v:mass"     double           lumped mass                 [kg]
//   vertex "v:velocity" Eigen::Vector3d  velocity                    [mm/s]
//   vertex "v:force"    Eigen::Vector3d  external force, added every step [mN]
//   edge   "e:rest"     double           rest length of the mesh spring [mm]
//   edge   "e:k"        double           stiffness of the mesh spring   [mN/mm]
// Mesh positions (mesh.positions()) are the current positions.
//
// Units: millimetres, kilograms, seconds; forces in mN (kg·mm/s²).
//
// After a topology edit the cutter calls the init* hooks for every new vertex and
// every new or changed edge. Rules (thesis ch. 3-4, with the differences noted):
//  - New vertex on an edge or in a face: home and velocity are interpolated from the
//    parent vertices (the thesis sets the home to the vertex's position at creation;
//    choose NewVertexHome::Current for that). Interpolating keeps a cut through a
//    deformed, tensioned tissue from shifting its rest shape.
//  - Duplicated vertex (splitVertex / separateEdge): same home and velocity.
//  - New or changed edge: rest = restRatio × |home_a − home_b|, k = K / rest, exactly
//    as an edge at load (the thesis pre-stretches every mesh spring the same way);
//    half-edges of a split edge thus keep their share of the parent's tension.
//  - Masses: lumped, one third of each incident triangle's area measured at the home
//    positions, times the areal density (or uniform). Every hook recomputes the
//    masses of the touched vertex and its one-ring, so the total mass of the tissue
//    is conserved by splits (the areas of the pieces add up to the parent's area).
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "sim/mesh/surface_mesh.h"

namespace ld::physics {

inline constexpr const char* kHomeProp = "v:home";
inline constexpr const char* kMassProp = "v:mass";
inline constexpr const char* kVelocityProp = "v:velocity";
inline constexpr const char* kForceProp = "v:force";
inline constexpr const char* kRestProp = "e:rest";
inline constexpr const char* kStiffnessProp = "e:k";

enum class NewVertexHome {
  Interpolated,  // from the parents' homes (default)
  Current,       // the vertex's position when it is created (the thesis)
};

struct TissueParams {
  double restRatio = 0.7;    // rest length = ratio × initial length (pre-stretch)
  double K = 10.0;           // mesh spring constant [mN]; k = K / rest  [mN/mm]
  double homeK = 10.0;       // home spring stiffness per vertex        [mN/mm]
  double damping = 15.0;     // velocity damping rate [1/s]: f = −damping·m·v
  double density = 5e-6;     // areal density [kg/mm²] (≈ 1000 kg/m³ × 5 mm)
  bool uniformMass = false;  // every vertex gets vertexMass
  double vertexMass = 1e-4;  // [kg], used when uniformMass
  double minMass = 1e-9;     // floor for vertices with (near) zero area
  double minRest = 1e-3;     // floor for rest lengths [mm] (bounds k = K / rest)
  // Selective mass scaling, off at 0: no vertex is lighter than dt² · (homeK + 2·Σk of
  // its springs), which bounds ω·dt ≤ 1 for a symplectic step of this size
  // (Gershgorin). Short edges made by cutting (k = K / rest) are stiff and light and
  // would otherwise force substeps; equilibria do not change, only inertia. [s]
  double massFloorDt = 0.0;
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();  // [mm/s²]; off by default
  NewVertexHome newVertexHome = NewVertexHome::Interpolated;
  // Gauss-Seidel passes of settleVertices over what a cut adds; 0: the vertices start
  // where the cutter put them (the thesis).
  int settleSweeps = 10;
};

// The six properties of one mesh, looked up by name once (a lookup searches the mesh's
// property names: it was most of a hook's cost). A caller that runs many hooks (the
// cutter, several per edit) keeps one and passes `of(m)` to the hooks' overloads below;
// it looks the properties up again only when m is another mesh or m's property set has
// changed (SurfaceMesh::propertySetVersion). Missing properties stay null: each hook
// requires what it reads and throws MissingPropertyError, as without the handles.
struct TissueHandles {
  mesh::VertexProperty<Eigen::Vector3d> home, vel, force;
  mesh::VertexProperty<double> mass;
  mesh::EdgeProperty<double> rest, k;
  std::vector<mesh::Vertex> ring;  // a hook's one-ring (scratch)

  TissueHandles() = default;
  explicit TissueHandles(const mesh::SurfaceMesh& m) { lookUp(m); }
  TissueHandles& of(const mesh::SurfaceMesh& m) {
    if (mesh_ != &m || version_ != m.propertySetVersion()) lookUp(m);
    return *this;
  }

 private:
  void lookUp(const mesh::SurfaceMesh& m);
  const mesh::SurfaceMesh* mesh_ = nullptr;
  std::uint64_t version_ = 0;
};

// True when all six properties exist on the mesh.
[[nodiscard]] bool hasTissueProperties(const mesh::SurfaceMesh& m);

// Adds (or overwrites) the properties: home = current position, zero velocity and
// external force, rest = ratio × current length, k = K / rest, lumped masses.
void attachTissueProperties(mesh::SurfaceMesh& m, const TissueParams& p);

// v was inserted on the segment a→b at parameter t (0 at a, 1 at b).
void initVertexOnEdge(mesh::SurfaceMesh& m, mesh::Vertex v, mesh::Vertex a, mesh::Vertex b, double t,
                      const TissueParams& p);
// v was inserted inside the triangle (a, b, c) at barycentric coordinates bary.
void initVertexInFace(mesh::SurfaceMesh& m, mesh::Vertex v, mesh::Vertex a, mesh::Vertex b, mesh::Vertex c,
                      const Eigen::Vector3d& bary, const TissueParams& p);
// Same, naming the face (its three vertices as they are when called).
void initVertexInFace(mesh::SurfaceMesh& m, mesh::Vertex v, mesh::Face f, const Eigen::Vector3d& bary,
                      const TissueParams& p);
// v is a copy of original (splitVertex, separateEdge): same home and velocity.
void initVertexCopy(mesh::SurfaceMesh& m, mesh::Vertex v, mesh::Vertex original, const TissueParams& p);
// Only the state of initVertexCopy (home, velocity, zero force), for a caller that calls
// initEdgesAround on v and original afterwards anyway (once its edit is complete): the
// springs and masses are computed once, with the edit's final faces.
void copyVertexState(mesh::SurfaceMesh& m, mesh::Vertex v, mesh::Vertex original);
// e is new or its end vertices changed: rest from the homes × ratio, k = K / rest.
void initEdge(mesh::SurfaceMesh& m, mesh::Edge e, const TissueParams& p);

// Recomputes the lumped masses of the given vertices from their incident faces'
// areas at the home positions (or sets the uniform mass).
void redistributeMass(mesh::SurfaceMesh& m, std::span<const mesh::Vertex> vertices, const TissueParams& p);
// initEdge for every edge of each live vertex, then redistributeMass of them (what the
// cutter does for the vertices an edit touched), the properties looked up once.
void initEdgesAround(mesh::SurfaceMesh& m, std::span<const mesh::Vertex> vertices, const TissueParams& p);
// The same for every live vertex.
void recomputeMasses(mesh::SurfaceMesh& m, const TissueParams& p);

// The hooks with the properties at hand (h = handles.of(m)): the same results.
void initVertexOnEdge(mesh::SurfaceMesh& m, TissueHandles& h, mesh::Vertex v, mesh::Vertex a, mesh::Vertex b, double t,
                      const TissueParams& p);
void initVertexInFace(mesh::SurfaceMesh& m, TissueHandles& h, mesh::Vertex v, mesh::Vertex a, mesh::Vertex b,
                      mesh::Vertex c, const Eigen::Vector3d& bary, const TissueParams& p);
void initVertexCopy(mesh::SurfaceMesh& m, TissueHandles& h, mesh::Vertex v, mesh::Vertex original,
                    const TissueParams& p);
void copyVertexState(TissueHandles& h, mesh::Vertex v, mesh::Vertex original);
void initEdge(mesh::SurfaceMesh& m, TissueHandles& h, mesh::Edge e, const TissueParams& p);
void redistributeMass(mesh::SurfaceMesh& m, TissueHandles& h, std::span<const mesh::Vertex> vertices,
                      const TissueParams& p);
void initEdgesAround(mesh::SurfaceMesh& m, TissueHandles& h, std::span<const mesh::Vertex> vertices,
                     const TissueParams& p);

// Lumped mass of one vertex from its faces' home areas (what redistributeMass sets).
[[nodiscard]] double lumpedMass(const mesh::SurfaceMesh& m, mesh::Vertex v, const TissueParams& p);

// ---- settling what a cut adds ----------------------------------------------------
// A cut puts its vertices on the blade, where one side of their springs has just been
// cut away: stepped from there, a light vertex springs toward its balance and, with a
// tissue's light velocity damping, rings for a second or more (seen: a lip flapping a
// millimetre above the surface at the end of a cut, the cut recorded at rest wavering
// across the drawn line). Settling moves them to their balance at once, as in an
// overdamped tissue: the wound opens without ringing.
inline constexpr const char* kSettledProp = "v:settled";  // std::uint8_t, 1 once settled

// The live vertices not settled yet, leaving out any within 1e-6 mm of a point of
// `keep` (a cut's tips on the blade, which the cutter places; they are settled once
// the cut has moved on or ended). A mesh without the property gets it, every vertex
// settled (nothing to return).
[[nodiscard]] std::vector<mesh::Vertex> unsettledVertices(mesh::SurfaceMesh& m,
                                                          std::span<const Eigen::Vector3d> keep = {});

// Moves each vertex of `vertices` toward where its mesh springs and home spring
// balance, every other vertex held (p.settleSweeps Gauss-Seidel passes over them; a
// move that would turn one of its faces by more than 60° is halved until none does: a
// balance past a neighbour folds the surface), gives it the
// mean velocity of its neighbours outside the set (zero without any) and marks it
// settled. With settleSweeps = 0 the vertices are only marked. Requires the tissue
// properties (MissingPropertyError).
void settleVertices(mesh::SurfaceMesh& m, std::span<const mesh::Vertex> vertices, const TissueParams& p);

}  // namespace ld::physics
