// STL, ASCII and binary. Every facet carries its own three corners; the points are
// welded later (RawMesh::weld) so that neighbouring facets share vertices.
#include <cstring>
#include <string>

#include "sim/io/mesh_formats.h"
#include "sim/io/parse_util.h"

namespace ld::io {
namespace {

bool looksAscii(std::string_view d) {
  std::size_t i = 0;
  while (i < d.size() && (d[i] == ' ' || d[i] == '\t' || d[i] == '\r' || d[i] == '\n')) ++i;
  if (d.substr(i, 5) != "solid") return false;
  // Binary files may also start with "solid"; a real ASCII file has "facet" or
  // "endsolid" in its first kilobyte and no NUL bytes there.
  const std::string_view head = d.substr(0, 1024);
  if (head.find('\0') != std::string_view::npos) return false;
  return head.find("facet") != std::string_view::npos || head.find("endsolid") != std::string_view::npos;
}

RawMesh parseBinary(std::string_view d, const std::string& name) {
  RawMesh raw;
  raw.weld = true;
  if (d.size() < 84)
    throw ParseError(name, 0, "truncated binary STL: " + std::to_string(d.size()) + " bytes, the header needs 84");
  std::uint32_t n = 0;
  std::memcpy(&n, d.data() + 80, 4);  // little endian on every platform we build for
  const std::uint64_t need = 84 + 50ull * n;
  if (need != d.size())
    throw ParseError(name, 0,
                     "binary STL announces " + std::to_string(n) + " triangles (" + std::to_string(need) +
                         " bytes) but the file has " + std::to_string(d.size()) + " bytes");
  raw.points.reserve(3ull * n);
  for (std::uint32_t t = 0; t < n; ++t) {
    const char* rec = d.data() + 84 + 50ull * t;
    std::uint32_t idx[3];
    for (int c = 0; c < 3; ++c) {
      float xyz[3];
      std::memcpy(xyz, rec + 12 + 12 * c, 12);
      Eigen::Vector3d p(xyz[0], xyz[1], xyz[2]);
      if (!p.allFinite())
        throw ParseError(name, 0,
                         "triangle " + std::to_string(t) + " (byte " + std::to_string(84 + 50ull * t) +
                             ") has a non-finite coordinate");
      idx[c] = static_cast<std::uint32_t>(raw.points.size());
      raw.points.push_back(p);
    }
    raw.addPolygon(idx, 3, 0);
  }
  return raw;
}

RawMesh parseAscii(std::string_view d, const std::string& name) {
  RawMesh raw;
  raw.weld = true;
  detail::Scanner sc(d, name, false);
  auto expect = [&](std::string_view want) {
    const std::string_view t = sc.next();
    if (t != want) {
      if (t.empty()) sc.fail("unexpected end of file, expected '" + std::string(want) + "'");
      sc.fail("expected '" + std::string(want) + "', found " + detail::shown(t));
    }
  };
  bool inSolid = false;
  std::vector<std::uint32_t> poly;
  for (;;) {
    const std::string_view t = sc.next();
    if (t.empty()) break;
    if (t == "solid") {
      if (inSolid) sc.fail("'solid' inside a solid");
      inSolid = true;
      sc.restOfLine();  // the name
    } else if (t == "endsolid") {
      if (!inSolid) sc.fail("'endsolid' without 'solid'");
      inSolid = false;
      sc.restOfLine();
    } else if (t == "facet") {
      if (!inSolid) sc.fail("'facet' outside a solid");
      const long facetLine = sc.line();
      expect("normal");
      for (int k = 0; k < 3; ++k) sc.number(sc.next(), "normal component");
      expect("outer");
      expect("loop");
      poly.clear();
      for (;;) {
        const std::string_view v = sc.next();
        if (v == "endloop") break;
        if (v != "vertex") {
          if (v.empty()) sc.fail("unexpected end of file inside a facet");
          sc.fail("expected 'vertex' or 'endloop', found " + detail::shown(v));
        }
        Eigen::Vector3d p;
        for (int k = 0; k < 3; ++k) p[k] = sc.number(sc.next(), "vertex coordinate");
        poly.push_back(static_cast<std::uint32_t>(raw.points.size()));
        raw.points.push_back(p);
      }
      if (poly.size() < 3) throw ParseError(name, facetLine, "facet with " + std::to_string(poly.size()) + " vertices");
      expect("endfacet");
      raw.addPolygon(poly.data(), poly.size(), facetLine);
    } else {
      sc.fail("expected 'facet' or 'endsolid', found " + detail::shown(t));
    }
  }
  if (inSolid) sc.fail("unexpected end of file: missing 'endsolid'");
  return raw;
}

}  // namespace

RawMesh parseStl(std::string_view data, const std::string& name, ImportReport*) {
  return looksAscii(data) ? parseAscii(data, name) : parseBinary(data, name);
}

}  // namespace ld::io
