// Wavefront OBJ: `v` and `f` records; everything else (normals, texture coordinates,
// groups, materials, lines) is skipped.
#include <set>
#include <string>

#include "sim/io/mesh_formats.h"
#include "sim/io/parse_util.h"

namespace ld::io {

RawMesh parseObj(std::string_view text, const std::string& name, ImportReport* report) {
  RawMesh raw;
  detail::Scanner sc(text, name, true);
  std::vector<long long> faceIdx;
  std::vector<std::uint32_t> poly;
  std::set<std::string, std::less<>> unknown;
  while (!sc.atEnd()) {
    const std::string_view key = sc.nextOnLine();
    if (key.empty()) {
      sc.skipLine();
      continue;
    }
    if (key == "v") {
      Eigen::Vector3d p;
      for (int k = 0; k < 3; ++k) p[k] = sc.number(sc.nextOnLine(), "vertex coordinate");
      raw.points.push_back(p);
      // An optional w and vertex colours may follow.
      for (std::string_view t = sc.nextOnLine(); !t.empty(); t = sc.nextOnLine()) sc.number(t, "vertex value");
    } else if (key == "f" || key == "fo") {
      poly.clear();
      const long faceLine = sc.line();
      for (std::string_view t = sc.nextOnLine();; t = sc.nextOnLine()) {
        if (t == "\\") {  // line continuation
          sc.skipLine();
          t = sc.nextOnLine();
        }
        if (t.empty()) break;
        const std::string_view v = t.substr(0, t.find('/'));
        long long i = 0;
        if (!detail::parseInt(v, i)) sc.fail("bad face index " + detail::shown(t));
        const auto n = static_cast<long long>(raw.points.size());
        if (i < 0) i += n + 1;  // relative to the vertices read so far
        if (i < 1 || i > n)
          sc.fail("face index " + detail::shown(v) + " out of range (" + std::to_string(n) + " vertices so far)");
        poly.push_back(static_cast<std::uint32_t>(i - 1));
      }
      if (poly.size() < 3) sc.fail("face with " + std::to_string(poly.size()) + " corners");
      raw.addPolygon(poly.data(), poly.size(), faceLine);
    } else if (key == "vn" || key == "vt" || key == "vp" || key == "g" || key == "o" || key == "s" || key == "usemtl" ||
               key == "mtllib" || key == "l" || key == "p" || key == "usemap" || key == "maplib" || key == "lod" ||
               key == "shadow_obj" || key == "trace_obj" || key == "bevel" || key == "c_interp" || key == "d_interp") {
      // Not geometry we use.
    } else {
      if (report && unknown.insert(std::string(key)).second)
        report->warnings.push_back(name + ":" + std::to_string(sc.line()) + ": skipped unknown record " +
                                   detail::shown(key));
    }
    // Skip the rest (handles continuation lines of skipped records too).
    for (;;) {
      const std::string_view rest = sc.restOfLine();
      sc.skipLine();
      const auto last = rest.find_last_not_of(" \t");
      if (last == std::string_view::npos || rest[last] != '\\' || key == "f" || key == "v") break;
    }
  }
  return raw;
}

}  // namespace ld::io
