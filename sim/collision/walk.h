#pragma once
// The thesis's fast path from the last hit: a contact that moved a little is found
// on the same face or on a face sharing an edge or a vertex with it, and a contact
// that moved farther by walking across edges towards it (a visibility walk over
// the surface). Both are exact for what they visit, and local: they do not see
// other layers or other parts of the mesh, so the complete answer remains the BVH
// query (TriangleBvh::intersectSegment); use these to follow one contact cheaply.
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "sim/collision/segment_triangle.h"
#include "sim/mesh/surface_mesh.h"

namespace ld::collision {

// f first, then every face sharing an edge or a vertex with f, each once.
void faceNeighbourhood(const mesh::SurfaceMesh& m, mesh::Face f, std::vector<mesh::Face>& out);

// Faces around a hit's feature: for OnVertex the faces around the vertex, for OnEdge
// the faces around both end vertices, else the face's neighbourhood.
void hitNeighbourhood(const mesh::SurfaceMesh& m, const SurfaceHit& h, std::vector<mesh::Face>& out);

// Hits of segment a->b on f and its edge/vertex neighbours, canonical and sorted.
void intersectNeighbourhood(const mesh::SurfaceMesh& m, mesh::Face f, const Eigen::Vector3d& a,
                            const Eigen::Vector3d& b, std::vector<SurfaceHit>& out, const Tolerance& tol = {});

// Walks from `start` across edges towards the face where the line through a, b
// crosses the surface, at most maxSteps faces. Returns that face's hit when the
// segment reaches it, nothing when the walk leaves the mesh, runs parallel, or
// finds the crossing off the segment.
std::optional<SurfaceHit> walkToHit(const mesh::SurfaceMesh& m, mesh::Face start, const Eigen::Vector3d& a,
                                    const Eigen::Vector3d& b, int maxSteps = 64, const Tolerance& tol = {});

}  // namespace ld::collision
