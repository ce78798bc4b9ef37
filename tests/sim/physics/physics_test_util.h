#pragma once
// Small scenes shared by the physics tests.
#include <cmath>
#include <numbers>

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

}  // namespace ld::physics::testutil
