// VRML 1.0 and 2.0/97 reader. One tokenizer and one generic node parser serve both
// versions (the grammar is the same: nodes, fields, DEF/USE); an evaluation pass then
// walks the scene with the version's semantics (VRML 1.0 keeps a traversal state of
// coordinates, transforms and shape hints; VRML 2.0 nests transforms as groups) and
// emits every IndexedFaceSet it reaches with its accumulated transform.
#include <array>
#include <cstring>
#include <map>
#include <set>
#include <string>
#include <unordered_map>

#include <Eigen/Geometry>

#include "sim/io/mesh_formats.h"
#include "sim/io/parse_util.h"

namespace ld::io {
namespace {

enum class Tok { Word, String, LBrace, RBrace, LBracket, RBracket, End };

struct Token {
  Tok type;
  std::string_view text;
  long line;
};

constexpr int kMaxDepth = 256;
constexpr long kMaxVisits = 2'000'000;           // node evaluations (DEF/USE fan-out)
constexpr std::size_t kMaxEmitted = 50'000'000;  // emitted corner indices

std::vector<Token> tokenize(std::string_view s, long firstLine, const std::string& name) {
  std::vector<Token> out;
  long line = firstLine;
  std::size_t i = 0;
  const auto isSpace = [](char c) {
    return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == ',' || c == '\f' || c == '\v';
  };
  while (i < s.size()) {
    const char c = s[i];
    if (c == '\n') {
      ++line;
      ++i;
    } else if (isSpace(c) || c == '\0') {
      ++i;
    } else if (c == '#') {
      while (i < s.size() && s[i] != '\n') ++i;
    } else if (c == '{' || c == '}' || c == '[' || c == ']') {
      const Tok t = c == '{' ? Tok::LBrace : c == '}' ? Tok::RBrace : c == '[' ? Tok::LBracket : Tok::RBracket;
      out.push_back({t, s.substr(i, 1), line});
      ++i;
    } else if (c == '"') {
      const long startLine = line;
      const std::size_t b = ++i;
      while (i < s.size() && s[i] != '"') {
        if (s[i] == '\\' && i + 1 < s.size()) ++i;
        if (s[i] == '\n') ++line;
        ++i;
      }
      if (i >= s.size()) throw ParseError(name, startLine, "unterminated string");
      out.push_back({Tok::String, s.substr(b, i - b), startLine});
      ++i;
    } else {
      const std::size_t b = i;
      while (i < s.size() && !isSpace(s[i]) && s[i] != '#' && s[i] != '{' && s[i] != '}' && s[i] != '[' &&
             s[i] != ']' && s[i] != '"' && s[i] != '\0')
        ++i;
      out.push_back({Tok::Word, s.substr(b, i - b), line});
    }
  }
  out.push_back({Tok::End, {}, line});
  return out;
}

bool numericStart(std::string_view w) {
  if (w.empty()) return false;
  const char c = w.front();
  return (c >= '0' && c <= '9') || c == '-' || c == '+' || c == '.';
}

struct Field {
  std::string_view name;
  long line = 0;
  std::size_t begin = 0, end = 0;  // scalar tokens [begin, end) (no brackets)
  std::vector<int> nodes;          // SFNode / MFNode values (-1 for NULL or unknown USE)
};

struct Node {
  std::string_view type;
  long line = 0;
  std::vector<Field> fields;
  std::vector<int> children;  // VRML 1.0 child nodes written inside the body
  [[nodiscard]] const Field* field(std::string_view n) const {
    for (const auto& f : fields)
      if (f.name == n) return &f;
    return nullptr;
  }
};

class Parser {
 public:
  Parser(std::vector<Token> toks, std::string name, ImportReport* report)
      : t_(std::move(toks)), name_(std::move(name)), report_(report) {}

  std::vector<int> parseFile() {
    std::vector<int> roots;
    while (t_[p_].type != Tok::End) {
      if (t_[p_].type == Tok::RBrace) fail(t_[p_].line, "unbalanced braces: '}' without a matching '{'");
      if (t_[p_].type == Tok::RBracket) fail(t_[p_].line, "unbalanced brackets: ']' without a matching '['");
      if (t_[p_].type != Tok::Word) fail(t_[p_].line, "expected a node, found " + detail::shown(t_[p_].text));
      if (statement()) continue;
      roots.push_back(node(0));
    }
    return roots;
  }

