#pragma once
// Authoring helpers for new tasks: a polyline drawn in the view is projected onto
// the surface (the nearest hit along each view ray), resampled to a spacing,
// smoothed, snapped back onto the surface, and saved in a task.
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "curriculum/metrics/polyline.h"
#include "curriculum/tissue_path.h"
#include "sim/mesh/surface_mesh.h"

namespace ld::curriculum {

struct Ray {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d dir = Eigen::Vector3d(0, 0, -1);
};

// Nearest hit of the ray (t >= 0) with the surface, or nothing. `t` receives the
// distance along dir (dir need not be unit: t is in units of dir).
std::optional<SurfaceLocation> castRay(const mesh::SurfaceMesh& m, const Ray& ray, double* t = nullptr);

// One point per ray; a ray that misses ends the piece before it.
Polyline projectOntoSurface(const mesh::SurfaceMesh& m, const std::vector<Ray>& rays);

// Points at equal arc length (at most `spacing` apart) along each piece, ends kept.
Polyline resamplePath(const Polyline& path, double spacing);

// Laplacian smoothing of the inner points of each piece (ends fixed).
Polyline smoothPath(const Polyline& path, int iterations, double lambda = 0.5);

// Every point moved to the closest point of the surface.
Polyline snapToSurface(const mesh::SurfaceMesh& m, const Polyline& path);

}  // namespace ld::curriculum
