#include "sim/physics/tissue_properties.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include <Eigen/Geometry>

#include "sim/physics/physics_error.h"

namespace ld::physics {

using mesh::Edge;
using mesh::Face;
using mesh::SurfaceMesh;
using mesh::Vertex;
using Vec3 = Eigen::Vector3d;

namespace {

template <class T>
mesh::VertexProperty<T> requireV(const SurfaceMesh& m, const char* name) {
  auto p = m.getVertexProperty<T>(name);
  if (!p) throw MissingPropertyError(name);
  return p;
}

double homeArea(const SurfaceMesh& m, const mesh::VertexProperty<Vec3>& home, Face f) {
  const auto& vs = m.vertices(f);
  return 0.5 * (home[vs[1]] - home[vs[0]]).cross(home[vs[2]] - home[vs[0]]).norm();
}

// v and every vertex sharing an edge with it.
void oneRing(const SurfaceMesh& m, Vertex v, std::vector<Vertex>& r) {
  r.clear();
  r.reserve(m.edges(v).size() + 1);
  r.push_back(v);
  for (Edge e : m.edges(v)) r.push_back(m.otherVertex(e, v));
}

void setEdge(SurfaceMesh& m, Edge e, const TissueParams& p, const mesh::VertexProperty<Vec3>& home,
             mesh::EdgeProperty<double>& rest, mesh::EdgeProperty<double>& k) {
  const double len = (home[m.vertex(e, 0)] - home[m.vertex(e, 1)]).norm();
  rest[e] = std::max(p.restRatio * len, p.minRest);
  k[e] = p.K / rest[e];
}

template <class P>
P& need(P& prop, const char* name) {
  if (!prop) throw MissingPropertyError(name);
  return prop;
}

void initEdgeWith(SurfaceMesh& m, Edge e, const TissueParams& p, TissueHandles& q) {
  need(q.home, kHomeProp);
  need(q.rest, kRestProp);
  need(q.k, kStiffnessProp);
  setEdge(m, e, p, q.home, q.rest, q.k);
}

}  // namespace

bool hasTissueProperties(const SurfaceMesh& m) {
  return m.getVertexProperty<Vec3>(kHomeProp) && m.getVertexProperty<double>(kMassProp) &&
         m.getVertexProperty<Vec3>(kVelocityProp) && m.getVertexProperty<Vec3>(kForceProp) &&
         m.getEdgeProperty<double>(kRestProp) && m.getEdgeProperty<double>(kStiffnessProp);
}

namespace {

// The lightest mass massFloorDt allows for a vertex whose springs sum to sumK.
double massFloor(const TissueParams& p, double sumK) {
  return p.massFloorDt > 0.0 ? p.massFloorDt * p.massFloorDt * (p.homeK + 2.0 * sumK) : 0.0;
}

double springSum(const SurfaceMesh& m, Vertex v, const mesh::EdgeProperty<double>& k) {
  double sum = 0.0;
  if (k)
    for (Edge e : m.edges(v)) sum += k[e];
  return sum;
}

double springSum(const SurfaceMesh& m, Vertex v) { return springSum(m, v, m.getEdgeProperty<double>(kStiffnessProp)); }

// The home areas of v's faces, each face taken once: from the edge that runs from v to
// the face's next corner (no face list to build and search for repeats).
double homeAreaAround(const SurfaceMesh& m, const mesh::VertexProperty<Vec3>& home, Vertex v) {
  double area = 0.0;
  for (Edge e : m.edges(v)) {
    const Vertex a = m.otherVertex(e, v);
    for (int side = 0; side < 2; ++side) {
      const Face f = m.face(e, side);
      if (!f.isValid()) continue;
      const auto& fv = m.vertices(f);
      if ((fv[0] == v && fv[1] == a) || (fv[1] == v && fv[2] == a) || (fv[2] == v && fv[0] == a))
        area += homeArea(m, home, f);
    }
  }
  return area;
}

// lumpedMass with the properties at hand.
double lumpedMassWith(const SurfaceMesh& m, Vertex v, const TissueParams& p, const TissueHandles& q) {
  const double floor = p.massFloorDt > 0.0 ? massFloor(p, springSum(m, v, q.k)) : 0.0;
  if (p.uniformMass) return std::max(p.vertexMass, floor);
  const double area = homeAreaAround(m, need(q.home, kHomeProp), v);
  return std::max({p.density * area / 3.0, p.minMass, floor});
}

void redistributeMassWith(SurfaceMesh& m, std::span<const Vertex> vertices, const TissueParams& p, TissueHandles& q) {
  auto& mass = need(q.mass, kMassProp);
  for (Vertex v : vertices)
    if (m.isValid(v)) mass[v] = lumpedMassWith(m, v, p, q);
}

}  // namespace

double lumpedMass(const SurfaceMesh& m, Vertex v, const TissueParams& p) {
  return lumpedMassWith(m, v, p, TissueHandles(m));
}

void attachTissueProperties(SurfaceMesh& m, const TissueParams& p) {
  auto home = m.vertexProperty<Vec3>(kHomeProp, Vec3::Zero());
  auto mass = m.vertexProperty<double>(kMassProp, 0.0);
  auto vel = m.vertexProperty<Vec3>(kVelocityProp, Vec3::Zero());
  auto force = m.vertexProperty<Vec3>(kForceProp, Vec3::Zero());
  auto rest = m.edgeProperty<double>(kRestProp, 1.0);
  auto k = m.edgeProperty<double>(kStiffnessProp, 0.0);
  for (Vertex v : m.vertices()) {
    home[v] = m.position(v);
    vel[v].setZero();
    force[v].setZero();
  }
  for (Edge e : m.edges()) setEdge(m, e, p, home, rest, k);
  (void)mass;
  recomputeMasses(m, p);
}

void redistributeMass(SurfaceMesh& m, TissueHandles& h, std::span<const Vertex> vertices, const TissueParams& p) {
  redistributeMassWith(m, vertices, p, h);
}

void redistributeMass(SurfaceMesh& m, std::span<const Vertex> vertices, const TissueParams& p) {
  TissueHandles q(m);
  redistributeMass(m, q, vertices, p);
}

void initEdgesAround(SurfaceMesh& m, TissueHandles& q, std::span<const Vertex> vertices, const TissueParams& p) {
  // Edges first, then masses: a mass reads only its own vertex's springs (the floor)
  // and home areas, so this equals initEdge + redistributeMass vertex by vertex.
  for (Vertex v : vertices)
    if (m.isValid(v))
      for (Edge e : m.edges(v)) initEdgeWith(m, e, p, q);
  redistributeMassWith(m, vertices, p, q);
}

void initEdgesAround(SurfaceMesh& m, std::span<const Vertex> vertices, const TissueParams& p) {
  TissueHandles q(m);
  initEdgesAround(m, q, vertices, p);
}

void recomputeMasses(SurfaceMesh& m, const TissueParams& p) {
  auto mass = requireV<double>(m, kMassProp);
  std::vector<double> floor(m.verticesSize(), 0.0);
  if (p.massFloorDt > 0.0)
    for (Vertex v : m.vertices()) floor[v.idx()] = massFloor(p, springSum(m, v));
  if (p.uniformMass) {
    for (Vertex v : m.vertices()) mass[v] = std::max(p.vertexMass, floor[v.idx()]);
    return;
  }
  // One pass over faces instead of per-vertex face lists.
  const auto home = requireV<Vec3>(m, kHomeProp);
  std::vector<double> area(m.verticesSize(), 0.0);
  for (Face f : m.faces()) {
    const double a = homeArea(m, home, f);
    for (Vertex v : m.vertices(f)) area[v.idx()] += a;
  }
  for (Vertex v : m.vertices()) mass[v] = std::max({p.density * area[v.idx()] / 3.0, p.minMass, floor[v.idx()]});
}

void initVertexOnEdge(SurfaceMesh& m, TissueHandles& q, Vertex v, Vertex a, Vertex b, double t, const TissueParams& p) {
  auto& home = need(q.home, kHomeProp);
  auto& vel = need(q.vel, kVelocityProp);
  auto& force = need(q.force, kForceProp);
  home[v] = p.newVertexHome == NewVertexHome::Current ? m.position(v) : Vec3((1.0 - t) * home[a] + t * home[b]);
  vel[v] = (1.0 - t) * vel[a] + t * vel[b];
  force[v].setZero();
  for (Edge e : m.edges(v)) initEdgeWith(m, e, p, q);
  oneRing(m, v, q.ring);
  redistributeMassWith(m, q.ring, p, q);
}

void initVertexOnEdge(SurfaceMesh& m, Vertex v, Vertex a, Vertex b, double t, const TissueParams& p) {
  TissueHandles q(m);
  initVertexOnEdge(m, q, v, a, b, t, p);
}

void initVertexInFace(SurfaceMesh& m, TissueHandles& q, Vertex v, Vertex a, Vertex b, Vertex c, const Vec3& bary,
                      const TissueParams& p) {
  auto& home = need(q.home, kHomeProp);
  auto& vel = need(q.vel, kVelocityProp);
  auto& force = need(q.force, kForceProp);
  home[v] = p.newVertexHome == NewVertexHome::Current ? m.position(v)
                                                      : Vec3(bary[0] * home[a] + bary[1] * home[b] + bary[2] * home[c]);
  vel[v] = bary[0] * vel[a] + bary[1] * vel[b] + bary[2] * vel[c];
  force[v].setZero();
  for (Edge e : m.edges(v)) initEdgeWith(m, e, p, q);
  oneRing(m, v, q.ring);
  redistributeMassWith(m, q.ring, p, q);
}

void initVertexInFace(SurfaceMesh& m, Vertex v, Vertex a, Vertex b, Vertex c, const Vec3& bary, const TissueParams& p) {
  TissueHandles q(m);
  initVertexInFace(m, q, v, a, b, c, bary, p);
}

void initVertexInFace(SurfaceMesh& m, Vertex v, Face f, const Vec3& bary, const TissueParams& p) {
  const auto vs = m.vertices(f);
  initVertexInFace(m, v, vs[0], vs[1], vs[2], bary, p);
}

namespace {
// Home and velocity of original, no force (every property checked before any is read).
void copyStateWith(TissueHandles& q, Vertex v, Vertex original) {
  auto& home = need(q.home, kHomeProp);
  auto& vel = need(q.vel, kVelocityProp);
  auto& force = need(q.force, kForceProp);
  home[v] = home[original];
  vel[v] = vel[original];
  force[v].setZero();
}
}  // namespace

void initVertexCopy(SurfaceMesh& m, TissueHandles& q, Vertex v, Vertex original, const TissueParams& p) {
  copyStateWith(q, v, original);
  for (Edge e : m.edges(v)) initEdgeWith(m, e, p, q);
  const Vertex both[2] = {v, original};
  redistributeMassWith(m, both, p, q);
}

void initVertexCopy(SurfaceMesh& m, Vertex v, Vertex original, const TissueParams& p) {
  TissueHandles q(m);
  initVertexCopy(m, q, v, original, p);
}

void copyVertexState(TissueHandles& h, Vertex v, Vertex original) { copyStateWith(h, v, original); }

void copyVertexState(SurfaceMesh& m, Vertex v, Vertex original) {
  TissueHandles q(m);
  copyStateWith(q, v, original);
}

void initEdge(SurfaceMesh& m, TissueHandles& h, Edge e, const TissueParams& p) { initEdgeWith(m, e, p, h); }

void initEdge(SurfaceMesh& m, Edge e, const TissueParams& p) {
  TissueHandles q(m);
  initEdgeWith(m, e, p, q);
}

void TissueHandles::lookUp(const SurfaceMesh& m) {
  home = m.getVertexProperty<Vec3>(kHomeProp);
  vel = m.getVertexProperty<Vec3>(kVelocityProp);
  force = m.getVertexProperty<Vec3>(kForceProp);
  mass = m.getVertexProperty<double>(kMassProp);
  rest = m.getEdgeProperty<double>(kRestProp);
  k = m.getEdgeProperty<double>(kStiffnessProp);
  mesh_ = &m;
  version_ = m.propertySetVersion();
}

std::vector<Vertex> unsettledVertices(SurfaceMesh& m, std::span<const Vec3> keep) {
  std::vector<Vertex> out;
  if (!m.getVertexProperty<std::uint8_t>(kSettledProp)) {
    auto settled = m.vertexProperty<std::uint8_t>(kSettledProp, 0);
    for (Vertex v : m.vertices()) settled[v] = 1;
    return out;
  }
  // A byte scan (most are settled; it runs after every cutting sample, 50k vertices
  // at 100k triangles): memchr's vector search, not std::find's byte loop (which was
  // 5 % of `cut --physics on` at 100k).
  const std::vector<std::uint8_t>& flags = m.getVertexProperty<std::uint8_t>(kSettledProp).vector();
  const std::uint8_t* const begin = flags.data();
  const std::uint8_t* const end = begin + flags.size();
  for (auto* it = begin; it < end; ++it) {
    it = static_cast<const std::uint8_t*>(std::memchr(it, 0, static_cast<std::size_t>(end - it)));
    if (it == nullptr) break;
    const Vertex v(static_cast<std::uint32_t>(it - begin));
    if (!m.isValid(v)) continue;
    const bool kept =
        std::any_of(keep.begin(), keep.end(), [&](const Vec3& q) { return (q - m.position(v)).squaredNorm() < 1e-12; });
    if (!kept) out.push_back(v);
  }
  return out;
}

void settleVertices(SurfaceMesh& m, std::span<const Vertex> vertices, const TissueParams& p) {
  if (vertices.empty()) return;
  auto settled = m.vertexProperty<std::uint8_t>(kSettledProp, 0);
  TissueHandles h(m);  // (after adding the flag: adding a property may move the views)
  need(h.home, kHomeProp);
  need(h.vel, kVelocityProp);
  need(h.rest, kRestProp);
  need(h.k, kStiffnessProp);
  for (Vertex v : vertices) settled[v] = 0;  // (the set, for the velocities below)
  // Where they were and their faces' normals there: a move that turns a face by more
  // than 60° is halved until none does. A balance past a neighbour folds the surface
  // (seen in the window: a groove's last bottom vertex settled 0.8 mm back and up, and
  // the physics then held it 0.4 mm above the top surface).
  std::vector<Vec3> from;
  std::vector<std::vector<std::pair<Face, Vec3>>> normals;
  from.reserve(vertices.size());
  normals.reserve(vertices.size());
  for (Vertex v : vertices) {
    from.push_back(m.position(v));
    auto& n = normals.emplace_back();
    for (Face f : m.faces(v)) n.emplace_back(f, m.faceNormal(f));
  }
  for (int sweep = 0; sweep < p.settleSweeps; ++sweep)
    for (Vertex v : vertices) {
      // Balance with the spring directions frozen at the current ones: each spring pulls
      // v toward the point at its rest length from the far end.
      const Vec3 x = m.position(v);
      Vec3 num = p.homeK * h.home[v];
      double den = p.homeK;
      for (Edge e : m.edges(v)) {
        const Vec3& y = m.position(m.otherVertex(e, v));
        const double l = (x - y).norm();
        if (!(l > 0.0) || !(h.k[e] > 0.0)) continue;
        num += h.k[e] * (y + (h.rest[e] / l) * (x - y));
        den += h.k[e];
      }
      if (den > 0.0 && num.allFinite()) m.position(v) = num / den;
    }
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    const Vertex v = vertices[i];
    const Vec3 target = m.position(v);
    for (int halvings = 0; halvings <= 20; ++halvings) {
      const double t = halvings == 20 ? 0.0 : std::ldexp(1.0, -halvings);
      m.position(v) = from[i] + t * (target - from[i]);
      const bool turned = std::any_of(normals[i].begin(), normals[i].end(), [&](const auto& fn) {
        return fn.second.squaredNorm() > 0.0 && m.faceNormal(fn.first).dot(fn.second) < 0.5;
      });
      if (!turned) break;
    }
  }
  for (Vertex v : vertices) {
    Vec3 sum = Vec3::Zero();
    int n = 0;
    for (Edge e : m.edges(v)) {
      const Vertex w = m.otherVertex(e, v);
      if (!settled[w]) continue;
      sum += h.vel[w];
      ++n;
    }
    h.vel[v] = n > 0 ? Vec3(sum / n) : Vec3::Zero();
  }
  for (Vertex v : vertices) settled[v] = 1;
}

}  // namespace ld::physics