  const std::vector<Node>& nodes() const { return nodes_; }
  const std::vector<Token>& tokens() const { return t_; }

 private:
  [[noreturn]] void fail(long line, const std::string& reason) const { throw ParseError(name_, line, reason); }
  void warn(long line, const std::string& reason) {
    if (report_) report_->warnings.push_back(name_ + ":" + std::to_string(line) + ": " + reason);
  }

  bool isWord(std::size_t i, std::string_view w) const { return t_[i].type == Tok::Word && t_[i].text == w; }
  bool startsNode(std::size_t i) const {
    if (t_[i].type != Tok::Word) return false;
    return t_[i].text == "DEF" || t_[i].text == "USE" || t_[i + 1].type == Tok::LBrace ||
           protos_.count(std::string(t_[i].text)) > 0;
  }

  // Skips from an opening bracket or brace to its partner.
  void skipBalanced() {
    const Tok open = t_[p_].type;
    const Tok close = open == Tok::LBrace ? Tok::RBrace : Tok::RBracket;
    const long line = t_[p_].line;
    int depth = 0;
    for (;; ++p_) {
      if (t_[p_].type == Tok::End)
        fail(line, std::string("unbalanced ") + (open == Tok::LBrace ? "braces" : "brackets") + ": '" +
                       (open == Tok::LBrace ? "{" : "[") + "' is never closed");
      if (t_[p_].type == open) ++depth;
      if (t_[p_].type == close && --depth == 0) {
        ++p_;
        return;
      }
    }
  }

  // PROTO, EXTERNPROTO and ROUTE: read past. Returns true when one was consumed.
  bool statement() {
    if (isWord(p_, "ROUTE")) {
      for (int k = 0; k < 4; ++k) {
        if (t_[p_].type != Tok::Word) fail(t_[p_].line, "malformed ROUTE");
        ++p_;
      }
      return true;
    }
    if (isWord(p_, "PROTO") || isWord(p_, "EXTERNPROTO")) {
      const bool ext = isWord(p_, "EXTERNPROTO");
      const long line = t_[p_].line;
      ++p_;
      if (t_[p_].type != Tok::Word) fail(line, "PROTO without a name");
      protos_.insert(std::string(t_[p_].text));
      warn(line, std::string(ext ? "EXTERNPROTO " : "PROTO ") + std::string(t_[p_].text) +
                     " not supported; its instances are skipped");
      ++p_;
      if (t_[p_].type != Tok::LBracket) fail(line, "PROTO interface must start with '['");
      skipBalanced();
      if (ext) {
        if (t_[p_].type == Tok::LBracket)
          skipBalanced();
        else if (t_[p_].type == Tok::String)
          ++p_;
      } else {
        if (t_[p_].type != Tok::LBrace) fail(line, "PROTO body must start with '{'");
        skipBalanced();
      }
      return true;
    }
    return false;
  }

  int node(int depth) {
    if (depth > kMaxDepth) fail(t_[p_].line, "nodes nested too deeply");
    const Token& first = t_[p_];
    if (first.text == "DEF") {
      ++p_;
      if (t_[p_].type != Tok::Word) fail(first.line, "DEF without a name");
      const std::string defName(t_[p_].text);
      ++p_;
      if (!startsNode(p_) || t_[p_].text == "DEF" || t_[p_].text == "USE")
        fail(first.line, "DEF " + defName + " is not followed by a node");
      const int id = node(depth + 1);
      defs_[defName] = id;
      return id;
    }
    if (first.text == "USE") {
      ++p_;
      if (t_[p_].type != Tok::Word) fail(first.line, "USE without a name");
      const std::string useName(t_[p_].text);
      ++p_;
      auto it = defs_.find(useName);
      if (it == defs_.end()) {
        warn(first.line, "USE of undefined name '" + useName + "' ignored");
        return -1;
      }
      return it->second;
    }
    Node n;
    n.type = first.text;
    n.line = first.line;
    ++p_;
    if (t_[p_].type != Tok::LBrace) {
      // A PROTO instance without a body cannot occur; anything else is malformed.
      fail(first.line, "expected '{' after node type " + detail::shown(first.text));
    }
    const long openLine = t_[p_].line;
    ++p_;
    for (;;) {
      const Token& t = t_[p_];
      if (t.type == Tok::RBrace) {
        ++p_;
        break;
      }
      if (t.type == Tok::End) fail(openLine, "unbalanced braces: '{' of " + std::string(n.type) + " is never closed");
      if (t.type != Tok::Word) fail(t.line, "unexpected " + detail::shown(t.text) + " in " + std::string(n.type));
      if (statement()) continue;
      if (startsNode(p_)) {
        n.children.push_back(node(depth + 1));
        continue;
      }
      n.fields.push_back(fieldValue(depth));
    }
    nodes_.push_back(std::move(n));
    return static_cast<int>(nodes_.size() - 1);
  }

