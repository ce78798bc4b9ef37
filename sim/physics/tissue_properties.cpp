#include "sim/physics/tissue_properties.h"

#include <algorithm>
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

template <class T>
mesh::EdgeProperty<T> requireE(const SurfaceMesh& m, const char* name) {
  auto p = m.getEdgeProperty<T>(name);
  if (!p) throw MissingPropertyError(name);
  return p;
}

double homeArea(const SurfaceMesh& m, const mesh::VertexProperty<Vec3>& home, Face f) {
  const auto& vs = m.vertices(f);
  return 0.5 * (home[vs[1]] - home[vs[0]]).cross(home[vs[2]] - home[vs[0]]).norm();
}

// v and every vertex sharing an edge with it.
std::vector<Vertex> oneRing(const SurfaceMesh& m, Vertex v) {
  std::vector<Vertex> r{v};
  for (Edge e : m.edges(v)) r.push_back(m.otherVertex(e, v));
  return r;
}

void setEdge(SurfaceMesh& m, Edge e, const TissueParams& p, const mesh::VertexProperty<Vec3>& home,
             mesh::EdgeProperty<double>& rest, mesh::EdgeProperty<double>& k) {
  const double len = (home[m.vertex(e, 0)] - home[m.vertex(e, 1)]).norm();
  rest[e] = std::max(p.restRatio * len, p.minRest);
  k[e] = p.K / rest[e];
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

double springSum(const SurfaceMesh& m, Vertex v) {
  const auto k = m.getEdgeProperty<double>(kStiffnessProp);
  double sum = 0.0;
  if (k)
    for (Edge e : m.edges(v)) sum += k[e];
  return sum;
}

}  // namespace

double lumpedMass(const SurfaceMesh& m, Vertex v, const TissueParams& p) {
  const double floor = p.massFloorDt > 0.0 ? massFloor(p, springSum(m, v)) : 0.0;
  if (p.uniformMass) return std::max(p.vertexMass, floor);
  const auto home = requireV<Vec3>(m, kHomeProp);
  double area = 0.0;
  for (Face f : m.faces(v)) area += homeArea(m, home, f);
  return std::max({p.density * area / 3.0, p.minMass, floor});
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

void redistributeMass(SurfaceMesh& m, std::span<const Vertex> vertices, const TissueParams& p) {
  auto mass = requireV<double>(m, kMassProp);
  for (Vertex v : vertices)
    if (m.isValid(v)) mass[v] = lumpedMass(m, v, p);
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

void initVertexOnEdge(SurfaceMesh& m, Vertex v, Vertex a, Vertex b, double t, const TissueParams& p) {
  auto home = requireV<Vec3>(m, kHomeProp);
  auto vel = requireV<Vec3>(m, kVelocityProp);
  auto force = requireV<Vec3>(m, kForceProp);
  home[v] = p.newVertexHome == NewVertexHome::Current ? m.position(v) : Vec3((1.0 - t) * home[a] + t * home[b]);
  vel[v] = (1.0 - t) * vel[a] + t * vel[b];
  force[v].setZero();
  for (Edge e : m.edges(v)) initEdge(m, e, p);
  const auto ring = oneRing(m, v);
  redistributeMass(m, ring, p);
}

void initVertexInFace(SurfaceMesh& m, Vertex v, Vertex a, Vertex b, Vertex c, const Vec3& bary, const TissueParams& p) {
  auto home = requireV<Vec3>(m, kHomeProp);
  auto vel = requireV<Vec3>(m, kVelocityProp);
  auto force = requireV<Vec3>(m, kForceProp);
  home[v] = p.newVertexHome == NewVertexHome::Current ? m.position(v)
                                                      : Vec3(bary[0] * home[a] + bary[1] * home[b] + bary[2] * home[c]);
  vel[v] = bary[0] * vel[a] + bary[1] * vel[b] + bary[2] * vel[c];
  force[v].setZero();
  for (Edge e : m.edges(v)) initEdge(m, e, p);
  const auto ring = oneRing(m, v);
  redistributeMass(m, ring, p);
}

void initVertexInFace(SurfaceMesh& m, Vertex v, Face f, const Vec3& bary, const TissueParams& p) {
  const auto vs = m.vertices(f);
  initVertexInFace(m, v, vs[0], vs[1], vs[2], bary, p);
}

void initVertexCopy(SurfaceMesh& m, Vertex v, Vertex original, const TissueParams& p) {
  auto home = requireV<Vec3>(m, kHomeProp);
  auto vel = requireV<Vec3>(m, kVelocityProp);
  auto force = requireV<Vec3>(m, kForceProp);
  home[v] = home[original];
  vel[v] = vel[original];
  force[v].setZero();
  for (Edge e : m.edges(v)) initEdge(m, e, p);
  const std::vector<Vertex> both{v, original};
  redistributeMass(m, both, p);
}

void initEdge(SurfaceMesh& m, Edge e, const TissueParams& p) {
  const auto home = requireV<Vec3>(m, kHomeProp);
  auto rest = requireE<double>(m, kRestProp);
  auto k = requireE<double>(m, kStiffnessProp);
  setEdge(m, e, p, home, rest, k);
}

}  // namespace ld::physics
