#include "sim/mesh/surface_mesh.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>
#include <unordered_set>

namespace ld::mesh {

std::string ValidationReport::message() const {
  std::string s;
  for (const auto& p : problems) s += p + "\n";
  return s;
}

// ---- construction -----------------------------------------------------------

SurfaceMesh::SurfaceMesh() { initBuiltins(); }

namespace {
std::uint64_t nextVersionId() {
  static std::atomic<std::uint64_t> counter{0};
  return counter.fetch_add(1, std::memory_order_relaxed) + 1;
}
}  // namespace

// Layout ids are unique across all meshes of the process, so that a cache never takes
// another mesh's (or an earlier content's) journal for its own.
void SurfaceMesh::newLayout() {
  layoutVersion_ = nextVersionId();
  journalV_.clear();
  journalE_.clear();
  journalF_.clear();
}

void SurfaceMesh::newPropertySet() { propertySetVersion_ = nextVersionId(); }

void SurfaceMesh::initBuiltins() {
  vprops_ = PropertyContainer();
  eprops_ = PropertyContainer();
  fprops_ = PropertyContainer();
  vprops_.add<Point>("v:point", Point::Zero());
  vprops_.add<EdgeList>("v:edges", {});
  vprops_.add<std::uint8_t>("v:deleted", 0);
  eprops_.add<std::array<Vertex, 2>>("e:vertices", {});
  eprops_.add<std::array<Face, 2>>("e:faces", {});
  eprops_.add<std::uint8_t>("e:deleted", 0);
  fprops_.add<std::array<Vertex, 3>>("f:vertices", {});
  fprops_.add<std::array<Edge, 3>>("f:edges", {});
  fprops_.add<std::uint8_t>("f:deleted", 0);
  deletedVertices_ = deletedEdges_ = deletedFaces_ = 0;
  bindProperties();
  newLayout();
  newPropertySet();
}

void SurfaceMesh::bindProperties() {
  points_ = getVertexProperty<Point>("v:point");
  vedges_ = getVertexProperty<EdgeList>("v:edges");
  vdeleted_ = getVertexProperty<std::uint8_t>("v:deleted");
  everts_ = getEdgeProperty<std::array<Vertex, 2>>("e:vertices");
  efaces_ = getEdgeProperty<std::array<Face, 2>>("e:faces");
  edeleted_ = getEdgeProperty<std::uint8_t>("e:deleted");
  fverts_ = getFaceProperty<std::array<Vertex, 3>>("f:vertices");
  fedges_ = getFaceProperty<std::array<Edge, 3>>("f:edges");
  fdeleted_ = getFaceProperty<std::uint8_t>("f:deleted");
  // The edits append to the built-ins directly (PropertyContainer::pushBackTyped): they
  // must be the first three arrays of their containers, as initBuiltins adds them.
  auto firstAre = [](const PropertyContainer& c, const char* a, const char* b, const char* d) {
    return c.arrayCount() >= 3 && c.array(0).name() == a && c.array(1).name() == b && c.array(2).name() == d;
  };
  if (!firstAre(vprops_, "v:point", "v:edges", "v:deleted") ||
      !firstAre(eprops_, "e:vertices", "e:faces", "e:deleted") ||
      !firstAre(fprops_, "f:vertices", "f:edges", "f:deleted"))
    throw PropertyError("built-in properties out of place");
}

SurfaceMesh::SurfaceMesh(const SurfaceMesh& o)
    : vprops_(o.vprops_),
      eprops_(o.eprops_),
      fprops_(o.fprops_),
      deletedVertices_(o.deletedVertices_),
      deletedEdges_(o.deletedEdges_),
      deletedFaces_(o.deletedFaces_),
      topologyVersion_(o.topologyVersion_) {
  bindProperties();
  newLayout();
  newPropertySet();
}

SurfaceMesh& SurfaceMesh::operator=(const SurfaceMesh& o) {
  if (this != &o) {
    SurfaceMesh tmp(o);
    *this = std::move(tmp);
  }
  return *this;
}

// Property views point into heap-allocated arrays, which move with the containers.
SurfaceMesh::SurfaceMesh(SurfaceMesh&& o) noexcept
    : vprops_(std::move(o.vprops_)),
      eprops_(std::move(o.eprops_)),
      fprops_(std::move(o.fprops_)),
      deletedVertices_(o.deletedVertices_),
      deletedEdges_(o.deletedEdges_),
      deletedFaces_(o.deletedFaces_),
      topologyVersion_(o.topologyVersion_),
      layoutVersion_(o.layoutVersion_),
      propertySetVersion_(o.propertySetVersion_),
      journalV_(std::move(o.journalV_)),
      journalE_(std::move(o.journalE_)),
      journalF_(std::move(o.journalF_)),
      scratch_(std::move(o.scratch_)) {
  bindProperties();
  o.initBuiltins();
}

SurfaceMesh& SurfaceMesh::operator=(SurfaceMesh&& o) noexcept {
  if (this != &o) {
    vprops_ = std::move(o.vprops_);
    eprops_ = std::move(o.eprops_);
    fprops_ = std::move(o.fprops_);
    deletedVertices_ = o.deletedVertices_;
    deletedEdges_ = o.deletedEdges_;
    deletedFaces_ = o.deletedFaces_;
    topologyVersion_ = o.topologyVersion_ + 1;
    // The contents are replaced: a cache built for this object's old contents must
    // not read the journal as a continuation, so the layout is new.
    scratch_ = std::move(o.scratch_);
    bindProperties();
    o.initBuiltins();
    newLayout();
    newPropertySet();
  }
  return *this;
}

void SurfaceMesh::clear() {
  initBuiltins();  // new layout
  ++topologyVersion_;
}

// Every property, built-in or attached, so that the edits up to these sizes do not
// reallocate an array.
void SurfaceMesh::reserve(std::size_t nv, std::size_t ne, std::size_t nf) {
  vprops_.reserve(nv);
  eprops_.reserve(ne);
  fprops_.reserve(nf);
  // splitVertex's per-face marks too (stamps: zeros are "unmarked"), so that the first
  // split after a reserve does not size and fill them inside an edit.
  if (scratch_.fanMark.size() < nf) scratch_.fanMark.resize(nf, 0);
  // Cutting journals about 8 edges, 4 faces and 2 vertices per face it adds (benchmark
  // strokes: 8.5, 3.8, 0.7): room for that, so that the journal's doublings (each a copy
  // into fresh pages) do not fall inside an edit either.
  const std::size_t newFaces = nf > facesSize() ? nf - facesSize() : 0;
  journalV_.reserve(journalV_.view().size() + 2 * newFaces);
  journalE_.reserve(journalE_.view().size() + 8 * newFaces);
  journalF_.reserve(journalF_.view().size() + 4 * newFaces);
}

void SurfaceMesh::touchReserved() {
  vprops_.touchReserved();
  eprops_.touchReserved();
  fprops_.touchReserved();
  journalV_.touchReserved();
  journalE_.touchReserved();
  journalF_.touchReserved();
}

void SurfaceMesh::removeVertexProperty(const std::string& name) {
  if (name.rfind("v:point", 0) == 0 || name == "v:edges" || name == "v:deleted")
    throw PropertyError("cannot remove built-in property '" + name + "'");
  vprops_.remove(name);
  newPropertySet();
}
void SurfaceMesh::removeEdgeProperty(const std::string& name) {
  if (name == "e:vertices" || name == "e:faces" || name == "e:deleted")
    throw PropertyError("cannot remove built-in property '" + name + "'");
  eprops_.remove(name);
  newPropertySet();
}
void SurfaceMesh::removeFaceProperty(const std::string& name) {
  if (name == "f:vertices" || name == "f:edges" || name == "f:deleted")
    throw PropertyError("cannot remove built-in property '" + name + "'");
  fprops_.remove(name);
  newPropertySet();
}

void SurfaceMesh::throwInvalid(Vertex v, const char* where) {
  std::ostringstream s;
  s << where << ": " << v << " is not a live vertex";
  throw InvalidHandleError(s.str());
}
void SurfaceMesh::throwInvalid(Edge e, const char* where) {
  std::ostringstream s;
  s << where << ": " << e << " is not a live edge";
  throw InvalidHandleError(s.str());
}
void SurfaceMesh::throwInvalid(Face f, const char* where) {
  std::ostringstream s;
  s << where << ": " << f << " is not a live face";
  throw InvalidHandleError(s.str());
}

// ---- low-level element creation --------------------------------------------

// The built-in arrays are appended to with their values (kBuiltins per kind, see
// bindProperties), the attached properties get their defaults or copies.
constexpr std::size_t kBuiltins = 3;

Vertex SurfaceMesh::addVertex(const Point& p) {
  const Point at = p;  // p may be a position of this mesh
  vprops_.pushBackTyped(kBuiltins, [&] {
    points_.vector().push_back(at);
    vedges_.vector().emplace_back();
    vdeleted_.vector().push_back(0);
  });
  Vertex v(verticesSize() - 1);
  record(journalV_, v);
  return v;
}

Edge SurfaceMesh::newEdge(Vertex a, Vertex b) {
  eprops_.pushBackTyped(kBuiltins, [&] {
    everts_.vector().push_back({a, b});
    efaces_.vector().push_back({Face(), Face()});
    edeleted_.vector().push_back(0);
  });
  return linkNewEdge(a, b);
}

Face SurfaceMesh::newFace() {
  fprops_.pushBackTyped(kBuiltins, [&] {
    fverts_.vector().emplace_back();
    fedges_.vector().emplace_back();
    fdeleted_.vector().push_back(0);
  });
  return journalNewFace();
}

// A new edge (a, b), without faces, with the attached properties of `from` (one pass
// over the property arrays).
Edge SurfaceMesh::newEdgeCopy(Edge from, Vertex a, Vertex b) {
  const std::uint8_t deleted = edeleted_[from];
  eprops_.pushBackCopyTyped(kBuiltins, from.idx(), [&] {
    everts_.vector().push_back({a, b});
    efaces_.vector().push_back({Face(), Face()});
    edeleted_.vector().push_back(deleted);
  });
  return linkNewEdge(a, b);
}

// A new face with the attached properties of `from` (its corners and sides are set by
// attachFace).
Face SurfaceMesh::newFaceCopy(Face from) {
  const std::uint8_t deleted = fdeleted_[from];
  fprops_.pushBackCopyTyped(kBuiltins, from.idx(), [&] {
    fverts_.vector().emplace_back();
    fedges_.vector().emplace_back();
    fdeleted_.vector().push_back(deleted);
  });
  return journalNewFace();
}

// The last edge (just pushed as (a, b) without faces) listed at both ends.
Edge SurfaceMesh::linkNewEdge(Vertex a, Vertex b) {
  const Edge e(edgesSize() - 1);
  addEdgeToVertex(a, e);
  addEdgeToVertex(b, e);
  record(journalE_, e);
  return e;
}

Face SurfaceMesh::journalNewFace() {
  const Face f(facesSize() - 1);
  record(journalF_, f);
  return f;
}

bool SurfaceMesh::runsForward(Face f, Edge e) const {
  const auto& fv = fverts_[f];
  const auto& ev = everts_[e];
  for (int i = 0; i < 3; ++i)
    if (fv[static_cast<std::size_t>(i)] == ev[0]) return fv[static_cast<std::size_t>((i + 1) % 3)] == ev[1];
  return false;
}

void SurfaceMesh::removeEdgeFromVertex(Vertex v, Edge e) {
  auto& list = vedges_[v];
  auto it = std::find(list.begin(), list.end(), e);
  if (it != list.end()) {
    *it = list.back();
    list.pop_back();
  }
}

void SurfaceMesh::detachFace(Face f) {
  record(journalF_, f);
  for (Edge e : fedges_[f]) {
    record(journalE_, e);
    auto& ef = efaces_[e];
    if (ef[0] == f) {
      ef[0] = ef[1];
      ef[1] = Face();
    } else if (ef[1] == f) {
      ef[1] = Face();
    }
  }
}

void SurfaceMesh::attachFace(Face f, Vertex a, Vertex b, Vertex c, std::array<Edge, 3> known, bool missingAreNew) {
  fverts_[f] = {a, b, c};
  record(journalF_, f);
  const std::array<Vertex, 3> v{a, b, c};
  for (std::size_t i = 0; i < 3; ++i) {
    Vertex x = v[i], y = v[(i + 1) % 3];
    Edge e = known[i].isValid() || missingAreNew ? known[i] : findEdge(x, y);
    if (!e.isValid()) e = newEdge(x, y);
    auto& ef = efaces_[e];
    if (!ef[0].isValid())
      ef[0] = f;
    else
      ef[1] = f;
    fedges_[f][i] = e;
    record(journalE_, e);
  }
}

void SurfaceMesh::deleteEmptyEdge(Edge e) {
  if (edeleted_[e] || efaces_[e][0].isValid()) return;
  removeEdgeFromVertex(everts_[e][0], e);
  removeEdgeFromVertex(everts_[e][1], e);
  edeleted_[e] = 1;
  ++deletedEdges_;
  record(journalE_, e);
}

// ---- edits ----------------------------------------------------------------------

Face SurfaceMesh::addFace(Vertex a, Vertex b, Vertex c) {
  check(a, "addFace");
  check(b, "addFace");
  check(c, "addFace");
  if (a == b || b == c || c == a) return Face();
  return addFaceOnSides(a, b, c, {findEdge(a, b), findEdge(b, c), findEdge(c, a)});
}

Face SurfaceMesh::addFace(Vertex a, Vertex b, Vertex c, const std::array<Edge, 3>& sides) {
  check(a, "addFace");
  check(b, "addFace");
  check(c, "addFace");
  if (a == b || b == c || c == a) return Face();
  return addFaceOnSides(a, b, c, sides);
}

Face SurfaceMesh::addFaceOnSides(Vertex a, Vertex b, Vertex c, const std::array<Edge, 3>& found) {
  const std::array<Vertex, 3> v{a, b, c};
  for (std::size_t i = 0; i < 3; ++i) {
    Vertex x = v[i], y = v[(i + 1) % 3];
    const Edge e = found[i];
    if (!e.isValid()) continue;
    const auto& ef = efaces_[e];
    if (ef[1].isValid()) return Face();  // would be a third face
    // The existing face must run the edge y -> x.
    const auto& ov = fverts_[ef[0]];
    for (std::size_t k = 0; k < 3; ++k)
      if (ov[k] == x && ov[(k + 1) % 3] == y) return Face();
  }
  Face f = newFace();
  // The pairs are distinct: new edges do not change `found`, and one not found is new.
  attachFace(f, a, b, c, found, true);
  ++topologyVersion_;
  return f;
}

void SurfaceMesh::deleteFace(Face f) {
  check(f, "deleteFace");
  detachFace(f);
  for (Edge e : fedges_[f]) deleteEmptyEdge(e);
  fdeleted_[f] = 1;
  ++deletedFaces_;
  record(journalF_, f);
  ++topologyVersion_;
}

void SurfaceMesh::deleteVertex(Vertex v) {
  check(v, "deleteVertex");
  auto& around = scratch_.around;
  faces(v, around);
  for (Face f : around) deleteFace(f);
  vdeleted_[v] = 1;
  ++deletedVertices_;
  record(journalV_, v);
  ++topologyVersion_;
}

Vertex SurfaceMesh::splitEdge(Edge e, const Point& p) {
  check(e, "splitEdge");
  const Vertex a = everts_[e][0], b = everts_[e][1];
  std::array<Face, 2> fs = efaces_[e];
  if (fs[0].isValid() && fs[1].isValid() && oppositeVertex(fs[0], e) == oppositeVertex(fs[1], e)) return Vertex();
  const Vertex m = addVertex(p);
  std::array<std::array<Vertex, 3>, 2> tri{};
  for (std::size_t k = 0; k < 2; ++k) {
    if (!fs[k].isValid()) continue;
    // Rotate so the split edge is (x, y) and c is opposite.
    auto fv = fverts_[fs[k]];
    while (!((fv[0] == a && fv[1] == b) || (fv[0] == b && fv[1] == a)))
      std::rotate(fv.begin(), fv.begin() + 1, fv.end());
    tri[k] = fv;
    detachFace(fs[k]);
  }
  // e becomes (a, m); a new edge (m, b) inherits its properties.
  removeEdgeFromVertex(b, e);
  everts_[e] = {a, m};
  addEdgeToVertex(m, e);
  record(journalE_, e);
  const Edge e2 = newEdgeCopy(e, m, b);
  for (std::size_t k = 0; k < 2; ++k) {
    if (!fs[k].isValid()) continue;
    const auto [x, y, c] = tri[k];
    const std::array<Edge, 3> oldEdges = fedges_[fs[k]];
    // The edges that stay are known (the face's old sides, e and e2, and the new edge
    // (m, c) once made): no search through the valence lists of x, y and c.
    auto oldSide = [&](Vertex p0, Vertex p1) {
      for (Edge oe : oldEdges) {
        const auto& ev = everts_[oe];
        if (((ev[0] == p0 && ev[1] == p1) || (ev[0] == p1 && ev[1] == p0)) && !edeleted_[oe]) return oe;
      }
      return Edge();
    };
    const Edge cx = oldSide(c, x), yc = oldSide(y, c);
    const Face g = newFaceCopy(fs[k]);
    attachFace(fs[k], x, m, c, {x == a ? e : e2, Edge(), cx});
    attachFace(g, m, y, c, {y == b ? e2 : e, yc, fedges_[fs[k]][1]});
    for (Edge oe : oldEdges) deleteEmptyEdge(oe);
  }
  ++topologyVersion_;
  return m;
}

Vertex SurfaceMesh::splitFace(Face f, const Point& p) {
  check(f, "splitFace");
  const auto [a, b, c] = fverts_[f];
  const Vertex m = addVertex(p);
  const std::array<Edge, 3> old = fedges_[f];  // (a,b), (b,c), (c,a)
  detachFace(f);
  const Face g1 = newFaceCopy(f);
  const Face g2 = newFaceCopy(f);
  // The sides are f's old edges and the spokes are made in order: nothing to search
  // except the spokes' first lookups in m's short list.
  attachFace(f, a, b, m, {old[0], Edge(), Edge()});
  attachFace(g1, b, c, m, {old[1], Edge(), fedges_[f][1]});
  attachFace(g2, c, a, m, {old[2], fedges_[f][2], fedges_[g1][1]});
  ++topologyVersion_;
  return m;
}

Vertex SurfaceMesh::collapseEdge(Edge e, Vertex keep) {
  check(e, "collapseEdge");
  const Vertex x = otherVertex(e, keep);
  const std::array<Face, 2> fs = efaces_[e];
  if (!x.isValid() || !fs[0].isValid() || !fs[1].isValid()) return Vertex();
  const std::array<Vertex, 2> opp{oppositeVertex(fs[0], e), oppositeVertex(fs[1], e)};
  if (opp[0] == opp[1] || valence(opp[0]) <= 3 || valence(opp[1]) <= 3) return Vertex();
  for (Edge g : vedges_[x]) {
    if (!efaces_[g][1].isValid()) return Vertex();
    const Vertex z = otherVertex(g, x);
    if (z != keep && z != opp[0] && z != opp[1] && findEdge(keep, z).isValid()) return Vertex();
  }
  std::vector<Face> around;
  faces(x, around);
  // x's edges to vertices keep has no edge to move to keep (their copies), before any
  // face is detached.
  std::vector<std::pair<Vertex, Edge>> moved;
  for (Edge g : vedges_[x])
    if (const Vertex z = otherVertex(g, x); z != keep && z != opp[0] && z != opp[1]) moved.emplace_back(z, g);
  for (Face f : around) detachFace(f);
  for (Face f : fs) {
    fdeleted_[f] = 1;
    ++deletedFaces_;
  }
  std::vector<std::pair<Vertex, Edge>> copies;
  auto toKeep = [&](Vertex z) {
    for (const auto& [w, c] : copies)
      if (w == z) return c;
    for (const auto& [w, g] : moved)
      if (w == z) {
        copies.emplace_back(z, newEdgeCopy(g, keep, z));
        return copies.back().second;
      }
    return findEdge(keep, z);
  };
  for (Face f : around) {
    if (f == fs[0] || f == fs[1]) continue;
    std::array<Vertex, 3> fv = fverts_[f];
    std::array<Edge, 3> known{};
    for (Vertex& c : fv)
      if (c == x) c = keep;
    for (std::size_t i = 0; i < 3; ++i) {
      const Vertex a = fv[i], b = fv[(i + 1) % 3];
      if (a == keep || b == keep) known[i] = toKeep(a == keep ? b : a);
    }
    attachFace(f, fv[0], fv[1], fv[2], known);
  }
  for (Edge g : EdgeList(vedges_[x])) deleteEmptyEdge(g);
  for (Face f : fs)
    for (Edge g : fedges_[f]) deleteEmptyEdge(g);
  vdeleted_[x] = 1;
  ++deletedVertices_;
  record(journalV_, x);
  ++topologyVersion_;
  return keep;
}

std::vector<Face> SurfaceMesh::faces(Vertex v) const {
  std::vector<Face> out;
  faces(v, out);
  return out;
}

// Valences are small: a linear search in a short, hot array beats a set. A cut's
// groove-bottom vertex carries dozens of faces, though (the search was most of the
// physics hooks' cost there): past 16 edges a small open-addressing table on the stack
// (no shared scratch: a const mesh may be read by several threads). Same faces, same
// order (first seen along the edge list).
void SurfaceMesh::faces(Vertex v, std::vector<Face>& out) const {
  out.clear();
  const EdgeList& es = vedges_[v];
  constexpr std::size_t kSlots = 512;  // at most 2 faces an edge, the table half full
  if (es.size() <= 16) {
    // Into a stack buffer, then one copy (no push_back per face).
    std::array<Face, 32> buf;
    Face* end = buf.data();
    for (Edge e : es)
      for (Face f : efaces_[e])
        if (f.isValid() && std::find(buf.data(), end, f) == end) *end++ = f;
    out.assign(buf.data(), end);
    return;
  }
  if (4 * es.size() > kSlots) {
    for (Edge e : es)
      for (Face f : efaces_[e])
        if (f.isValid() && std::find(out.begin(), out.end(), f) == out.end()) out.push_back(f);
    return;
  }
  std::array<std::uint32_t, kSlots> table;
  table.fill(std::numeric_limits<std::uint32_t>::max());
  for (Edge e : es)
    for (Face f : efaces_[e]) {
      if (!f.isValid()) continue;
      const std::uint32_t id = f.idx();
      std::size_t slot = (id * 0x9E3779B1u) >> 23;  // 9 bits: kSlots
      while (table[slot] != id && table[slot] != std::numeric_limits<std::uint32_t>::max()) slot = (slot + 1) % kSlots;
      if (table[slot] == id) continue;
      table[slot] = id;
      out.push_back(f);
    }
}

// In one pass over v's edges (no face list, no search, nothing deleted): an edge whose
// faces are all in the fan moves to the new vertex (same handle and properties, one end
// re-set); an edge with a fan face on one side and another face on the other keeps the
// other face and gets a copy at the new vertex for the fan face. Numbering (the edit
// fingerprint test freezes it): the new vertex is the next vertex index; the copies are
// the next edge indices in the order of v's edge list; v keeps its other edges in their
// order, and the new vertex lists the moved edges and the copies in that order too; the
// far ends list a copy after their other edges.
Vertex SurfaceMesh::splitVertex(Vertex v, std::span<const Face> fan) {
  check(v, "splitVertex");
  if (fan.empty()) return Vertex();
  // The fan's faces are marked (a fan can hold most of the ~50 faces of a groove's
  // bottom vertex: no search of the fan per edge of v).
  auto& mark = scratch_.fanMark;
  if (mark.size() < facesSize()) mark.resize(std::max(facesSize(), 2 * mark.size()), 0);
  if (++scratch_.fanStamp == 0) {  // wrapped
    std::fill(mark.begin(), mark.end(), 0u);
    scratch_.fanStamp = 1;
  }
  const std::uint32_t stamp = scratch_.fanStamp;
  for (Face f : fan) {
    if (!isValid(f) || localIndex(f, v) < 0 || mark[f.idx()] == stamp) return Vertex();
    mark[f.idx()] = stamp;
  }
  // Each face around v has two sides at v.
  std::size_t sides = 0;
  for (Edge e : vedges_[v]) sides += (efaces_[e][0].isValid() ? 1u : 0u) + (efaces_[e][1].isValid() ? 1u : 0u);
  if (2 * fan.size() >= sides) return Vertex();
  auto inFan = [&](Face f) { return f.isValid() && mark[f.idx()] == stamp; };

  // The copy's edge list is built below (copying v's would be an allocation and a
  // copy wasted).
  const Point at = points_[v];
  const std::uint8_t deleted = vdeleted_[v];
  vprops_.pushBackCopyTyped(kBuiltins, v.idx(), [&] {
    points_.vector().push_back(at);
    vedges_.vector().emplace_back();
    vdeleted_.vector().push_back(deleted);
  });
  const Vertex nv(verticesSize() - 1);
  record(journalV_, v);
  record(journalV_, nv);

  // (fan face, edge it leaves, the copy it takes instead)
  auto& swaps = scratch_.swaps;
  swaps.clear();
  EdgeList& list = vedges_[v];
  std::size_t keep = 0;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const Edge e = list[i];
    const Face f0 = efaces_[e][0], f1 = efaces_[e][1];
    const bool in0 = inFan(f0), in1 = inFan(f1);
    auto ends = everts_[e];
    for (auto& x : ends)
      if (x == v) x = nv;
    if (in0 && (in1 || !f1.isValid())) {
      everts_[e] = ends;
      addEdgeToVertex(nv, e);
      record(journalE_, e);
      continue;
    }
    list[keep++] = e;
    if (!in0 && !in1) continue;
    const Face moved = in0 ? f0 : f1;
    efaces_[e] = {in0 ? f1 : f0, Face()};
    record(journalE_, e);
    const Edge c = newEdgeCopy(e, ends[0], ends[1]);  // journals c
    efaces_[c] = {moved, Face()};
    swaps.push_back({moved, e, c});
  }
  list.resize(keep);
  for (Face f : fan) {
    for (auto& x : fverts_[f])
      if (x == v) x = nv;
    record(journalF_, f);
  }
  for (const auto& s : swaps)
    for (auto& fe : fedges_[s.face])
      if (fe == s.from) fe = s.to;
  ++topologyVersion_;
  return nv;
}

