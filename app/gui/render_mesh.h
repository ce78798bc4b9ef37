#pragma once
// What the view draws: an indexed triangle list in single precision, and the
// per-corner vertex buffer (position, normal) built from it. Normals are shared
// across smooth regions and split at creases so a slab keeps sharp edges.
#include <array>
#include <cstdint>
#include <vector>

namespace ld::gui {

using Vec3f = std::array<float, 3>;
using Triangle = std::array<std::uint32_t, 3>;

struct Bounds {
  Vec3f min{0, 0, 0};
  Vec3f max{0, 0, 0};
  [[nodiscard]] bool empty() const { return min[0] > max[0]; }
};

struct RenderMesh {
  std::vector<Vec3f> positions;
  std::vector<Triangle> triangles;  // counter-clockwise seen from the front
  // Per triangle: 0 tissue surface, otherwise a cut wall (drawn in the interior
  // colour). Empty means all surface.
  std::vector<std::uint8_t> faceKind;

  [[nodiscard]] Bounds bounds() const;
  [[nodiscard]] bool empty() const { return triangles.empty(); }
};

// Seven floats per triangle corner: position, unit normal, and the face kind (0 for
// surface, 1 for a cut wall). Corner normals average the area-weighted normals of
// the faces around the vertex that lie within `creaseDegrees` of the corner's own
// face.
constexpr int kFloatsPerCorner = 7;
std::vector<float> buildCornerBuffer(const RenderMesh& m, float creaseDegrees = 50.0F);

}  // namespace ld::gui
