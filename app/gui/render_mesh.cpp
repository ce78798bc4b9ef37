#include "app/gui/render_mesh.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace ld::gui {
namespace {

Vec3f sub(const Vec3f& a, const Vec3f& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3f cross(const Vec3f& a, const Vec3f& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
float dot(const Vec3f& a, const Vec3f& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

}  // namespace

Bounds RenderMesh::bounds() const {
  Bounds b;
  constexpr float big = std::numeric_limits<float>::max();
  b.min = {big, big, big};
  b.max = {-big, -big, -big};
  for (const auto& t : triangles)
    for (auto v : t)
      for (std::size_t a = 0; a < 3; ++a) {
        b.min[a] = std::min(b.min[a], positions[v][a]);
        b.max[a] = std::max(b.max[a], positions[v][a]);
      }
  return b;
}

std::vector<float> buildCornerBuffer(const RenderMesh& m, float creaseDegrees) {
  const std::size_t nf = m.triangles.size(), nv = m.positions.size();
  // Area-weighted face normals (length = twice the area) and their unit versions.
  std::vector<Vec3f> weighted(nf), unit(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    const auto& t = m.triangles[f];
    weighted[f] = cross(sub(m.positions[t[1]], m.positions[t[0]]), sub(m.positions[t[2]], m.positions[t[0]]));
    const float len = std::sqrt(dot(weighted[f], weighted[f]));
    unit[f] = len > 0 ? Vec3f{weighted[f][0] / len, weighted[f][1] / len, weighted[f][2] / len} : Vec3f{0, 0, 0};
  }
  // Faces around each vertex, in compressed rows.
  std::vector<std::uint32_t> start(nv + 1, 0), around(3 * nf);
  for (const auto& t : m.triangles)
    for (auto v : t) ++start[v + 1];
  for (std::size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
  std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
  for (std::size_t f = 0; f < nf; ++f)
    for (auto v : m.triangles[f]) around[fill[v]++] = static_cast<std::uint32_t>(f);

  const float cosCrease = std::cos(creaseDegrees * 3.14159265F / 180.0F);
  std::vector<float> out;
  out.reserve(nf * 3 * kFloatsPerCorner);
  for (std::size_t f = 0; f < nf; ++f) {
    for (auto v : m.triangles[f]) {
      Vec3f n{0, 0, 0};
      for (auto i = start[v]; i < start[v + 1]; ++i) {
        const auto g = around[i];
        if (g == f || dot(unit[g], unit[f]) >= cosCrease)
          for (std::size_t a = 0; a < 3; ++a) n[a] += weighted[g][a];
      }
      float len = std::sqrt(dot(n, n));
      if (!(len > 0)) {  // a degenerate face alone: any unit normal will do
        n = {0, 0, 1};
        len = 1.0F;
      }
      const auto& p = m.positions[v];
      const float kind = f < m.faceKind.size() && m.faceKind[f] != 0 ? 1.0F : 0.0F;
      out.insert(out.end(), {p[0], p[1], p[2], n[0] / len, n[1] / len, n[2] / len, kind});
    }
  }
  return out;
}

}  // namespace ld::gui