void SurfaceMesh::fanGroups(Vertex v, const std::vector<Face>& around, Edge ignore, std::vector<int>& group) const {
  group.resize(around.size());
  std::iota(group.begin(), group.end(), 0);
  auto find = [&](int i) {
    while (group[static_cast<std::size_t>(i)] != i) i = group[static_cast<std::size_t>(i)];
    return i;
  };
  auto indexOf = [&](Face f) { return static_cast<int>(std::find(around.begin(), around.end(), f) - around.begin()); };
  for (Edge ve : vedges_[v]) {
    if (ve == ignore || !efaces_[ve][1].isValid()) continue;
    group[static_cast<std::size_t>(find(indexOf(efaces_[ve][0])))] = find(indexOf(efaces_[ve][1]));
  }
  for (std::size_t i = 0; i < group.size(); ++i) group[i] = find(static_cast<int>(i));
}

// Moves the faces of f1's group around v onto a new vertex if they are not connected
// to f0 around v (ignoring `ignore`).
Vertex SurfaceMesh::splitOff(Vertex v, Face f0, Face f1, Edge ignore) {
  auto& around = scratch_.sepAround;
  auto& group = scratch_.sepGroup;
  auto& fan = scratch_.sepFan;
  faces(v, around);
  fanGroups(v, around, ignore, group);
  auto groupOf = [&](Face f) {
    return group[static_cast<std::size_t>(std::find(around.begin(), around.end(), f) - around.begin())];
  };
  if (groupOf(f0) == groupOf(f1)) return Vertex();
  fan.clear();
  for (std::size_t i = 0; i < around.size(); ++i)
    if (group[i] == groupOf(f1)) fan.push_back(around[i]);
  return splitVertex(v, fan);
}

