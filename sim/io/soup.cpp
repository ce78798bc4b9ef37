// Processing of a triangle soup: welding, clean-up, orientation, statistics, and the
// conversion into a SurfaceMesh.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <string>
#include <unordered_map>

#include "sim/io/mesh_formats.h"

namespace ld::io {
namespace {

std::uint64_t edgeKey(std::uint32_t a, std::uint32_t b) {
  if (a > b) std::swap(a, b);
  return (static_cast<std::uint64_t>(a) << 32) | b;
}

struct HalfEdge {
  std::uint64_t key;
  std::uint32_t face;
  bool forward;  // runs from the smaller to the larger vertex index
};

// Every face's three edges, sorted so that the faces of one edge are adjacent.
std::vector<HalfEdge> sortedHalfEdges(const std::vector<Triangle>& tris) {
  std::vector<HalfEdge> h;
  h.reserve(tris.size() * 3);
  for (std::size_t f = 0; f < tris.size(); ++f)
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t a = tris[f][static_cast<std::size_t>(i)], b = tris[f][static_cast<std::size_t>((i + 1) % 3)];
      h.push_back({edgeKey(a, b), static_cast<std::uint32_t>(f), a < b});
    }
  std::sort(h.begin(), h.end(),
            [](const HalfEdge& x, const HalfEdge& y) { return x.key != y.key ? x.key < y.key : x.face < y.face; });
  return h;
}

class UnionFind {
 public:
  // Filled by push_back: GCC 12 -O3 warns (falsely) on the zero-fill of vector(n).
  explicit UnionFind(std::size_t n) {
    p_.reserve(n);
    for (std::size_t i = 0; i < n; ++i) p_.push_back(i);
  }
  std::size_t find(std::size_t x) {
    while (p_[x] != x) x = p_[x] = p_[p_[x]];
    return x;
  }
  void unite(std::size_t a, std::size_t b) { p_[find(a)] = find(b); }

 private:
  std::vector<std::size_t> p_;
};

double triArea(const TriangleSoup& s, const Triangle& t) {
  return 0.5 * (s.points[t[1]] - s.points[t[0]]).cross(s.points[t[2]] - s.points[t[0]]).norm();
}

// The mesh rejects faces of zero or non-finite area (huge coordinates overflow).
bool usableArea(double a) { return a > 0 && std::isfinite(a); }

void warn(ImportReport* r, const std::string& src, const std::string& msg) {
  if (r) r->warnings.push_back(src + ":0: " + msg);
}

}  // namespace

