#include "sim/physics/scenes.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "sim/physics/physics_error.h"

namespace ld::physics {

using mesh::SurfaceMesh;
using mesh::Vertex;
using Vec3 = Eigen::Vector3d;

SurfaceMesh makeGrid(int nx, int ny, double h) { return makeSlitGrid(nx, ny, h, 0); }

SurfaceMesh makeSlitGrid(int nx, int ny, double h, int slitCells) {
  if (nx < 1 || ny < 1 || !(h > 0)) throw PhysicsError("makeGrid: bad size");
  SurfaceMesh m;
  std::vector<Vertex> v(static_cast<std::size_t>((nx + 1) * (ny + 1)));
  auto id = [&](int i, int j) { return static_cast<std::size_t>(j * (nx + 1) + i); };
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) v[id(i, j)] = m.addVertex(Vec3(i * h, j * h, 0.0));
  const int js = ny / 2;
  slitCells = std::clamp(slitCells, 0, nx - 1);
  // Copies of the slit row used by the faces below it (i = 0 .. slitCells - 1 open;
  // the vertex at i = slitCells closes the slit and stays shared).
  std::vector<Vertex> below(static_cast<std::size_t>(nx + 1));
  for (int i = 0; i <= nx; ++i)
    below[static_cast<std::size_t>(i)] = i < slitCells ? m.addVertex(m.position(v[id(i, js)])) : v[id(i, js)];
  auto at = [&](int i, int j, bool lowerFace) {
    return (j == js && lowerFace) ? below[static_cast<std::size_t>(i)] : v[id(i, j)];
  };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const bool lower = j + 1 == js;  // faces just below the slit row use the copies
      const Vertex a = at(i, j, false), b = at(i + 1, j, false);
      const Vertex c = at(i + 1, j + 1, lower), d = at(i, j + 1, lower);
      m.addFace(a, b, c);
      m.addFace(a, c, d);
    }
  return m;
}

SurfaceMesh makeBox(std::span<const double> xs, std::span<const double> ys, std::span<const double> zs) {
  const int nx = static_cast<int>(xs.size()) - 1, ny = static_cast<int>(ys.size()) - 1,
            nz = static_cast<int>(zs.size()) - 1;
  if (nx < 1 || ny < 1 || nz < 1) throw PhysicsError("makeBox: need two coordinates per axis");
  SurfaceMesh m;
  const std::size_t total = static_cast<std::size_t>((nx + 1) * (ny + 1) * (nz + 1));
  std::vector<Vertex> lattice(total);
  auto get = [&](int i, int j, int k) {
    Vertex& v = lattice[static_cast<std::size_t>((k * (ny + 1) + j) * (nx + 1) + i)];
    if (!v.isValid())
      v = m.addVertex(
          Vec3(xs[static_cast<std::size_t>(i)], ys[static_cast<std::size_t>(j)], zs[static_cast<std::size_t>(k)]));
    return v;
  };
  const std::array<int, 3> n{nx, ny, nz};
  // Each side: fixed axis and its value, then axes u, w with u × w = outward normal.
  struct Side {
    int axis, at, u, w;
  };
  const std::array<Side, 6> sides{
      {{2, nz, 0, 1}, {2, 0, 1, 0}, {0, nx, 1, 2}, {0, 0, 2, 1}, {1, ny, 2, 0}, {1, 0, 0, 2}}};
  for (const Side& s : sides) {
    for (int a = 0; a < n[static_cast<std::size_t>(s.u)]; ++a)
      for (int b = 0; b < n[static_cast<std::size_t>(s.w)]; ++b) {
        auto vert = [&](int da, int db) {
          std::array<int, 3> ijk{};
          ijk[static_cast<std::size_t>(s.axis)] = s.at;
          ijk[static_cast<std::size_t>(s.u)] = a + da;
          ijk[static_cast<std::size_t>(s.w)] = b + db;
          return get(ijk[0], ijk[1], ijk[2]);
        };
        const Vertex p00 = vert(0, 0), p10 = vert(1, 0), p11 = vert(1, 1), p01 = vert(0, 1);
        // Alternate the diagonal so the lattice has no preferred direction.
        if ((a + b) % 2 == 0) {
          m.addFace(p00, p10, p11);
          m.addFace(p00, p11, p01);
        } else {
          m.addFace(p00, p10, p01);
          m.addFace(p10, p11, p01);
        }
      }
  }
  return m;
}

namespace {
std::vector<double> ladder(double size, double h) {
  const int n = std::max(1, static_cast<int>(std::lround(size / h)));
  std::vector<double> c(static_cast<std::size_t>(n + 1));
  for (int i = 0; i <= n; ++i) c[static_cast<std::size_t>(i)] = size * i / n;
  return c;
}
}  // namespace

SurfaceMesh makeSlab(double sx, double sy, double sz, double h) {
  const auto xs = ladder(sx, h), ys = ladder(sy, h), zs = ladder(sz, h);
  return makeBox(xs, ys, zs);
}

SurfaceMesh makeSliverSlab(double sx, double sy, double sz, double h, double sliverWidth) {
  auto xs = ladder(sx, h);
  const auto ys = ladder(sy, h), zs = ladder(sz, h);
  const std::size_t mid = xs.size() / 2;
  xs.insert(xs.begin() + static_cast<std::ptrdiff_t>(mid) + 1, xs[mid] + sliverWidth);
  return makeBox(xs, ys, zs);
}

SurfaceMesh makeSlabWithTriangles(int triangles) {
  // Top and bottom hold about 4·nx·ny triangles; nx = 4/3·ny.
  const double ny = std::max(2.0, std::sqrt(3.0 * triangles / 16.0));
  const double h = 60.0 / ny;
  return makeSlab(80.0, 60.0, std::min(5.0, 2.0 * h), h);
}

Vertex nearestVertex(const SurfaceMesh& m, const Vec3& p) {
  Vertex best;
  double bd = std::numeric_limits<double>::infinity();
  for (Vertex v : m.vertices()) {
    const double d = (m.position(v) - p).squaredNorm();
    if (d < bd) {
      bd = d;
      best = v;
    }
  }
  return best;
}

Vertex topCentreVertex(const SurfaceMesh& m) {
  const auto b = m.bounds();
  return nearestVertex(m, Vec3(b.center().x(), b.center().y(), b.max.z()));
}

}  // namespace ld::physics