Edge SurfaceMesh::separateEdge(Edge e) {
  check(e, "separateEdge");
  if (isBoundary(e)) return Edge();
  const Face f0 = efaces_[e][0], f1 = efaces_[e][1];
  for (int end = 0; end < 2; ++end) {
    const Vertex v = everts_[e][static_cast<std::size_t>(end)];
    const Vertex w = everts_[e][static_cast<std::size_t>(1 - end)];
    const Vertex nv = splitOff(v, f0, f1, e);
    if (!nv.isValid()) continue;
    // The far end may now join the two sides at a single vertex: split it as well,
    // so that no vertex is shared by faces that no edge connects.
    const Vertex nw = splitOff(w, f0, f1, Edge());
    return findEdge(nv, nw.isValid() ? nw : w);
  }
  return Edge();
}

Compaction SurfaceMesh::garbageCollection() {
  Compaction c;
  c.vertexMap.assign(verticesSize(), Vertex());
  c.edgeMap.assign(edgesSize(), Edge());
  c.faceMap.assign(facesSize(), Face());
  std::vector<std::size_t> keepV, keepE, keepF;
  for (std::size_t i = 0; i < verticesSize(); ++i)
    if (!vdeleted_[Vertex(i)]) {
      c.vertexMap[i] = Vertex(keepV.size());
      keepV.push_back(i);
    }
  for (std::size_t i = 0; i < edgesSize(); ++i)
    if (!edeleted_[Edge(i)]) {
      c.edgeMap[i] = Edge(keepE.size());
      keepE.push_back(i);
    }
  for (std::size_t i = 0; i < facesSize(); ++i)
    if (!fdeleted_[Face(i)]) {
      c.faceMap[i] = Face(keepF.size());
      keepF.push_back(i);
    }
  vprops_.compact(keepV);
  eprops_.compact(keepE);
  fprops_.compact(keepF);
  bindProperties();
  for (auto& list : vedges_.vector())
    for (auto& e : list) e = c.edgeMap[e.idx()];
  for (auto& ev : everts_.vector())
    for (auto& v : ev) v = c.vertexMap[v.idx()];
  for (auto& ef : efaces_.vector())
    for (auto& f : ef)
      if (f.isValid()) f = c.faceMap[f.idx()];
  for (auto& fv : fverts_.vector())
    for (auto& v : fv) v = c.vertexMap[v.idx()];
  for (auto& fe : fedges_.vector())
    for (auto& e : fe) e = c.edgeMap[e.idx()];
  deletedVertices_ = deletedEdges_ = deletedFaces_ = 0;
  ++topologyVersion_;
  newLayout();
  return c;
}

