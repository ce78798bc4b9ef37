#pragma once
// Paths as the metrics see them: points in order, a stop flag ending each piece.
#include <string>
#include <vector>

#include <Eigen/Core>

namespace ld::curriculum {

struct PathPoint {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  bool stop = false;  // this point ends a piece
};

using Polyline = std::vector<PathPoint>;

enum class Plane { XY, YZ, XZ };

// The pieces of a path (a stop flag ends a piece; the last point always does).
std::vector<std::vector<Eigen::Vector3d>> pieces(const Polyline& path);

// All points in order: pieces joined by straight segments (how the deviation sees them).
std::vector<Eigen::Vector3d> joinedPoints(const Polyline& path);

// Total length of the pieces (the joins between pieces are not counted).
double piecesLength(const Polyline& path);

Eigen::Vector2d project(const Eigen::Vector3d& p, Plane plane);

// A polyline built from plain points (one piece).
Polyline makePolyline(const std::vector<Eigen::Vector3d>& pts);

// Resampled so that consecutive points are at most `spacing` apart along each piece;
// original points are kept (the shape does not change).
Polyline densify(const Polyline& path, double spacing);

}  // namespace ld::curriculum
