#pragma once
// Small scenes shared by the physics tests.
#include <cmath>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "sim/physics/mass_spring.h"
#include "sim/physics/scenes.h"

namespace ld::physics::testutil {

// One unit mass on a home spring: ω0 = 2π (period 1 s), x(0) = 1 mm along x.
struct Oscillator {
  Params params;
  State state;
  double omega0 = 2.0 * std::numbers::pi;
  explicit Oscillator(double damping) {
    params.tissue.uniformMass = true;
    params.tissue.vertexMass = 1.0;
    params.tissue.homeK = omega0 * omega0;
    params.tissue.damping = damping;
    mesh::SurfaceMesh m;
    m.addVertex(Eigen::Vector3d::Zero());
    state = makeState(std::move(m), params.tissue);
    state.mesh.positions()[0] = Eigen::Vector3d(1.0, 0.0, 0.0);
  }
  [[nodiscard]] double x() const { return state.mesh.positions()[0].x(); }
  // Analytic x(t) of the damped oscillator with x(0) = 1, v(0) = 0.
  [[nodiscard]] double exact(double t) const {
    const double c = params.tissue.damping;
    const double wd = std::sqrt(omega0 * omega0 - 0.25 * c * c);
    return std::exp(-0.5 * c * t) * (std::cos(wd * t) + 0.5 * c / wd * std::sin(wd * t));
  }
  [[nodiscard]] double exactVelocity(double t) const {
    const double c = params.tissue.damping;
    const double wd = std::sqrt(omega0 * omega0 - 0.25 * c * c);
    return -std::exp(-0.5 * c * t) * (omega0 * omega0 / wd) * std::sin(wd * t);
  }
  [[nodiscard]] double v() const {
    return state.mesh.getVertexProperty<Eigen::Vector3d>(kVelocityProp).vector()[0].x();
  }
};

// An 8 x 8 patch of 4 mm squares with the vertex nearest its centre pushed 5 mm down.
inline State pushedPatch(const Params& p) {
  State s = makeState(makeGrid(8, 8, 4.0), p.tissue);
  s.mesh.position(nearestVertex(s.mesh, Eigen::Vector3d(16, 16, 0))).z() -= 5.0;
  return s;
}

inline std::vector<Eigen::Vector3d> positionsOf(const State& s) { return s.mesh.positions(); }

inline double maxDiff(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b) {
  double d = 0;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) d = std::max(d, (a[i] - b[i]).norm());
  return d;
}

// Random local edits with the physics hooks, as the cutter makes them.
inline void randomEdits(mesh::SurfaceMesh& m, const TissueParams& tp, std::mt19937& rng, int count) {
  for (int k = 0; k < count; ++k) {
    const int kind = static_cast<int>(rng() % 3);
    if (kind == 0) {
      const mesh::Face f(static_cast<int>(rng() % m.facesSize()));
      if (!m.isValid(f)) continue;
      const auto vs = m.vertices(f);
      const auto v = m.splitFace(f, m.centroid(f));
      initVertexInFace(m, v, vs[0], vs[1], vs[2], Eigen::Vector3d::Constant(1.0 / 3.0), tp);
      for (mesh::Edge e : m.edges(v)) initEdge(m, e, tp);
    } else if (kind == 1) {
      const mesh::Edge e(static_cast<int>(rng() % m.edgesSize()));
      if (!m.isValid(e)) continue;
      const auto a = m.vertex(e, 0), b = m.vertex(e, 1);
      const auto v = m.splitEdge(e, 0.5 * (m.position(a) + m.position(b)));
      initVertexOnEdge(m, v, a, b, 0.5, tp);
      for (mesh::Edge e2 : m.edges(v)) initEdge(m, e2, tp);
    } else {
      const mesh::Face f(static_cast<int>(rng() % m.facesSize()));
      if (!m.isValid(f)) continue;
      const auto vs = m.vertices(f);
      m.deleteFace(f);
      redistributeMass(m, vs, tp);
    }
  }
  ASSERT_TRUE(m.validate().ok()) << m.validate().message();
}

}  // namespace ld::physics::testutil