// ---- queries ---------------------------------------------------------------------

bool SurfaceMesh::isClosed() const {
  if (nFaces() == 0) return false;
  for (Edge e : edges())
    if (isBoundary(e)) return false;
  return true;
}

// ---- geometry --------------------------------------------------------------------

Normal SurfaceMesh::faceNormal(Face f) const {
  const auto& v = fverts_[f];
  const Normal n = (points_[v[1]] - points_[v[0]]).cross(points_[v[2]] - points_[v[0]]);
  const double len = n.norm();
  return len > 0.0 ? Normal(n / len) : Normal::Zero();
}

double SurfaceMesh::faceArea(Face f) const {
  const auto& v = fverts_[f];
  return 0.5 * (points_[v[1]] - points_[v[0]]).cross(points_[v[2]] - points_[v[0]]).norm();
}

Point SurfaceMesh::centroid(Face f) const {
  const auto& v = fverts_[f];
  return (points_[v[0]] + points_[v[1]] + points_[v[2]]) / 3.0;
}

double SurfaceMesh::edgeLength(Edge e) const { return (points_[everts_[e][0]] - points_[everts_[e][1]]).norm(); }

std::vector<Normal> SurfaceMesh::vertexNormals() const {
  std::vector<Normal> n(verticesSize(), Normal::Zero());
  for (Face f : faces()) {
    const auto& v = fverts_[f];
    // The unnormalised cross product is twice the area times the unit normal.
    const Normal w = (points_[v[1]] - points_[v[0]]).cross(points_[v[2]] - points_[v[0]]);
    for (Vertex x : v) n[x.idx()] += w;
  }
  for (auto& x : n) {
    const double len = x.norm();
    if (len > 0.0) x /= len;
  }
  return n;
}