void cleanSoup(TriangleSoup& soup, bool weld, ImportReport* report) {
  const std::size_t n0 = soup.points.size();
  std::size_t welded = 0;
  if (weld) {
    struct Key {
      double x, y, z;
      bool operator==(const Key& o) const { return x == o.x && y == o.y && z == o.z; }
    };
    struct Hash {
      std::size_t operator()(const Key& k) const {
        std::uint64_t h = 1469598103934665603ull;
        for (double d : {k.x, k.y, k.z}) {
          std::uint64_t b;
          std::memcpy(&b, &d, 8);
          h = (h ^ b) * 1099511628211ull;
        }
        return static_cast<std::size_t>(h);
      }
    };
    // Referenced points only, so that unreferenced ones are counted as dropped.
    std::vector<bool> used(n0, false);
    for (const auto& t : soup.triangles)
      for (auto v : t) used[v] = true;
    std::unordered_map<Key, std::uint32_t, Hash> first;
    std::vector<std::uint32_t> map(n0);
    for (std::size_t i = 0; i < n0; ++i) {
      map[i] = static_cast<std::uint32_t>(i);
      if (!used[i]) continue;
      const auto& p = soup.points[i];
      const Key k{p.x() + 0.0, p.y() + 0.0, p.z() + 0.0};  // +0.0 folds -0 into 0
      auto [it, inserted] = first.try_emplace(k, static_cast<std::uint32_t>(i));
      if (!inserted) {
        map[i] = it->second;
        ++welded;
      }
    }
    for (auto& t : soup.triangles)
      for (auto& v : t) v = map[v];
  }
  // Faces that repeat a vertex (after welding) are not triangles.
  std::size_t repeated = 0;
  std::erase_if(soup.triangles, [&](const Triangle& t) {
    const bool bad = t[0] == t[1] || t[1] == t[2] || t[2] == t[0];
    repeated += bad ? 1 : 0;
    return bad;
  });
  // Drop unreferenced vertices, keeping the file's order of the others.
  std::vector<std::uint32_t> newIndex(n0, UINT32_MAX);
  for (const auto& t : soup.triangles)
    for (auto v : t) newIndex[v] = 0;
  std::vector<Eigen::Vector3d> pts;
  for (std::size_t i = 0; i < n0; ++i)
    if (newIndex[i] != UINT32_MAX) {
      newIndex[i] = static_cast<std::uint32_t>(pts.size());
      pts.push_back(soup.points[i]);
    }
  for (auto& t : soup.triangles)
    for (auto& v : t) v = newIndex[v];
  const std::size_t dropped = n0 - pts.size() - welded;
  soup.points.swap(pts);
  if (report) {
    report->weldedVertices += welded;
    report->droppedVertices += dropped;
    report->droppedPolygons += repeated;
    if (repeated) warn(report, soup.source, std::to_string(repeated) + " face(s) that repeat a vertex dropped");
    if (dropped) warn(report, soup.source, std::to_string(dropped) + " unreferenced vertex(es) dropped");
  }

  // Orientation: propagate across edges with exactly two faces.
  const auto& tris = soup.triangles;
  const std::size_t nf = tris.size();
  const auto h = sortedHalfEdges(tris);
  // At most one neighbour per edge; the flag says the two must end up flipped differently.
  struct Neighbours {
    std::array<std::uint32_t, 3> face{};
    std::array<bool, 3> differ{};
    std::uint8_t n = 0;
    void add(std::uint32_t f, bool d) {
      face[n] = f;
      differ[n] = d;
      ++n;
    }
  };
  std::vector<Neighbours> adj(nf);
  std::vector<bool> allManifold(nf, true);
  for (std::size_t i = 0; i < h.size();) {
    std::size_t j = i;
    while (j < h.size() && h[j].key == h[i].key) ++j;
    if (j - i == 2 && h[i].face != h[i + 1].face) {
      const bool same = h[i].forward == h[i + 1].forward;
      adj[h[i].face].add(h[i + 1].face, same);
      adj[h[i + 1].face].add(h[i].face, same);
    } else {
      for (std::size_t k = i; k < j; ++k) allManifold[h[k].face] = false;
    }
    i = j;
  }
  std::vector<int> flip(nf, -1);
  std::size_t conflicts = 0, flipped = 0;
  std::vector<std::uint32_t> comp, stack;
  for (std::size_t s = 0; s < nf; ++s) {
    if (flip[s] >= 0) continue;
    comp.clear();
    stack.assign(1, static_cast<std::uint32_t>(s));
    flip[s] = 0;
    bool closed = true, orientable = true;
    while (!stack.empty()) {
      const std::uint32_t f = stack.back();
      stack.pop_back();
      comp.push_back(f);
      closed = closed && allManifold[f];
      for (std::uint8_t k = 0; k < adj[f].n; ++k) {
        const std::uint32_t g = adj[f].face[k];
        const int want = flip[f] ^ (adj[f].differ[k] ? 1 : 0);
        if (flip[g] < 0) {
          flip[g] = want;
          stack.push_back(g);
        } else if (flip[g] != want) {
          orientable = false;
          ++conflicts;
        }
      }
    }
    // Keep the orientation most of the file's faces have...
    std::size_t nflip = 0;
    for (auto f : comp) nflip += static_cast<std::size_t>(flip[f]);
    bool invert = 2 * nflip > comp.size();
    // ...but make closed pieces face outward (positive enclosed volume).
    if (closed && orientable) {
      double vol = 0;
      for (auto f : comp) {
        const auto& t = tris[f];
        const double v = soup.points[t[0]].dot(soup.points[t[1]].cross(soup.points[t[2]])) * (flip[f] ? -1.0 : 1.0);
        vol += v;
      }
      if (vol < 0)
        invert = true;
      else if (vol > 0)
        invert = false;
    }
    for (auto f : comp) {
      if ((flip[f] != 0) != invert) {
        std::swap(soup.triangles[f][1], soup.triangles[f][2]);
        ++flipped;
      }
    }
  }
  if (report) {
    report->flippedFaces += flipped;
    if (conflicts)
      warn(report, soup.source,
           "the surface is not orientable (" + std::to_string(conflicts / 2) +
               " edge(s) keep inconsistent orientation)");
  }
}

