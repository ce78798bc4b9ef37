// PLY, ASCII and binary (little and big endian). Reads `vertex` (x, y, z) and `face`
// (vertex_indices / vertex_index); when there is no `face` element, OpenSurgSim's
// `2d_element` triangles are used. Every other element is read past and ignored.
#include <algorithm>
#include <cstring>
#include <string>

#include "sim/io/mesh_formats.h"
#include "sim/io/parse_util.h"

namespace ld::io {
namespace {

enum class Type { I8, U8, I16, U16, I32, U32, F32, F64 };

bool typeFromName(std::string_view s, Type& t) {
  static const std::pair<const char*, Type> names[] = {
      {"char", Type::I8},   {"int8", Type::I8},     {"uchar", Type::U8},   {"uint8", Type::U8},
      {"short", Type::I16}, {"int16", Type::I16},   {"ushort", Type::U16}, {"uint16", Type::U16},
      {"int", Type::I32},   {"int32", Type::I32},   {"uint", Type::U32},   {"uint32", Type::U32},
      {"float", Type::F32}, {"float32", Type::F32}, {"double", Type::F64}, {"float64", Type::F64}};
  for (const auto& [n, ty] : names)
    if (s == n) {
      t = ty;
      return true;
    }
  return false;
}

std::size_t typeSize(Type t) {
  switch (t) {
    case Type::I8:
    case Type::U8:
      return 1;
    case Type::I16:
    case Type::U16:
      return 2;
    case Type::I32:
    case Type::U32:
    case Type::F32:
      return 4;
    case Type::F64:
      return 8;
  }
  return 1;
}

bool isIntegral(Type t) { return t != Type::F32 && t != Type::F64; }

struct Property {
  std::string name;
  bool list = false;
  Type countType = Type::U8;
  Type type = Type::F32;
};

struct Element {
  std::string name;
  long long count = 0;
  long line = 0;
  std::vector<Property> props;
};

enum class Encoding { Ascii, BinaryLE, BinaryBE };

// Reads one value at a time from the body, ASCII or binary.
class BodyReader {
 public:
  BodyReader(std::string_view body, long firstLine, Encoding enc, const std::string& name)
      : enc_(enc), sc_(body, name, false), bytes_(body), name_(name) {
    sc_.setOffset(0, firstLine);
  }

  double read(Type t, const char* where) {
    if (enc_ == Encoding::Ascii) {
      const std::string_view tok = sc_.next();
      if (tok.empty()) sc_.fail(std::string("unexpected end of file in ") + where);
      if (isIntegral(t)) return static_cast<double>(sc_.integer(tok, "integer"));
      return sc_.number(tok, "number");
    }
    const std::size_t n = typeSize(t);
    if (pos_ + n > bytes_.size())
      throw ParseError(
          name_, 0,
          std::string("unexpected end of file in ") + where + " (byte " + std::to_string(offset0_ + pos_) + ")");
    unsigned char b[8];
    std::memcpy(b, bytes_.data() + pos_, n);
    pos_ += n;
    if (enc_ == Encoding::BinaryBE) std::reverse(b, b + n);
    switch (t) {
      case Type::I8:
        return static_cast<double>(static_cast<std::int8_t>(b[0]));
      case Type::U8:
        return static_cast<double>(b[0]);
      case Type::I16: {
        std::int16_t v;
        std::memcpy(&v, b, 2);
        return v;
      }
      case Type::U16: {
        std::uint16_t v;
        std::memcpy(&v, b, 2);
        return v;
      }
      case Type::I32: {
        std::int32_t v;
        std::memcpy(&v, b, 4);
        return v;
      }
      case Type::U32: {
        std::uint32_t v;
        std::memcpy(&v, b, 4);
        return v;
      }
      case Type::F32: {
        float v;
        std::memcpy(&v, b, 4);
        return static_cast<double>(v);
      }
      case Type::F64: {
        double v;
        std::memcpy(&v, b, 8);
        return v;
      }
    }
    return 0.0;
  }
  [[nodiscard]] std::size_t remainingBytes() const { return bytes_.size() - pos_; }
  [[nodiscard]] bool binary() const { return enc_ != Encoding::Ascii; }
  [[nodiscard]] long line() const { return enc_ == Encoding::Ascii ? sc_.line() : 0; }
  [[noreturn]] void fail(const std::string& reason) const {
    if (enc_ == Encoding::Ascii) sc_.fail(reason);
    throw ParseError(name_, 0, reason + " (byte " + std::to_string(offset0_ + pos_) + ")");
  }
  void setOffset0(std::size_t o) { offset0_ = o; }
  bool asciiAtEnd() { return sc_.atEnd(); }

