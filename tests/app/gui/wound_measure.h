#pragma once
// How far a wound has opened, measured on what the window draws: the cut walls'
// vertices near the top surface (the lips) across a straight cut along y = c.
#include <algorithm>
#include <cmath>
#include <vector>

#include "app/gui/render_mesh.h"

namespace ld::gui::test {

// The lips are the vertices of cut-wall triangles (faceKind != 0) above `zMin`, within
// `band` of x = x0 and `reach` of y = c, over all objects (a freed piece's lip is in
// its own object). Returns the largest gap between their y values: the distance
// between the two lips (0 with fewer than two lip vertices).
inline double lipGap(const std::vector<RenderMesh>& objects, float x0, float c, float band = 1.0F, float zMin = 1.5F,
                     float reach = 15.0F) {
  std::vector<float> ys;
  for (const RenderMesh& m : objects) {
    std::vector<bool> lip(m.positions.size(), false);
    for (std::size_t f = 0; f < m.triangles.size() && f < m.faceKind.size(); ++f)
      if (m.faceKind[f] != 0)
        for (auto v : m.triangles[f]) lip[v] = true;
    for (std::size_t v = 0; v < lip.size(); ++v) {
      const auto& p = m.positions[v];
      if (lip[v] && std::abs(p[0] - x0) < band && p[2] > zMin && std::abs(p[1] - c) < reach) ys.push_back(p[1]);
    }
  }
  std::sort(ys.begin(), ys.end());
  double gap = 0.0;
  for (std::size_t i = 1; i < ys.size(); ++i) gap = std::max(gap, static_cast<double>(ys[i] - ys[i - 1]));
  return gap;
}

}  // namespace ld::gui::test
