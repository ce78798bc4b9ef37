#pragma once
// Tiny closed and open meshes and scripted strokes for the cutting tests.
#include <array>
#include <cmath>
#include <map>
#include <tuple>
#include <vector>

#include <Eigen/Core>

#include "sim/cutting/cutter.h"
#include "sim/instruments/instrument.h"
#include "sim/mesh/surface_mesh.h"

namespace ld::cutting::test {

using Vec3 = Eigen::Vector3d;

// Adds triangle (a,b,c) turned so that its normal points away from `inside`.
inline void addOutward(mesh::SurfaceMesh& m, mesh::Vertex a, mesh::Vertex b, mesh::Vertex c, const Vec3& inside) {
  const Vec3 n = (m.position(b) - m.position(a)).cross(m.position(c) - m.position(a));
  const Vec3 cen = (m.position(a) + m.position(b) + m.position(c)) / 3.0;
  if (n.dot(cen - inside) >= 0)
    m.addFace(a, b, c);
  else
    m.addFace(a, c, b);
}

// Closed box [lo, hi] with n[0] x n[1] x n[2] cells, quads split along alternating diagonals.
inline mesh::SurfaceMesh makeBox(const Vec3& lo, const Vec3& hi, std::array<int, 3> n) {
  mesh::SurfaceMesh m;
  std::map<std::array<int, 3>, mesh::Vertex> idx;
  auto vert = [&](std::array<int, 3> k) {
    auto it = idx.find(k);
    if (it != idx.end()) return it->second;
    Vec3 p;
    for (int d = 0; d < 3; ++d)
      p[d] = lo[d] + (hi[d] - lo[d]) * k[static_cast<std::size_t>(d)] / n[static_cast<std::size_t>(d)];
    auto v = m.addVertex(p);
    idx[k] = v;
    return v;
  };
  const Vec3 inside = 0.5 * (lo + hi);
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, w = (axis + 2) % 3;
    for (int side = 0; side < 2; ++side) {
      for (int i = 0; i < n[static_cast<std::size_t>(u)]; ++i)
        for (int j = 0; j < n[static_cast<std::size_t>(w)]; ++j) {
          auto key = [&](int di, int dj) {
            std::array<int, 3> k{};
            k[static_cast<std::size_t>(axis)] = side ? n[static_cast<std::size_t>(axis)] : 0;
            k[static_cast<std::size_t>(u)] = i + di;
            k[static_cast<std::size_t>(w)] = j + dj;
            return vert(k);
          };
          auto a = key(0, 0), b = key(1, 0), c = key(1, 1), d = key(0, 1);
          if ((i + j) % 2 == 0) {
            addOutward(m, a, b, c, inside);
            addOutward(m, a, c, d, inside);
          } else {
            addOutward(m, a, b, d, inside);
            addOutward(m, b, c, d, inside);
          }
        }
    }
  }
  return m;
}

// Closed cylinder around z (radius r, z in [z0, z1]), `seg` around, `rings` along, capped.
inline mesh::SurfaceMesh makeCylinder(double r, double z0, double z1, int seg, int rings) {
  mesh::SurfaceMesh m;
  std::vector<std::vector<mesh::Vertex>> ring(static_cast<std::size_t>(rings + 1));
  for (int k = 0; k <= rings; ++k)
    for (int i = 0; i < seg; ++i) {
      const double a = 2 * M_PI * i / seg;
      ring[static_cast<std::size_t>(k)].push_back(
          m.addVertex(Vec3(r * std::cos(a), r * std::sin(a), z0 + (z1 - z0) * k / rings)));
    }
  const auto c0 = m.addVertex(Vec3(0, 0, z0)), c1 = m.addVertex(Vec3(0, 0, z1));
  for (int k = 0; k < rings; ++k)
    for (int i = 0; i < seg; ++i) {
      const auto& R0 = ring[static_cast<std::size_t>(k)];
      const auto& R1 = ring[static_cast<std::size_t>(k + 1)];
      const std::size_t i0 = static_cast<std::size_t>(i), i1 = static_cast<std::size_t>((i + 1) % seg);
      const Vec3 in(0, 0, 0.5 * (m.position(R0[i0]).z() + m.position(R1[i0]).z()));
      addOutward(m, R0[i0], R0[i1], R1[i1], in);
      addOutward(m, R0[i0], R1[i1], R1[i0], in);
    }
  const Vec3 mid(0, 0, 0.5 * (z0 + z1));
  for (int i = 0; i < seg; ++i) {
    const std::size_t i0 = static_cast<std::size_t>(i), i1 = static_cast<std::size_t>((i + 1) % seg);
    addOutward(m, c0, ring[0][i0], ring[0][i1], mid);
    addOutward(m, c1, ring[static_cast<std::size_t>(rings)][i0], ring[static_cast<std::size_t>(rings)][i1], mid);
  }
  return m;
}

// Open flat disc (a sheet) in z = 0: polar grid, `rings` rings of `seg` vertices.
inline mesh::SurfaceMesh makeSheetDisc(double r, int seg, int rings) {
  mesh::SurfaceMesh m;
  const auto c = m.addVertex(Vec3::Zero());
  std::vector<std::vector<mesh::Vertex>> ring;
  for (int k = 1; k <= rings; ++k) {
    ring.emplace_back();
    for (int i = 0; i < seg; ++i) {
      const double a = 2 * M_PI * (i + 0.5 * k) / seg;
      ring.back().push_back(m.addVertex(Vec3(r * k / rings * std::cos(a), r * k / rings * std::sin(a), 0)));
    }
  }
  const Vec3 below(0, 0, -1);
  for (int i = 0; i < seg; ++i)
    addOutward(m, c, ring[0][static_cast<std::size_t>(i)], ring[0][static_cast<std::size_t>((i + 1) % seg)], below);
  for (std::size_t k = 0; k + 1 < ring.size(); ++k)
    for (int i = 0; i < seg; ++i) {
      const std::size_t i0 = static_cast<std::size_t>(i), i1 = static_cast<std::size_t>((i + 1) % seg);
      addOutward(m, ring[k][i0], ring[k][i1], ring[k + 1][i0], below);
      addOutward(m, ring[k][i1], ring[k + 1][i1], ring[k + 1][i0], below);
    }
  return m;
}