  Field fieldValue(int depth) {
    Field f;
    f.name = t_[p_].text;
    f.line = t_[p_].line;
    ++p_;
    const Token& v = t_[p_];
    f.begin = f.end = p_;
    if (v.type == Tok::LBracket) {
      const long openLine = v.line;
      ++p_;
      f.begin = p_;
      bool scalars = false;
      for (;;) {
        const Token& t = t_[p_];
        if (t.type == Tok::RBracket) break;
        if (t.type == Tok::End)
          fail(openLine, "unbalanced brackets: '[' of field " + std::string(f.name) + " is never closed");
        if (t.type == Tok::LBrace || t.type == Tok::RBrace || t.type == Tok::LBracket)
          fail(t.line, "unexpected " + detail::shown(t.text) + " in the list of field " + std::string(f.name));
        if (t.type == Tok::Word && statement()) continue;
        if (t.type == Tok::Word && startsNode(p_)) {
          if (scalars) fail(t.line, "node inside a list of values in field " + std::string(f.name));
          f.nodes.push_back(node(depth + 1));
          f.begin = p_;
          continue;
        }
        if (!f.nodes.empty()) fail(t.line, "value " + detail::shown(t.text) + " inside a list of nodes");
        scalars = true;
        ++p_;
      }
      f.end = p_;
      ++p_;  // ']'
      if (!scalars) f.begin = f.end;
      return f;
    }
    if (v.type == Tok::Word && startsNode(p_)) {
      f.nodes.push_back(node(depth + 1));
      f.begin = f.end = p_;
      return f;
    }
    if (v.type == Tok::String) {
      f.end = ++p_;
      return f;
    }
    if (v.type != Tok::Word) return f;  // empty value before '}' (lenient)
    if (v.text == "NULL") {
      ++p_;
      f.begin = f.end = p_;
      f.nodes.push_back(-1);
      return f;
    }
    if (numericStart(v.text)) {
      while (t_[p_].type == Tok::Word && numericStart(t_[p_].text)) ++p_;
      f.end = p_;
      return f;
    }
    if (v.text.front() == '(') {  // VRML 1.0 bit mask: ( A | B )
      const long line = v.line;
      while (t_[p_].type == Tok::Word && t_[p_].text.back() != ')') ++p_;
      if (t_[p_].type != Tok::Word) fail(line, "unterminated bit mask in field " + std::string(f.name));
      f.end = ++p_;
      return f;
    }
    f.end = ++p_;  // one word: a boolean or an enumeration value
    return f;
  }

  std::vector<Token> t_;
  std::string name_;
  ImportReport* report_;
  std::size_t p_ = 0;
  std::vector<Node> nodes_;
  std::unordered_map<std::string, int> defs_;
  std::set<std::string> protos_;
};

// ---------------------------------------------------------------------------------
// Evaluation

struct State {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  int coord = -1;          // VRML 1.0 current Coordinate3 node
  bool clockwise = false;  // VRML 1.0 ShapeHints vertexOrdering
};

class Evaluator {
 public:
  Evaluator(const Parser& p, int version, std::string name, ImportReport* report)
      : nodes_(p.nodes()), t_(p.tokens()), v1_(version == 1), name_(std::move(name)), report_(report) {}

  RawMesh run(const std::vector<int>& roots) {
    State st;
    for (int r : roots) eval(r, st, 0);
    return std::move(raw_);
  }

