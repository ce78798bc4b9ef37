// Export to OBJ, PLY (ASCII) and VRML 2.0. Numbers are written with the shortest
// representation that reads back to the same double, so a round trip is exact.
#include <charconv>
#include <cstdint>
#include <fstream>
#include <string>
#include <type_traits>
#include <vector>

#include "sim/io/mesh_formats.h"

namespace ld::io {
namespace {

void appendNumber(std::string& out, double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

void appendIndex(std::string& out, std::size_t v) {
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

// "a b c" with single spaces (coordinates or corner indices).
template <class T>
void appendTriple(std::string& out, T a, T b, T c) {
  auto one = [&out](T v) {
    if constexpr (std::is_floating_point_v<T>)
      appendNumber(out, v);
    else
      appendIndex(out, v);
  };
  one(a);
  out += ' ';
  one(b);
  out += ' ';
  one(c);
}

// Live vertices renumbered 0..n-1 in handle order, and the live faces' corners.
struct Flat {
  std::vector<mesh::Point> points;
  std::vector<std::array<std::size_t, 3>> faces;
};

Flat flatten(const mesh::SurfaceMesh& m) {
  Flat f;
  std::vector<std::size_t> index(m.verticesSize(), 0);
  for (mesh::Vertex v : m.vertices()) {
    index[v.idx()] = f.points.size();
    f.points.push_back(m.position(v));
  }
  for (mesh::Face fc : m.faces()) {
    const auto& vs = m.vertices(fc);
    f.faces.push_back({index[vs[0].idx()], index[vs[1].idx()], index[vs[2].idx()]});
  }
  return f;
}

std::string toObj(const Flat& f) {
  std::string s = "# written by lapdissect\n";
  for (const auto& p : f.points) {
    s += "v ";
    appendTriple(s, p.x(), p.y(), p.z());
    s += '\n';
  }
  for (const auto& t : f.faces) {
    s += "f ";
    appendTriple(s, t[0] + 1, t[1] + 1, t[2] + 1);
    s += '\n';
  }
  return s;
}

std::string toPly(const Flat& f) {
  std::string s = "ply\nformat ascii 1.0\ncomment written by lapdissect\nelement vertex " +
                  std::to_string(f.points.size()) + "\nproperty double x\nproperty double y\nproperty double z\n" +
                  "element face " + std::to_string(f.faces.size()) +
                  "\nproperty list uchar uint vertex_indices\nend_header\n";
  for (const auto& p : f.points) {
    appendTriple(s, p.x(), p.y(), p.z());
    s += '\n';
  }
  for (const auto& t : f.faces) {
    s += "3 ";
    appendTriple(s, t[0], t[1], t[2]);
    s += '\n';
  }
  return s;
}

std::string toBinaryPly(const Flat& f) {
  std::string s = "ply\nformat binary_little_endian 1.0\ncomment written by lapdissect\nelement vertex " +
                  std::to_string(f.points.size()) + "\nproperty double x\nproperty double y\nproperty double z\n" +
                  "element face " + std::to_string(f.faces.size()) +
                  "\nproperty list uchar uint vertex_indices\nend_header\n";
  s.reserve(s.size() + f.points.size() * 24 + f.faces.size() * 13);
  auto put = [&s](const auto& v) { s.append(reinterpret_cast<const char*>(&v), sizeof v); };  // little endian hosts
  for (const auto& p : f.points) {
    put(p.x());
    put(p.y());
    put(p.z());
  }
  for (const auto& t : f.faces) {
    put(static_cast<std::uint8_t>(3));
    for (std::size_t k : t) put(static_cast<std::uint32_t>(k));
  }
  return s;
}

std::string toVrml(const Flat& f) {
  std::string s =
      "#VRML V2.0 utf8\n# written by lapdissect\nShape {\n  geometry IndexedFaceSet {\n    solid FALSE\n"
      "    coord Coordinate {\n      point [\n";
  for (const auto& p : f.points) {
    s += "        ";
    appendTriple(s, p.x(), p.y(), p.z());
    s += ",\n";
  }
  s += "      ]\n    }\n    coordIndex [\n";
  for (const auto& t : f.faces) {
    s += "      ";
    appendTriple(s, t[0], t[1], t[2]);
    s += " -1,\n";
  }
  s += "    ]\n  }\n}\n";
  return s;
}

}  // namespace

void writeMesh(const mesh::SurfaceMesh& m, const std::filesystem::path& file) { writeMesh(m, file, WriteOptions{}); }

void writeMesh(const mesh::SurfaceMesh& m, const std::filesystem::path& file, const WriteOptions& options) {
  const auto fmt = formatFromPath(file);
  if (!fmt || (*fmt != Format::Obj && *fmt != Format::Ply && *fmt != Format::Vrml))
    throw IoError(file.string() + ": cannot export '" + file.extension().string() + "' (use .obj, .ply or .wrl)");
  const Flat flat = flatten(m);
  const std::string text = *fmt == Format::Obj   ? toObj(flat)
                           : *fmt == Format::Ply ? (options.binaryPly ? toBinaryPly(flat) : toPly(flat))
                                                 : toVrml(flat);
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  if (!out) throw IoError(file.string() + ": cannot open for writing");
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  out.close();
  if (!out) throw IoError(file.string() + ": write failed");
}

}  // namespace ld::io
