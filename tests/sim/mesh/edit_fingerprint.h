#pragma once
// A fingerprint of a long, seeded sequence of mixed edits on grids with properties:
// the handles the edits return and create, the final connectivity, properties and
// journal. Edits must number new elements deterministically and in their documented
// order (caches, the cutter's replayable seeds and recorded sessions depend on it): a
// change here is a change of behaviour, to be made on purpose and documented (the
// one-pass splitVertex of 2026-12-02 was one), never as a side effect.
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "sim/mesh/surface_mesh.h"
#include "tests/sim/mesh/grid_mesh.h"

namespace ld::mesh::test {

struct EditFingerprint {
  std::uint64_t hash = 1469598103934665603ull;  // FNV-1a over 64-bit words
  std::vector<std::string> topologyProblems;    // validate() problems other than zero-area faces
  void mix(std::uint64_t x) {
    hash ^= x;
    hash *= 1099511628211ull;
  }
};

inline EditFingerprint editSequenceFingerprint() {
  EditFingerprint fp;
  for (int trial = 0; trial < 3; ++trial) {
    std::mt19937 rng(static_cast<std::uint32_t>(1234 + trial));
    SurfaceMesh m = grid(6);
    auto etag = m.addEdgeProperty<int>("e:tag", 0);
    auto vtag = m.addVertexProperty<int>("v:tag", 0);
    auto ftag = m.addFaceProperty<int>("f:tag", 0);
    for (Edge e : m.edges()) etag[e] = static_cast<int>(e.idx()) + 1;
    for (Vertex x : m.vertices()) vtag[x] = static_cast<int>(x.idx()) + 7;
    for (Face f : m.faces()) ftag[f] = static_cast<int>(f.idx()) + 3;
    for (int step = 0; step < 4000; ++step) {
      const std::vector<Face> fs(m.faces().begin(), m.faces().end());
      const std::vector<Edge> es(m.edges().begin(), m.edges().end());
      if (fs.size() < 10) break;
      const int op = static_cast<int>(rng() % 7);
      if (op == 0) {
        const Edge e = es[rng() % es.size()];
        fp.mix(m.splitEdge(e, 0.5 * (m.position(m.vertex(e, 0)) + m.position(m.vertex(e, 1)))).idx());
      } else if (op == 1) {
        const Face f = fs[rng() % fs.size()];
        fp.mix(m.splitFace(f, m.centroid(f)).idx());
      } else if (op == 2) {
        // The first k faces of faces(v): often not a connected run, which exercises
        // the duplicated-edge bookkeeping hardest.
        const Vertex x(static_cast<std::uint32_t>(rng() % m.verticesSize()));
        if (m.isValid(x) && !m.isIsolated(x)) {
          const auto around = m.faces(x);
          if (around.size() >= 2) {
            const std::vector<Face> fan(around.begin(),
                                        around.begin() + static_cast<std::ptrdiff_t>(1 + rng() % (around.size() - 1)));
            fp.mix(m.splitVertex(x, fan).idx());
          }
        }
      } else if (op == 3) {
        const Edge e = es[rng() % es.size()];
        if (!m.isBoundary(e)) fp.mix(m.separateEdge(e).idx());
      } else if (op == 4) {
        m.deleteFace(fs[rng() % fs.size()]);
      } else if (op == 5) {
        const Edge e = es[rng() % es.size()];
        if (m.isBoundary(e)) {
          const Face f = m.face(e, 0);
          const auto i = static_cast<std::size_t>(m.localIndex(f, e));
          const Vertex a = m.vertices(f)[i], b = m.vertices(f)[(i + 1) % 3];
          const Vertex c = m.addVertex(0.5 * (m.position(a) + m.position(b)) + Point(0, 0, 1));
          fp.mix(m.addFace(b, a, c).idx());
        }
      } else if (op == 6 && rng() % 8 == 0) {
        m.deleteVertex(m.vertices(fs[rng() % fs.size()])[0]);
      }
      if (step % 997 == 996) m.garbageCollection();
    }
    for (std::size_t i = 0; i < m.verticesSize(); ++i) {
      const Vertex x(i);
      fp.mix(m.isDeleted(x));
      fp.mix(static_cast<std::uint64_t>(vtag[x]));
      for (Edge e : m.edges(x)) fp.mix(e.idx());
    }
    for (std::size_t i = 0; i < m.edgesSize(); ++i) {
      const Edge e(i);
      fp.mix(m.isDeleted(e));
      fp.mix(static_cast<std::uint64_t>(etag[e]));
      for (int k = 0; k < 2; ++k) {
        fp.mix(m.vertex(e, k).idx());
        fp.mix(m.face(e, k).idx());
      }
    }
    for (std::size_t i = 0; i < m.facesSize(); ++i) {
      const Face f(i);
      fp.mix(m.isDeleted(f));
      fp.mix(static_cast<std::uint64_t>(ftag[f]));
      for (Vertex x : m.vertices(f)) fp.mix(x.idx());
      for (Edge e : m.edges(f)) fp.mix(e.idx());
    }
    for (Vertex x : m.editedVertices()) fp.mix(x.idx());
    for (Edge x : m.editedEdges()) fp.mix(x.idx());
    for (Face x : m.editedFaces()) fp.mix(x.idx());
    for (const auto& p : m.validate().problems)
      if (p.find("degenerate") == std::string::npos) fp.topologyProblems.push_back(p);
  }
  return fp;
}

}  // namespace ld::mesh::test