double SurfaceMesh::area() const {
  double a = 0.0;
  for (Face f : faces()) a += faceArea(f);
  return a;
}

BoundingBox SurfaceMesh::bounds() const {
  BoundingBox b;
  bool first = true;
  for (Vertex v : vertices()) {
    const Point& p = points_[v];
    if (first) {
      b.min = b.max = p;
      first = false;
    } else {
      b.min = b.min.cwiseMin(p);
      b.max = b.max.cwiseMax(p);
    }
  }
  return b;
}

// ---- global structure ----------------------------------------------------------

Components SurfaceMesh::connectedComponents() const {
  Components c;
  c.faceLabel.assign(facesSize(), -1);
  c.vertexLabel.assign(verticesSize(), -1);
  std::vector<Face> stack;
  for (Face seed : faces()) {
    if (c.faceLabel[seed.idx()] >= 0) continue;
    const int label = c.count++;
    c.faceLabel[seed.idx()] = label;
    stack.push_back(seed);
    while (!stack.empty()) {
      const Face f = stack.back();
      stack.pop_back();
      for (Vertex v : fverts_[f]) c.vertexLabel[v.idx()] = label;
      for (Edge e : fedges_[f]) {
        const Face g = otherFace(e, f);
        if (g.isValid() && c.faceLabel[g.idx()] < 0) {
          c.faceLabel[g.idx()] = label;
          stack.push_back(g);
        }
      }
    }
  }
  return c;
}

