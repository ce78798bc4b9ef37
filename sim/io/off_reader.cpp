// Object File Format: optional [ST][C][N]OFF header, counts "V F E", V points (extra
// values such as colours ignored), F polygons "n i1 .. in" (colours ignored).
#include <string>

#include "sim/io/mesh_formats.h"
#include "sim/io/parse_util.h"

namespace ld::io {

RawMesh parseOff(std::string_view text, const std::string& name, ImportReport* report) {
  RawMesh raw;
  if (text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);
  detail::Scanner sc(text, name, true);
  std::string_view t = sc.next();
  if (t.empty()) sc.fail("empty file");
  const auto isHeader = [](std::string_view w) {
    if (w.size() < 3 || w.substr(w.size() - 3) != "OFF") return false;
    for (char c : w.substr(0, w.size() - 3))
      if (c != 'S' && c != 'T' && c != 'C' && c != 'N') return false;
    return true;
  };
  if (isHeader(t)) {
    const std::string_view next = sc.nextOnLine();
    if (next == "BINARY") sc.fail("binary OFF is not supported");
    t = next.empty() ? sc.next() : next;
  } else if (t.find("OFF") != std::string_view::npos) {
    sc.fail("unsupported OFF variant " + detail::shown(t));
  } else if (report) {
    report->warnings.push_back(name + ":1: no OFF header line; reading the counts directly");
  }
  const long long nv = sc.integer(t, "vertex count");
  const long long nf = sc.integer(sc.next(), "face count");
  sc.integer(sc.next(), "edge count");
  if (nv < 0 || nf < 0) sc.fail("negative element count");
  // No reserve from the header: a lying count must not allocate gigabytes.
  sc.skipLine();
  for (long long i = 0; i < nv; ++i) {
    std::string_view x = sc.next();
    if (x.empty())
      sc.fail("unexpected end of file: " + std::to_string(i) + " of " + std::to_string(nv) + " vertices read");
    Eigen::Vector3d p;
    p[0] = sc.number(x, "vertex coordinate");
    p[1] = sc.number(sc.nextOnLine(), "vertex coordinate");
    p[2] = sc.number(sc.nextOnLine(), "vertex coordinate");
    raw.points.push_back(p);
    sc.skipLine();
  }
  std::vector<std::uint32_t> poly;
  for (long long i = 0; i < nf; ++i) {
    std::string_view c = sc.next();
    if (c.empty())
      sc.fail("unexpected end of file: " + std::to_string(i) + " of " + std::to_string(nf) + " faces read");
    const long long n = sc.integer(c, "corner count");
    if (n < 3) sc.fail("face with " + std::to_string(n) + " corners");
    poly.clear();
    for (long long k = 0; k < n; ++k) {
      const std::string_view tok = sc.nextOnLine();
      if (tok.empty()) sc.fail("face has fewer than the " + std::to_string(n) + " corners it announces");
      const long long idx = sc.integer(tok, "vertex index");
      if (idx < 0 || idx >= nv)
        sc.fail("vertex index " + std::to_string(idx) + " out of range (" + std::to_string(nv) + " vertices)");
      poly.push_back(static_cast<std::uint32_t>(idx));
    }
    raw.addPolygon(poly.data(), poly.size(), sc.line());
    sc.skipLine();
  }
  if (!sc.atEnd() && report)
    report->warnings.push_back(name + ":" + std::to_string(sc.line()) + ": data after the last face ignored");
  return raw;
}

}  // namespace ld::io