MeshStats computeStats(const TriangleSoup& soup) {
  MeshStats st;
  const auto& tris = soup.triangles;
  st.triangles = tris.size();
  std::vector<bool> used(soup.points.size(), false);
  for (const auto& t : tris)
    for (auto v : t) used[v] = true;
  bool first = true;
  for (std::size_t i = 0; i < used.size(); ++i) {
    if (!used[i]) continue;
    ++st.vertices;
    const auto& p = soup.points[i];
    if (first) {
      st.bboxMin = st.bboxMax = p;
      first = false;
    } else {
      st.bboxMin = st.bboxMin.cwiseMin(p);
      st.bboxMax = st.bboxMax.cwiseMax(p);
    }
  }
  for (const auto& t : tris) {
    const double a = triArea(soup, t);
    st.area += a;
    if (!usableArea(a)) ++st.degenerateFaces;
  }
  const auto h = sortedHalfEdges(tris);
  UnionFind corners(3 * tris.size());
  const auto cornerOf = [&](std::uint32_t f, std::uint32_t v) {
    for (std::size_t i = 0; i < 3; ++i)
      if (tris[f][i] == v) return 3 * static_cast<std::size_t>(f) + i;
    return 3 * static_cast<std::size_t>(f);
  };
  for (std::size_t i = 0; i < h.size();) {
    std::size_t j = i;
    while (j < h.size() && h[j].key == h[i].key) ++j;
    ++st.edges;
    const std::size_t k = j - i;
    if (k == 1) ++st.boundaryEdges;
    if (k > 2) ++st.nonManifoldEdges;
    if (k == 2 && h[i].forward == h[i + 1].forward) st.consistentlyOriented = false;
    if (k == 2) {  // join the two faces' corners at both ends (fans around vertices)
      const auto a = static_cast<std::uint32_t>(h[i].key >> 32), b = static_cast<std::uint32_t>(h[i].key & 0xffffffffu);
      corners.unite(cornerOf(h[i].face, a), cornerOf(h[i + 1].face, a));
      corners.unite(cornerOf(h[i].face, b), cornerOf(h[i + 1].face, b));
    }
    i = j;
  }
  // A vertex is manifold when its corners form one fan.
  std::vector<std::size_t> fanRoot(soup.points.size(), SIZE_MAX);
  std::vector<bool> nonManifoldVertex(soup.points.size(), false);
  for (std::size_t f = 0; f < tris.size(); ++f)
    for (std::size_t i = 0; i < 3; ++i) {
      const auto v = tris[f][i];
      const std::size_t r = corners.find(3 * f + i);
      if (fanRoot[v] == SIZE_MAX)
        fanRoot[v] = r;
      else if (fanRoot[v] != r)
        nonManifoldVertex[v] = true;
    }
  st.nonManifoldVertices =
      static_cast<std::size_t>(std::count(nonManifoldVertex.begin(), nonManifoldVertex.end(), true));
  UnionFind verts(soup.points.size());
  for (const auto& t : tris) {
    verts.unite(t[0], t[1]);
    verts.unite(t[1], t[2]);
  }
  for (std::size_t i = 0; i < used.size(); ++i)
    if (used[i] && verts.find(i) == i) ++st.components;
  st.manifold = st.nonManifoldEdges == 0 && st.nonManifoldVertices == 0;
  st.closed = st.triangles > 0 && st.boundaryEdges == 0 && st.nonManifoldEdges == 0;
  st.euler = static_cast<long>(st.vertices) - static_cast<long>(st.edges) + static_cast<long>(st.triangles);
  return st;
}