namespace {

// Old index -> new index for the elements of a part (open addressing, linear
// probing): cost in proportion to the part, not to the mesh.
class IndexMap {
 public:
  static constexpr std::uint32_t kNone = 0xffffffffu;
  explicit IndexMap(std::size_t n) {
    std::size_t c = 16;
    while (c < 2 * n + 2) c <<= 1;
    keys_.assign(c, kNone);
    vals_.assign(c, kNone);
  }
  // Inserts `k` (value kNone) when new; returns whether it was.
  bool insert(std::uint32_t k) {
    std::size_t i = slot(k);
    if (keys_[i] == k) return false;
    keys_[i] = k;
    return true;
  }
  void set(std::uint32_t k, std::uint32_t v) { vals_[slot(k)] = v; }
  [[nodiscard]] std::uint32_t find(std::uint32_t k) const {
    const std::size_t i = slot(k);
    return keys_[i] == k ? vals_[i] : kNone;
  }

 private:
  [[nodiscard]] std::size_t slot(std::uint32_t k) const {
    const std::size_t mask = keys_.size() - 1;
    std::size_t i = (static_cast<std::size_t>(k) * 0x9E3779B1u) & mask;
    while (keys_[i] != k && keys_[i] != kNone) i = (i + 1) & mask;
    return i;
  }
  std::vector<std::uint32_t> keys_, vals_;
};

// Sorted unique list of the map's keys (given in `list`, unique), ranks stored as values.
void rank(std::vector<std::size_t>& list, IndexMap& map) {
  std::sort(list.begin(), list.end());
  for (std::size_t j = 0; j < list.size(); ++j)
    map.set(static_cast<std::uint32_t>(list[j]), static_cast<std::uint32_t>(j));
}

}  // namespace

SplitComponents SurfaceMesh::splitComponents() const {
  const Components c = connectedComponents();
  std::vector<std::vector<Face>> all(static_cast<std::size_t>(c.count));
  for (Face f : faces()) all[static_cast<std::size_t>(c.faceLabel[f.idx()])].push_back(f);
  std::size_t keep = 0;
  for (std::size_t l = 1; l < all.size(); ++l)
    if (all[l].size() > all[keep].size()) keep = l;
  SplitComponents out;
  out.count = c.count;
  out.largestFaces = all.empty() ? 0 : all[keep].size();
  for (std::size_t l = 0; l < all.size(); ++l)
    if (l != keep) out.pieces.push_back(std::move(all[l]));
  out.facesVisited = nFaces();
  return out;
}