 private:
  Encoding enc_;
  detail::Scanner sc_;
  std::string_view bytes_;
  std::string name_;
  std::size_t pos_ = 0, offset0_ = 0;
};

}  // namespace

RawMesh parsePly(std::string_view data, const std::string& name, ImportReport* report) {
  RawMesh raw;
  detail::Scanner hs(data, name, false);
  if (hs.next() != "ply") throw ParseError(name, 1, "not a PLY file (no 'ply' magic line)");
  hs.skipLine();
  Encoding enc = Encoding::Ascii;
  bool haveFormat = false;
  std::vector<Element> elements;
  for (;;) {
    const std::string_view kw = hs.next();
    if (kw.empty()) hs.fail("unexpected end of file in the header (no 'end_header')");
    if (kw == "format") {
      const std::string_view f = hs.nextOnLine();
      if (f == "ascii")
        enc = Encoding::Ascii;
      else if (f == "binary_little_endian")
        enc = Encoding::BinaryLE;
      else if (f == "binary_big_endian")
        enc = Encoding::BinaryBE;
      else
        hs.fail("unknown PLY format " + detail::shown(f));
      haveFormat = true;
    } else if (kw == "comment" || kw == "obj_info") {
    } else if (kw == "element") {
      Element e;
      e.name = std::string(hs.nextOnLine());
      e.count = hs.integer(hs.nextOnLine(), "element count");
      if (e.name.empty() || e.count < 0) hs.fail("bad element declaration");
      e.line = hs.line();
      elements.push_back(std::move(e));
    } else if (kw == "property") {
      if (elements.empty()) hs.fail("'property' before any 'element'");
      Property p;
      std::string_view t = hs.nextOnLine();
      if (t == "list") {
        p.list = true;
        if (!typeFromName(hs.nextOnLine(), p.countType) || !isIntegral(p.countType)) hs.fail("bad list count type");
        t = hs.nextOnLine();
      }
      if (!typeFromName(t, p.type)) hs.fail("unknown property type " + detail::shown(t));
      p.name = std::string(hs.nextOnLine());
      if (p.name.empty()) hs.fail("property without a name");
      elements.back().props.push_back(std::move(p));
    } else if (kw == "end_header") {
      hs.restOfLine();
      hs.skipLine();
      break;
    } else {
      hs.fail("unknown header keyword " + detail::shown(kw));
    }
    hs.restOfLine();
    hs.skipLine();
  }
  if (!haveFormat) hs.fail("header has no 'format' line");

  const Element* faceEl = nullptr;
  for (const auto& e : elements)
    if (e.name == "face") faceEl = &e;
  if (!faceEl)
    for (const auto& e : elements)
      if (e.name == "2d_element") faceEl = &e;

  BodyReader body(data.substr(hs.offset()), hs.line(), enc, name);
  body.setOffset0(hs.offset());
  long long nVertices = -1;
  std::vector<std::uint32_t> poly;
  for (const Element& e : elements) {
    const bool isVertex = e.name == "vertex";
    const bool isFace = &e == faceEl;
    int ix = -1, iy = -1, iz = -1, iIdx = -1;
    for (std::size_t k = 0; k < e.props.size(); ++k) {
      const auto& p = e.props[k];
      const int kk = static_cast<int>(k);
      if (isVertex && !p.list) {
        if (p.name == "x") ix = kk;
        if (p.name == "y") iy = kk;
        if (p.name == "z") iz = kk;
      }
      if (isFace && p.list && (p.name == "vertex_indices" || p.name == "vertex_index")) iIdx = kk;
    }
    if (isVertex && (ix < 0 || iy < 0 || iz < 0)) throw ParseError(name, e.line, "element 'vertex' lacks x, y or z");
    if (isFace && iIdx < 0) throw ParseError(name, e.line, "element '" + e.name + "' has no vertex_indices list");
    if (isVertex) nVertices = e.count;
    if (isFace && nVertices < 0) throw ParseError(name, e.line, "faces come before the vertices");
    // A binary row needs at least this many bytes: a lying count cannot allocate much.
    std::size_t minRow = 0;
    for (const auto& p : e.props) minRow += typeSize(p.list ? p.countType : p.type);
    if (body.binary() && minRow > 0 && static_cast<unsigned long long>(e.count) > body.remainingBytes() / minRow)
      body.fail("element '" + e.name + "' announces " + std::to_string(e.count) + " rows, more than the file holds");
    const std::string where = "element '" + e.name + "'";
    // Rows without properties hold nothing; looping over a lying count of them would hang.
    const long long rows = e.props.empty() ? 0 : e.count;
    for (long long r = 0; r < rows; ++r) {
      Eigen::Vector3d pt = Eigen::Vector3d::Zero();
      const long rowLine = body.line();
      for (std::size_t k = 0; k < e.props.size(); ++k) {
        const auto& p = e.props[k];
        const int kk = static_cast<int>(k);
        if (!p.list) {
          const double v = body.read(p.type, where.c_str());
          if (!std::isfinite(v)) body.fail("non-finite value in " + where + " row " + std::to_string(r));
          if (kk == ix) pt[0] = v;
          if (kk == iy) pt[1] = v;
          if (kk == iz) pt[2] = v;
          continue;
        }
        const double cnt = body.read(p.countType, where.c_str());
        if (cnt < 0) body.fail("negative list length in " + where + " row " + std::to_string(r));
        const auto n = static_cast<std::size_t>(cnt);
        if (body.binary() && n > body.remainingBytes() / typeSize(p.type))
          body.fail("list in " + where + " row " + std::to_string(r) + " runs past the end of the file");
        if (kk == iIdx) poly.clear();
        for (std::size_t j = 0; j < n; ++j) {
          const double v = body.read(p.type, where.c_str());
          if (kk != iIdx) continue;
          if (!(v >= 0 && v < static_cast<double>(nVertices)) || v != std::floor(v))
            body.fail("vertex index " + std::to_string(static_cast<long long>(v)) + " in " + where + " row " +
                      std::to_string(r) + " out of range (" + std::to_string(nVertices) + " vertices)");
          poly.push_back(static_cast<std::uint32_t>(v));
        }
        if (kk == iIdx) {
          if (poly.size() < 3)
            body.fail(where + " row " + std::to_string(r) + " has " + std::to_string(poly.size()) + " corners");
          raw.addPolygon(poly.data(), poly.size(), rowLine);
        }
      }
      if (isVertex) raw.points.push_back(pt);
    }
    if (!isVertex && !isFace && report && e.count > 0)
      report->warnings.push_back(name + ":" + std::to_string(e.line) + ": skipped element '" + e.name + "' (" +
                                 std::to_string(e.count) + " rows)");
  }
  if (nVertices < 0) throw ParseError(name, 0, "no 'vertex' element");
  if (faceEl && faceEl->name != "face" && report)
    report->warnings.push_back(name + ":" + std::to_string(faceEl->line) + ": no 'face' element; using '" +
                               faceEl->name + "' as faces");
  return raw;
}

}  // namespace ld::io