 private:
  [[noreturn]] void fail(long line, const std::string& reason) const { throw ParseError(name_, line, reason); }
  void warnOnce(long line, const std::string& key, const std::string& reason) {
    if (report_ && warned_.insert(key).second)
      report_->warnings.push_back(name_ + ":" + std::to_string(line) + ": " + reason);
  }

  std::vector<double> numbers(const Field& f, std::size_t multiple, const char* what) const {
    std::vector<double> out;
    out.reserve(f.end - f.begin);
    for (std::size_t i = f.begin; i < f.end; ++i) {
      double v = 0;
      if (t_[i].type != Tok::Word || !detail::parseDouble(t_[i].text, v)) {
        const std::string_view w = t_[i].text;
        if (w == "nan" || w == "NaN" || w == "inf" || w == "-inf" || w == "-nan")
          fail(t_[i].line, std::string("non-finite number ") + detail::shown(w) + " in " + what);
        fail(t_[i].line, std::string("expected a number in ") + what + ", found " + detail::shown(w));
      }
      out.push_back(v);
    }
    if (multiple > 1 && out.size() % multiple != 0)
      fail(f.line, std::string(what) + " has " + std::to_string(out.size()) + " numbers, not a multiple of " +
                       std::to_string(multiple));
    return out;
  }

  Eigen::Vector3d vec3(const Node& n, std::string_view field, const Eigen::Vector3d& def) const {
    const Field* f = n.field(field);
    if (!f) return def;
    const auto v = numbers(*f, 1, std::string(field).c_str());
    if (v.size() != 3) fail(f->line, std::string(field) + " needs 3 numbers, has " + std::to_string(v.size()));
    return {v[0], v[1], v[2]};
  }

  Eigen::Matrix3d rotation(const Node& n, std::string_view field) const {
    const Field* f = n.field(field);
    if (!f) return Eigen::Matrix3d::Identity();
    const auto v = numbers(*f, 1, std::string(field).c_str());
    if (v.size() != 4)
      fail(f->line, std::string(field) + " needs 4 numbers (axis and angle), has " + std::to_string(v.size()));
    Eigen::Vector3d axis(v[0], v[1], v[2]);
    if (axis.norm() == 0.0) return Eigen::Matrix3d::Identity();
    return Eigen::AngleAxisd(v[3], axis.normalized()).toRotationMatrix();
  }

  // T * C * R * SR * S * SR^-1 * C^-1 (the VRML Transform definition).
  Eigen::Matrix4d transformMatrix(const Node& n) const {
    const Eigen::Vector3d t = vec3(n, "translation", Eigen::Vector3d::Zero());
    const Eigen::Vector3d c = vec3(n, "center", Eigen::Vector3d::Zero());
    const Eigen::Vector3d s = n.field("scaleFactor") ? vec3(n, "scaleFactor", Eigen::Vector3d::Ones())
                                                     : vec3(n, "scale", Eigen::Vector3d::Ones());
    const Eigen::Matrix3d r = rotation(n, "rotation");
    const Eigen::Matrix3d so = rotation(n, "scaleOrientation");
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = r * so * s.asDiagonal() * so.transpose();
    m.topRightCorner<3, 1>() = t + c - m.topLeftCorner<3, 3>() * c;
    return m;
  }

  Eigen::Matrix4d matrixField(const Node& n) const {
    const Field* f = n.field("matrix");
    if (!f) return Eigen::Matrix4d::Identity();
    const auto v = numbers(*f, 1, "matrix");
    if (v.size() != 16) fail(f->line, "matrix needs 16 numbers, has " + std::to_string(v.size()));
    // Inventor matrices act on row vectors (translation in the last row): transpose.
    Eigen::Matrix4d m;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) m(c, r) = v[static_cast<std::size_t>(4 * r + c)];
    return m;
  }

  std::string word(const Node& n, std::string_view field, const std::string& def) const {
    const Field* f = n.field(field);
    if (!f || f->begin == f->end) return def;
    return std::string(t_[f->begin].text);
  }

  bool boolean(const Node& n, std::string_view field, bool def) const {
    const std::string w = word(n, field, def ? "TRUE" : "FALSE");
    if (w == "TRUE") return true;
    if (w == "FALSE") return false;
    fail(n.field(field)->line, std::string(field) + " must be TRUE or FALSE, found " + detail::shown(w));
  }

