#pragma once
// Shared body of the io fuzz targets: a buffer goes through the whole import chain.
// ParseError is the expected way to refuse input; any other exception, a crash, a
// sanitizer report or a mesh that fails validate() is a finding.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string_view>

#include "sim/io/mesh_formats.h"

namespace ld::io::fuzz {

inline int run(Format f, const std::uint8_t* data, std::size_t size) {
  if (size > (1u << 20)) return 0;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    ImportReport rep;
    const RawMesh raw = parse(f, text, "fuzz", &rep);
    TriangleSoup soup = triangulate(raw, &rep);
    cleanSoup(soup, raw.weld, &rep);
    const MeshStats st = computeStats(soup);
    if (st.triangles != soup.triangles.size() || st.vertices != soup.points.size()) {
      std::fprintf(stderr, "stats disagree with the soup\n");
      std::abort();
    }
    const mesh::SurfaceMesh m = buildMesh(soup, &rep);
    const auto v = m.validate();
    if (!v.ok()) {
      std::fprintf(stderr, "invalid mesh from import:\n%s\n", v.message().c_str());
      std::abort();
    }
  } catch (const ParseError&) {
  }
  return 0;
}

}  // namespace ld::io::fuzz