SplitComponents SurfaceMesh::splitComponents(std::span<const Face> seeds, ComponentScratch& s) const {
  using Search = ComponentScratch::Search;
  const std::size_t nf = facesSize();
  if (s.seen.size() < nf) {
    s.seen.resize(nf, 0);
    s.owner.resize(nf, 0);
  }
  if (++s.generation == 0) {
    std::fill(s.seen.begin(), s.seen.end(), 0);
    s.generation = 1;
  }
  const std::uint32_t gen = s.generation;
  std::uint32_t used = 0;
  auto root = [&](std::uint32_t i) {
    while (s.searches[i].parent != i) i = s.searches[i].parent = s.searches[s.searches[i].parent].parent;
    return i;
  };
  auto reach = [&](std::uint32_t id, Face g) {
    s.seen[g.idx()] = gen;
    s.owner[g.idx()] = id;
    Search& x = s.searches[id];
    x.stack.push_back(g);
    x.faces.push_back(g);
    x.minFace = std::min(x.minFace, g.idx());
  };
  // The larger search takes the smaller one's faces and frontier.
  auto merge = [&](std::uint32_t a, std::uint32_t b) {
    if (s.searches[a].faces.size() < s.searches[b].faces.size()) std::swap(a, b);
    Search& big = s.searches[a];
    Search& small = s.searches[b];
    big.faces.insert(big.faces.end(), small.faces.begin(), small.faces.end());
    big.stack.insert(big.stack.end(), small.stack.begin(), small.stack.end());
    big.minFace = std::min(big.minFace, small.minFace);
    small.parent = a;
    small.faces.clear();
    small.stack.clear();
    return a;
  };
  std::size_t visited = 0;
  // One face of search `id` (a root that is not done); a finished component's faces
  // are never reached by another search (their neighbours are all its own).
  auto advance = [&](std::uint32_t id) {
    if (s.searches[id].stack.empty()) {
      s.searches[id].done = true;
      return;
    }
    const Face f = s.searches[id].stack.back();
    s.searches[id].stack.pop_back();
    ++visited;
    std::uint32_t cur = id;
    for (Edge e : fedges_[f]) {
      const Face g = otherFace(e, f);
      if (!g.isValid()) continue;
      if (s.seen[g.idx()] != gen) {
        reach(cur, g);
        continue;
      }
      const std::uint32_t o = root(s.owner[g.idx()]);
      if (o != cur) cur = merge(cur, o);
    }
  };

  s.active.clear();
  for (Face f : seeds) {
    if (!isValid(f) || s.seen[f.idx()] == gen) continue;
    if (used == s.searches.size()) s.searches.emplace_back();
    Search& x = s.searches[used];
    x.stack.clear();
    x.faces.clear();
    x.parent = used;
    x.minFace = f.idx();
    x.done = false;
    reach(used, f);
    s.active.push_back(used++);
  }
  auto isOpen = [&](std::uint32_t id) { return s.searches[id].parent == id && !s.searches[id].done; };
  for (;;) {
    std::erase_if(s.active, [&](std::uint32_t id) { return !isOpen(id); });
    if (s.active.size() <= 1) break;
    for (std::size_t k = 0; k < s.active.size(); ++k)
      if (isOpen(s.active[k])) advance(s.active[k]);
  }

  SplitComponents out;
  std::size_t doneFaces = 0, maxDone = 0;
  for (std::uint32_t i = 0; i < used; ++i)
    if (s.searches[i].parent == i && s.searches[i].done) {
      doneFaces += s.searches[i].faces.size();
      maxDone = std::max(maxDone, s.searches[i].faces.size());
    }
  const bool hasOpen = !s.active.empty();
  const std::uint32_t open = hasOpen ? s.active.front() : 0;
  const std::size_t rest = nFaces() - std::min(nFaces(), doneFaces);
  if (hasOpen && rest <= maxDone) {
    // It may not be the largest (or ties with one): finish it, bounded by maxDone.
    while (!s.searches[open].done) advance(open);
  }
  const bool openLargest = hasOpen && !s.searches[open].done;
  if (!hasOpen && doneFaces != nFaces()) {
    // Some component had no seed (precondition broken): the full labelling.
    out = splitComponents();
    out.facesVisited += visited;
    return out;
  }
  // Finished components; the largest stays unlisted.
  std::vector<std::uint32_t> comps;
  for (std::uint32_t i = 0; i < used; ++i)
    if (s.searches[i].parent == i && s.searches[i].done) comps.push_back(i);
  std::sort(comps.begin(), comps.end(),
            [&](std::uint32_t a, std::uint32_t b) { return s.searches[a].minFace < s.searches[b].minFace; });
  out.count = static_cast<int>(comps.size()) + (openLargest ? 1 : 0);
  std::size_t keep = comps.size();
  if (openLargest) {
    out.largestFaces = rest;
  } else {
    for (std::size_t k = 0; k < comps.size(); ++k)
      if (keep == comps.size() || s.searches[comps[k]].faces.size() > s.searches[comps[keep]].faces.size()) keep = k;
    if (keep < comps.size()) out.largestFaces = s.searches[comps[keep]].faces.size();
  }
  for (std::size_t k = 0; k < comps.size(); ++k) {
    if (k == keep) continue;
    std::vector<Face>& piece = out.pieces.emplace_back(s.searches[comps[k]].faces);
    std::sort(piece.begin(), piece.end());
  }
  out.facesVisited = visited;
  return out;
}