// A scalpel pose: blade from `tip` up along -dir, sharp side toward `up`.
inline instruments::Pose scalpel(const Vec3& tip, const Vec3& dir, const Vec3& up) {
  instruments::Pose p;
  p.tip = tip;
  p.dir = dir.normalized();
  Vec3 u = up - up.dot(p.dir) * p.dir;
  p.up = u.normalized();
  return p;
}

// Straight stroke of the tip from a to b at `speed` mm/s sampled at `hz`, blade
// pointing along dir; calls engine.step for every sample, then endStroke. Calls
// check(engine) after every sample when given.
template <class Check>
void stroke(CutEngine& e, const Vec3& a, const Vec3& b, const Vec3& dir, double speed, double hz, Check&& check,
            instruments::Tool tool = instruments::Tool::Scalpel) {
  const double len = (b - a).norm();
  const int n = std::max(1, static_cast<int>(std::ceil(len / speed * hz)));
  const Vec3 up = (b - a).normalized();
  for (int i = 0; i <= n; ++i) {
    const Vec3 tip = a + (b - a) * (static_cast<double>(i) / n);
    auto pose = scalpel(tip, dir, up);
    pose.pedal = true;
    e.step(instruments::Hand::Right, tool, pose);
    check(e);
  }
  e.endStroke(instruments::Hand::Right);
  check(e);
}

inline void stroke(CutEngine& e, const Vec3& a, const Vec3& b, const Vec3& dir, double speed = 20.0,
                   double hz = 1000.0) {
  stroke(e, a, b, dir, speed, hz, [](CutEngine&) {});
}

// Stroke of the tip along a polyline (e.g. deeper and deeper) at `speed` mm/s sampled
// at `hz`; the blade's sharp side faces the motion in the xy plane.
template <class Check>
void polyStroke(CutEngine& e, const std::vector<Vec3>& pts, const Vec3& dir, double speed, double hz, Check&& check,
                instruments::Tool tool = instruments::Tool::Scalpel) {
  for (std::size_t k = 0; k + 1 < pts.size(); ++k) {
    const Vec3 a = pts[k], b = pts[k + 1];
    const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / speed * hz)));
    Vec3 up = b - a;
    up.z() = 0.0;
    if (up.norm() < 1e-9) up = Vec3(1, 0, 0);
    for (int i = (k == 0 ? 0 : 1); i <= n; ++i) {
      auto pose = scalpel(a + (b - a) * (static_cast<double>(i) / n), dir, up.normalized());
      pose.pedal = true;
      e.step(instruments::Hand::Right, tool, pose);
      check(e);
    }
  }
  e.endStroke(instruments::Hand::Right);
  check(e);
}

// V - E + F: 2 for a closed surface without holes, 0 with one hole through it.
inline long eulerCharacteristic(const mesh::SurfaceMesh& m) {
  return static_cast<long>(m.nVertices()) - static_cast<long>(m.nEdges()) + static_cast<long>(m.nFaces());
}

// Pairs of triangles on the same three points facing the same way: a doubled
// surface (membrane). The two walls of a fresh cut coincide too, but face each other.
inline int coincidentTrianglePairs(const mesh::SurfaceMesh& m) {
  std::map<std::array<std::tuple<long, long, long>, 3>, std::vector<Vec3>> seen;
  int pairs = 0;
  for (auto f : m.faces()) {
    std::array<std::tuple<long, long, long>, 3> key;
    for (int i = 0; i < 3; ++i) {
      const Vec3 p = m.position(m.vertices(f)[static_cast<std::size_t>(i)]) * 1e6;
      key[static_cast<std::size_t>(i)] = {std::lround(p.x()), std::lround(p.y()), std::lround(p.z())};
    }
    std::sort(key.begin(), key.end());
    auto& normals = seen[key];
    const Vec3 n = m.faceNormal(f);
    for (const Vec3& o : normals) pairs += o.dot(n) > 0.0 ? 1 : 0;
    normals.push_back(n);
  }
  return pairs;
}

// Total area of the faces of one kind (face property kFaceKindProp).
inline double areaOfKind(const mesh::SurfaceMesh& m, int kind) {
  auto prop = m.getFaceProperty<int>(kFaceKindProp);
  double a = 0.0;
  for (auto f : m.faces())
    if (prop[f] == kind) a += m.faceArea(f);
  return a;
}

// Edges where a surface face facing -z (the bottom layer) meets a side wall: the
// bottom is open there.
inline int bottomEdgesOnSideWalls(const mesh::SurfaceMesh& m) {
  auto prop = m.getFaceProperty<int>(kFaceKindProp);
  int n = 0;
  for (auto e : m.edges()) {
    const auto f0 = m.face(e, 0), f1 = m.face(e, 1);
    if (!f1.isValid()) continue;
    for (auto [s, w] : {std::pair{f0, f1}, std::pair{f1, f0}})
      if (prop[s] == kSurface && prop[w] == kSideWall && m.faceNormal(s).z() < -0.99) ++n;
  }
  return n;
}

}  // namespace ld::cutting::test