  const std::vector<Eigen::Vector3d>& points(int coordNode) {
    auto it = pointCache_.find(coordNode);
    if (it != pointCache_.end()) return it->second;
    std::vector<Eigen::Vector3d> pts;
    if (coordNode >= 0) {
      const Field* f = nodes_[static_cast<std::size_t>(coordNode)].field("point");
      if (f) {
        const auto v = numbers(*f, 3, "point");
        for (std::size_t i = 0; i + 2 < v.size(); i += 3) pts.emplace_back(v[i], v[i + 1], v[i + 2]);
      }
    }
    return pointCache_.emplace(coordNode, std::move(pts)).first->second;
  }

  void emitFaceSet(const Node& ifs, int coordNode, const Eigen::Matrix4d& m, bool clockwise) {
    const Field* ci = ifs.field("coordIndex");
    if (!ci || ci->begin == ci->end) return;
    const auto& pts = points(coordNode);
    // Faces of one coordinate node under one transform share their vertices; another
    // transform (an instance through USE) gets its own copy. The copy keeps the file's
    // point order; points no face uses are dropped later.
    VertexKey key{coordNode, {}};
    std::memcpy(key.m.data(), m.data(), sizeof(double) * 16);
    auto [blockIt, fresh] = blocks_.try_emplace(key, static_cast<std::uint32_t>(raw_.points.size()));
    const std::uint32_t base = blockIt->second;
    if (fresh) {
      if (raw_.points.size() + pts.size() > kMaxEmitted) fail(ci->line, "too many points (instancing limit)");
      for (const auto& q : pts) {
        const Eigen::Vector3d p = (m * q.homogeneous()).head<3>();
        if (!p.allFinite()) fail(ci->line, "transformed point is not finite");
        raw_.points.push_back(p);
      }
    }
    const bool flip = clockwise != (m.topLeftCorner<3, 3>().determinant() < 0.0);
    std::vector<std::uint32_t> poly;
    long polyLine = t_[ci->begin].line;
    auto flush = [&]() {
      if (!poly.empty()) {
        if (flip) std::reverse(poly.begin(), poly.end());
        raw_.addPolygon(poly.data(), poly.size(), polyLine);
      }
      poly.clear();
    };
    for (std::size_t i = ci->begin; i < ci->end; ++i) {
      long long k = 0;
      if (t_[i].type != Tok::Word || !detail::parseInt(t_[i].text, k))
        fail(t_[i].line, "expected an integer in coordIndex, found " + detail::shown(t_[i].text));
      if (k == -1) {
        flush();
        continue;
      }
      if (k < -1 || k >= static_cast<long long>(pts.size()))
        fail(t_[i].line,
             "coordIndex " + std::to_string(k) + " out of range (" + std::to_string(pts.size()) + " points)");
      if (poly.empty()) polyLine = t_[i].line;
      poly.push_back(base + static_cast<std::uint32_t>(k));
      if (raw_.indices.size() + poly.size() > kMaxEmitted) fail(t_[i].line, "too many faces (instancing limit)");
    }
    flush();
  }

  void evalChildren(const Node& n, State& st, int depth) {
    for (int c : n.children) eval(c, st, depth + 1);
    if (const Field* f = n.field("children"))
      for (int c : f->nodes) eval(c, st, depth + 1);
  }