SurfaceMesh SurfaceMesh::extract(std::span<const Face> faces) const {
  std::vector<std::size_t> vi, ei, fi;
  IndexMap vmap(3 * faces.size()), emap(3 * faces.size()), fmap(faces.size());
  fi.reserve(faces.size());
  ei.reserve(2 * faces.size());
  vi.reserve(faces.size());
  for (Face f : faces) {
    check(f, "extract");
    if (!fmap.insert(f.idx())) continue;
    fi.push_back(f.idx());
    for (Edge e : fedges_[f])
      if (emap.insert(e.idx())) ei.push_back(e.idx());
    for (Vertex v : fverts_[f])
      if (vmap.insert(v.idx())) vi.push_back(v.idx());
  }
  rank(fi, fmap);
  rank(ei, emap);
  rank(vi, vmap);
  SurfaceMesh out;
  out.vprops_ = vprops_.gather(vi);
  out.eprops_ = eprops_.gather(ei);
  out.fprops_ = fprops_.gather(fi);
  out.bindProperties();
  for (auto& list : out.vedges_.vector()) {
    list.eraseIf([&](Edge e) { return emap.find(e.idx()) == IndexMap::kNone; });
    for (Edge& e : list) e = Edge(emap.find(e.idx()));
  }
  for (auto& ev : out.everts_.vector())
    for (Vertex& v : ev) v = Vertex(vmap.find(v.idx()));
  for (auto& ef : out.efaces_.vector()) {
    for (Face& f : ef)
      if (f.isValid()) f = Face(fmap.find(f.idx()));  // kNone: a face not listed
    if (!ef[0].isValid()) std::swap(ef[0], ef[1]);
  }
  for (auto& fv : out.fverts_.vector())
    for (Vertex& v : fv) v = Vertex(vmap.find(v.idx()));
  for (auto& fe : out.fedges_.vector())
    for (Edge& e : fe) e = Edge(emap.find(e.idx()));
  out.topologyVersion_ = topologyVersion_ + 1;
  return out;
}

std::vector<std::vector<Vertex>> SurfaceMesh::boundaryLoops() const {
  // A boundary edge runs x -> y in its face; the loop walks it y -> x.
  std::vector<std::vector<Vertex>> loops;
  std::vector<bool> used(edgesSize(), false);
  auto walkFrom = [&](Edge e, Vertex& from, Vertex& to) {
    const Face f = efaces_[e][0];
    if (runsForward(f, e)) {
      from = everts_[e][1];
      to = everts_[e][0];
    } else {
      from = everts_[e][0];
      to = everts_[e][1];
    }
  };
  for (Edge start : edges()) {
    if (!isBoundary(start) || used[start.idx()]) continue;
    std::vector<Vertex> loop;
    Edge e = start;
    while (e.isValid() && !used[e.idx()]) {
      used[e.idx()] = true;
      Vertex from, to;
      walkFrom(e, from, to);
      loop.push_back(from);
      Edge next;
      for (Edge c : vedges_[to]) {
        if (used[c.idx()] || !isBoundary(c)) continue;
        Vertex cf, ct;
        walkFrom(c, cf, ct);
        if (cf == to) {
          next = c;
          break;
        }
      }
      e = next;
    }
    loops.push_back(std::move(loop));
  }
  return loops;
}

ValidationReport SurfaceMesh::validate() const {
  ValidationReport r;
  auto problem = [&](auto&&... parts) {
    std::ostringstream s;
    (s << ... << parts);
    r.problems.push_back(s.str());
  };
  std::size_t nv = 0, ne = 0, nf = 0;
  for (std::size_t i = 0; i < verticesSize(); ++i) nv += vdeleted_[Vertex(i)] ? 0 : 1;
  for (std::size_t i = 0; i < edgesSize(); ++i) ne += edeleted_[Edge(i)] ? 0 : 1;
  for (std::size_t i = 0; i < facesSize(); ++i) nf += fdeleted_[Face(i)] ? 0 : 1;
  if (nv != nVertices() || ne != nEdges() || nf != nFaces()) problem("deleted-element counters disagree with flags");

  for (Face f : faces()) {
    const auto& v = fverts_[f];
    const auto& e = fedges_[f];
    for (std::size_t i = 0; i < 3; ++i) {
      if (!isValid(v[i])) problem(f, " has dead or invalid vertex ", v[i]);
      if (!isValid(e[i])) {
        problem(f, " has dead or invalid edge ", e[i]);
        continue;
      }
      const auto& ev = everts_[e[i]];
      const Vertex x = v[i], y = v[(i + 1) % 3];
      if (!((ev[0] == x && ev[1] == y) || (ev[0] == y && ev[1] == x)))
        problem(f, " edge ", i, " (", e[i], ") does not join ", x, " and ", y);
      if (efaces_[e[i]][0] != f && efaces_[e[i]][1] != f) problem(e[i], " does not list its face ", f);
    }
    if (v[0] == v[1] || v[1] == v[2] || v[2] == v[0]) {
      problem(f, " repeats a vertex");
    } else if (isValid(v[0]) && isValid(v[1]) && isValid(v[2])) {
      const double a = faceArea(f);
      if (!(a > 0.0) || !std::isfinite(a)) problem(f, " is degenerate (area ", a, ")");
    }
  }
  for (Edge e : edges()) {
    const auto& ev = everts_[e];
    const auto& ef = efaces_[e];
    if (!isValid(ev[0]) || !isValid(ev[1]) || ev[0] == ev[1]) {
      problem(e, " has invalid end vertices");
      continue;
    }
    if (!ef[0].isValid()) problem(e, " has no face (dangling edge)");
    for (Face f : ef) {
      if (!f.isValid()) continue;
      if (!isValid(f))
        problem(e, " lists dead face ", f);
      else if (localIndex(f, e) < 0)
        problem(e, " lists ", f, " which does not use it");
    }
    if (ef[0].isValid() && ef[1].isValid() && isValid(ef[0]) && isValid(ef[1])) {
      if (ef[0] == ef[1])
        problem(e, " lists the same face twice");
      else if (runsForward(ef[0], e) == runsForward(ef[1], e))
        problem(e, " is used by ", ef[0], " and ", ef[1], " in the same direction (inconsistent orientation)");
    }
    for (Vertex x : ev)
      if (std::count(vedges_[x].begin(), vedges_[x].end(), e) != 1) problem(x, " does not list its edge ", e, " once");
  }
  for (Vertex v : vertices()) {
    std::unordered_set<std::uint32_t> others;
    for (Edge e : vedges_[v]) {
      if (!isValid(e)) {
        problem(v, " lists dead edge ", e);
        continue;
      }
      const Vertex o = otherVertex(e, v);
      if (!o.isValid()) problem(v, " lists ", e, " which does not touch it");
      if (!others.insert(o.idx()).second) problem(v, " has two edges to ", o);
    }
    if (!points_[v].allFinite()) problem(v, " has a non-finite position");
  }
  return r;
}

}  // namespace ld::mesh