mesh::SurfaceMesh buildMesh(const TriangleSoup& soup, ImportReport* report) {
  using mesh::Vertex;
  mesh::SurfaceMesh m;
  m.reserve(soup.points.size(), soup.triangles.size() * 3 / 2 + 3, soup.triangles.size());
  for (const auto& p : soup.points) m.addVertex(p);
  std::vector<Vertex> copy(soup.points.size());  // latest copy of a vertex, if any
  std::size_t degenerate = 0, duplicated = 0, facesWithCopies = 0;
  const auto blocked = [&](Vertex x, Vertex y) {
    const mesh::Edge e = m.findEdge(x, y);
    if (!e.isValid()) return false;
    if (m.face(e, 1).isValid()) return true;
    const auto& fv = m.vertices(m.face(e, 0));
    for (std::size_t k = 0; k < 3; ++k)
      if (fv[k] == x && fv[(k + 1) % 3] == y) return true;
    return false;
  };
  for (const auto& t : soup.triangles) {
    if (!usableArea(triArea(soup, t))) {
      ++degenerate;
      continue;
    }
    std::array<Vertex, 3> v{Vertex(t[0]), Vertex(t[1]), Vertex(t[2])};
    if (m.addFace(v[0], v[1], v[2]).isValid()) continue;
    // Non-manifold or inconsistently oriented edge: give the face its own copies of the
    // vertices on the blocked edges (first the latest copies, then fresh ones).
    std::array<bool, 3> mark{false, false, false};
    for (std::size_t i = 0; i < 3; ++i)
      if (blocked(v[i], v[(i + 1) % 3])) mark[i] = mark[(i + 1) % 3] = true;
    ++facesWithCopies;
    std::array<Vertex, 3> w = v;
    bool reuse = true;
    for (std::size_t i = 0; i < 3; ++i)
      if (mark[i]) {
        if (copy[t[i]].isValid())
          w[i] = copy[t[i]];
        else
          reuse = false;
      }
    if (reuse && m.addFace(w[0], w[1], w[2]).isValid()) continue;
    for (std::size_t i = 0; i < 3; ++i)
      if (mark[i]) {
        w[i] = m.addVertex(soup.points[t[i]]);
        copy[t[i]] = w[i];
        ++duplicated;
      } else {
        w[i] = v[i];
      }
    if (!m.addFace(w[0], w[1], w[2]).isValid()) {
      // Cannot happen (the new vertices have no edges yet); keep going regardless.
      if (report) ++report->skippedFaces;
    }
  }
  // Vertices only used by degenerate faces would be left isolated.
  bool removed = false;
  for (Vertex v : m.vertices())
    if (m.isIsolated(v)) {
      m.deleteVertex(v);
      removed = true;
    }
  if (removed) m.garbageCollection();
  if (report) {
    report->degenerateFaces += degenerate;
    report->duplicatedVertices += duplicated;
    if (degenerate) warn(report, soup.source, std::to_string(degenerate) + " zero-area face(s) left out of the mesh");
    if (facesWithCopies)
      warn(report, soup.source,
           std::to_string(facesWithCopies) + " face(s) on non-manifold edges got " + std::to_string(duplicated) +
               " copied vertex(es)");
  }
  return m;
}

}  // namespace ld::io