  void eval(int id, State& st, int depth) {
    if (id < 0) return;
    if (++visits_ > kMaxVisits) fail(0, "too many node instances (DEF/USE fan-out limit)");
    if (depth > kMaxDepth) fail(0, "USE nesting too deep");
    const Node& n = nodes_[static_cast<std::size_t>(id)];
    const std::string_view ty = n.type;
    if (ty == "Separator" || ty == "WWWAnchor" || ty == "Anchor" || ty == "Billboard" || ty == "Collision") {
      State inner = st;
      evalChildren(n, inner, depth);
    } else if (ty == "Group") {
      if (v1_) {
        evalChildren(n, st, depth);
      } else {
        State inner = st;
        evalChildren(n, inner, depth);
      }
    } else if (ty == "TransformSeparator") {
      const Eigen::Matrix4d saved = st.m;
      evalChildren(n, st, depth);
      st.m = saved;
    } else if (ty == "Switch") {
      const bool v2 = n.field("choice") != nullptr;
      const Field* which = n.field(v2 ? "whichChoice" : "whichChild");
      long long k = -1;
      if (which && which->begin != which->end) {
        if (!detail::parseInt(t_[which->begin].text, k)) fail(which->line, "whichChild must be an integer");
      }
      std::vector<int> kids = n.children;
      if (const Field* f = n.field(v2 ? "choice" : "children"))
        kids.insert(kids.end(), f->nodes.begin(), f->nodes.end());
      State inner = st;
      State& s = v2 ? inner : st;
      if (k == -3) {
        for (int c : kids) eval(c, s, depth + 1);
      } else if (k >= 0 && k < static_cast<long long>(kids.size())) {
        eval(kids[static_cast<std::size_t>(k)], s, depth + 1);
      }
    } else if (ty == "LOD") {
      State inner = st;
      State& s = v1_ ? st : inner;
      if (const Field* lv = n.field("level"); lv && !lv->nodes.empty()) {
        eval(lv->nodes.front(), s, depth + 1);
      } else if (!n.children.empty()) {
        eval(n.children.front(), s, depth + 1);
      }
    } else if (ty == "Transform") {
      if (v1_ && !n.field("children") && n.children.empty()) {
        st.m = st.m * transformMatrix(n);
      } else {
        State inner = st;
        inner.m = st.m * transformMatrix(n);
        evalChildren(n, inner, depth);
      }
    } else if (ty == "Translation") {
      Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
      t.topRightCorner<3, 1>() = vec3(n, "translation", Eigen::Vector3d::Zero());
      st.m = st.m * t;
    } else if (ty == "Rotation") {
      Eigen::Matrix4d r = Eigen::Matrix4d::Identity();
      r.topLeftCorner<3, 3>() = rotation(n, "rotation");
      st.m = st.m * r;
    } else if (ty == "Scale") {
      Eigen::Matrix4d s = Eigen::Matrix4d::Identity();
      s.topLeftCorner<3, 3>() = vec3(n, "scaleFactor", Eigen::Vector3d::Ones()).asDiagonal();
      st.m = st.m * s;
    } else if (ty == "MatrixTransform") {
      st.m = st.m * matrixField(n);
    } else if (ty == "Coordinate3") {
      st.coord = id;
    } else if (ty == "ShapeHints") {
      const std::string o = word(n, "vertexOrdering", "UNKNOWN_ORDERING");
      st.clockwise = o == "CLOCKWISE";
    } else if (ty == "IndexedFaceSet") {
      if (const Field* c = n.field("coord")) {  // VRML 2.0 style
        emitFaceSet(n, c->nodes.empty() ? -1 : c->nodes.front(), st.m, !boolean(n, "ccw", true));
      } else {
        emitFaceSet(n, st.coord, st.m, st.clockwise);
      }
    } else if (ty == "Shape") {
      if (const Field* g = n.field("geometry"); g && !g->nodes.empty()) eval(g->nodes.front(), st, depth + 1);
    } else if (ty == "Sphere" || ty == "Cone" || ty == "Box" || ty == "Cylinder" || ty == "Cube" ||
               ty == "ElevationGrid" || ty == "Extrusion" || ty == "Text" || ty == "AsciiText" || ty == "FaceSet" ||
               ty == "TriangleStripSet" || ty == "QuadMesh" || ty == "NurbsSurface" || ty == "IndexedNurbsSurface") {
      warnOnce(n.line, std::string(ty), std::string(ty) + " is not imported (only IndexedFaceSet geometry); skipped");
    } else if (ty == "Inline" || ty == "WWWInline") {
      warnOnce(n.line, std::string(ty), std::string(ty) + " (external file) is not followed; skipped");
    } else if (!knownIgnored(ty)) {
      warnOnce(n.line, "node " + std::string(ty), "unknown node " + std::string(ty) + " skipped");
    }
  }

