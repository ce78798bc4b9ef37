#pragma once
// Small meshes built inline for the collision tests.
#include <cmath>
#include <map>
#include <utility>
#include <vector>

#include "sim/mesh/surface_mesh.h"

namespace ld::collision::testing {

// Iteration counts of the randomised tests: a quarter under AddressSanitizer, so the
// CI sanitizer job stays short (the Release run does the full count).
inline int scaled(int n) {
#if defined(__SANITIZE_ADDRESS__)
  return n / 4 > 0 ? n / 4 : 1;
#else
  return n;
#endif
}

// An n x n grid of squares of size h in the plane z = z0, split along a diagonal,
// normals +z (or -z when flipped).
inline void addGrid(mesh::SurfaceMesh& m, int n, double h, double z0, bool flipped = false) {
  std::vector<mesh::Vertex> v;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) v.push_back(m.addVertex(Eigen::Vector3d(i * h, j * h, z0)));
  auto at = [&](int i, int j) { return v[static_cast<std::size_t>(j * (n + 1) + i)]; };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      if (!flipped) {
        m.addFace(at(i, j), at(i + 1, j), at(i + 1, j + 1));
        m.addFace(at(i, j), at(i + 1, j + 1), at(i, j + 1));
      } else {
        m.addFace(at(i, j), at(i + 1, j + 1), at(i + 1, j));
        m.addFace(at(i, j), at(i, j + 1), at(i + 1, j + 1));
      }
    }
}

inline mesh::SurfaceMesh grid(int n, double h = 1.0) {
  mesh::SurfaceMesh m;
  addGrid(m, n, h, 0.0);
  return m;
}

// A closed icosphere of radius r around c, `levels` subdivisions (20 * 4^levels faces).
inline mesh::SurfaceMesh icosphere(int levels, double r = 1.0, Eigen::Vector3d c = Eigen::Vector3d::Zero()) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Eigen::Vector3d> p = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                                    {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  for (auto& x : p) x.normalize();
  std::vector<std::array<int, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                       {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                       {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                       {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      p.push_back((p[static_cast<std::size_t>(a)] + p[static_cast<std::size_t>(b)]).normalized());
      const int i = static_cast<int>(p.size()) - 1;
      mid[key] = i;
      return i;
    };
    std::vector<std::array<int, 3>> g;
    for (const auto& tri : f) {
      const int ab = midpoint(tri[0], tri[1]), bc = midpoint(tri[1], tri[2]), ca = midpoint(tri[2], tri[0]);
      g.push_back({tri[0], ab, ca});
      g.push_back({tri[1], bc, ab});
      g.push_back({tri[2], ca, bc});
      g.push_back({ab, bc, ca});
    }
    f.swap(g);
  }
  mesh::SurfaceMesh m;
  std::vector<mesh::Vertex> v;
  for (const auto& x : p) v.push_back(m.addVertex(c + r * x));
  for (const auto& tri : f)
    m.addFace(v[static_cast<std::size_t>(tri[0])], v[static_cast<std::size_t>(tri[1])],
              v[static_cast<std::size_t>(tri[2])]);
  return m;
}

// A closed axis-aligned slab [0, n*h] x [0, n*h] x [-thick, 0]: top, bottom and four
// side walls, consistently oriented outwards.
inline mesh::SurfaceMesh slab(int n, double h, double thick) {
  mesh::SurfaceMesh m;
  const double L = n * h;
  std::map<std::array<long long, 3>, mesh::Vertex> ids;
  auto vert = [&](Eigen::Vector3d p) {
    const std::array<long long, 3> key = {std::llround(p.x() * 1e6), std::llround(p.y() * 1e6),
                                          std::llround(p.z() * 1e6)};
    auto it = ids.find(key);
    if (it != ids.end()) return it->second;
    const mesh::Vertex v = m.addVertex(p);
    ids[key] = v;
    return v;
  };
  // A quad grid on a rectangle spanned from o by u (nu cells) and w (nw cells), normal u x w.
  auto quad = [&](Eigen::Vector3d o, Eigen::Vector3d u, int nu, Eigen::Vector3d w, int nw) {
    for (int j = 0; j < nw; ++j)
      for (int i = 0; i < nu; ++i) {
        const auto a = vert(o + u * i + w * j), b = vert(o + u * (i + 1) + w * j),
                   c = vert(o + u * (i + 1) + w * (j + 1)), d = vert(o + u * i + w * (j + 1));
        m.addFace(a, b, c);
        m.addFace(a, c, d);
      }
  };
  const Eigen::Vector3d X(h, 0, 0), Y(0, h, 0), Z(0, 0, thick);
  quad({0, 0, 0}, X, n, Y, n);       // top, normal +z
  quad({0, 0, -thick}, Y, n, X, n);  // bottom, normal -z
  quad({0, 0, -thick}, X, n, Z, 1);  // y = 0, normal -y
  quad({0, L, -thick}, Z, 1, X, n);  // y = L, normal +y
  quad({0, 0, -thick}, Z, 1, Y, n);  // x = 0, normal -x
  quad({L, 0, -thick}, Y, n, Z, 1);  // x = L, normal +x
  return m;
}

}  // namespace ld::collision::testing