  static bool knownIgnored(std::string_view ty) {
    static const std::set<std::string_view> names = {"Material",
                                                     "Appearance",
                                                     "ImageTexture",
                                                     "PixelTexture",
                                                     "MovieTexture",
                                                     "Texture2",
                                                     "TextureCoordinate",
                                                     "TextureCoordinate2",
                                                     "TextureTransform",
                                                     "Texture2Transform",
                                                     "Normal",
                                                     "NormalBinding",
                                                     "MaterialBinding",
                                                     "Color",
                                                     "Coordinate",
                                                     "Info",
                                                     "WorldInfo",
                                                     "PointLight",
                                                     "DirectionalLight",
                                                     "SpotLight",
                                                     "NavigationInfo",
                                                     "Viewpoint",
                                                     "Background",
                                                     "Fog",
                                                     "PerspectiveCamera",
                                                     "OrthographicCamera",
                                                     "FontStyle",
                                                     "Sound",
                                                     "AudioClip",
                                                     "TimeSensor",
                                                     "TouchSensor",
                                                     "PlaneSensor",
                                                     "SphereSensor",
                                                     "CylinderSensor",
                                                     "ProximitySensor",
                                                     "VisibilitySensor",
                                                     "PositionInterpolator",
                                                     "OrientationInterpolator",
                                                     "ColorInterpolator",
                                                     "ScalarInterpolator",
                                                     "CoordinateInterpolator",
                                                     "NormalInterpolator",
                                                     "Script",
                                                     "IndexedLineSet",
                                                     "PointSet",
                                                     "LineSet",
                                                     "Font",
                                                     "DrawStyle",
                                                     "Complexity",
                                                     "Environment",
                                                     "LightModel",
                                                     "TextureCoordinateBinding",
                                                     "TextureCoordinateDefault",
                                                     "TextureCoordinatePlane"};
    return names.count(ty) > 0;
  }

  struct VertexKey {
    int node;
    std::array<double, 16> m;
    bool operator<(const VertexKey& o) const {
      if (node != o.node) return node < o.node;
      return std::memcmp(m.data(), o.m.data(), sizeof(double) * 16) < 0;
    }
  };

  const std::vector<Node>& nodes_;
  const std::vector<Token>& t_;
  bool v1_;
  std::string name_;
  ImportReport* report_;
  RawMesh raw_;
  long visits_ = 0;
  std::map<int, std::vector<Eigen::Vector3d>> pointCache_;
  std::map<VertexKey, std::uint32_t> blocks_;  // first point of each (coordinates, transform) copy
  std::set<std::string> warned_;
};

int guessVersion(const std::vector<Token>& toks) {
  static const std::set<std::string_view> v1 = {"Separator",       "Coordinate3",  "ShapeHints", "Translation",
                                                "MatrixTransform", "Cube",         "Texture2",   "TransformSeparator",
                                                "MaterialBinding", "NormalBinding"};
  for (const auto& t : toks)
    if (t.type == Tok::Word && v1.count(t.text)) return 1;
  return 2;
}

}  // namespace

RawMesh parseVrml(std::string_view text, const std::string& name, ImportReport* report) {
  if (text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);
  if (text.size() >= 2 && static_cast<unsigned char>(text[0]) == 0x1f && static_cast<unsigned char>(text[1]) == 0x8b)
    throw ParseError(name, 1, "gzip-compressed VRML is not supported (decompress it first)");
  int version = 0;
  if (text.substr(0, 5) == "#VRML") {
    // Only the first tokens of the header count: "#VRML V2.0 utf8 CosmoWorlds V1.0" is 2.0.
    const std::size_t eol = std::min(text.find('\n'), text.size());
    std::string_view head = text.substr(5, eol - 5);
    while (!head.empty() && (head.front() == ' ' || head.front() == '\t')) head.remove_prefix(1);
    if (head.substr(0, 4) == "V1.0")
      version = 1;
    else if (head.substr(0, 4) == "V2.0")
      version = 2;
    else if (report)
      report->warnings.push_back(name + ":1: unknown VRML version in the header; guessing from the content");
  } else if (report) {
    report->warnings.push_back(name + ":1: no '#VRML V1.0' or '#VRML V2.0' header; reading leniently");
  }
  Parser parser(tokenize(text, 1, name), name, report);
  const std::vector<int> roots = parser.parseFile();
  if (version == 0) version = guessVersion(parser.tokens());
  if (report) report->vrmlVersion = version;
  Evaluator ev(parser, version, name, report);
  return ev.run(roots);
}

}  // namespace ld::io
