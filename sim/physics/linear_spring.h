#pragma once
// One linear spring between nodes 0 and 1 with optional axial damping, and its
// derivatives; the building block of the mass-spring forces and of the implicit
// method's Jacobian (checked against the OpenSurgSim oracle in the tests).
#include <cmath>

#include <Eigen/Core>

namespace ld::physics {

struct LinearSpringEval {
  Eigen::Vector3d f0 = Eigen::Vector3d::Zero();   // force on node 0 (node 1 gets −f0)
  Eigen::Matrix3d K00 = Eigen::Matrix3d::Zero();  // −∂f0/∂x0 (not symmetric when c ≠ 0)
  Eigen::Matrix3d D00 = Eigen::Matrix3d::Zero();  // −∂f0/∂v0 = c·u·uᵀ
  double length = 0.0;
};

// u = (p1 − p0)/l; f0 = (k(l − l0) + c·(v1 − v0)·u)·u. A zero-length spring gives no force.
inline LinearSpringEval linearSpring(double k, double c, double l0, const Eigen::Vector3d& p0,
                                     const Eigen::Vector3d& p1, const Eigen::Vector3d& v0, const Eigen::Vector3d& v1) {
  LinearSpringEval r;
  const Eigen::Vector3d d = p1 - p0;
  const double l = d.norm();
  r.length = l;
  if (!(l > 0.0)) return r;
  const Eigen::Vector3d u = d / l;
  const Eigen::Vector3d w = v1 - v0;
  const double s = k * (l - l0) + c * w.dot(u);
  r.f0 = s * u;
  const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - u * u.transpose();
  // f0 depends on x0 through d = p1 − p0, so −∂f0/∂x0 = ∂f0/∂d.
  r.K00 = k * u * u.transpose() + (c / l) * u * (w.transpose() * P) + (s / l) * P;
  r.D00 = c * u * u.transpose();
  return r;
}

// The spring block used by the implicit method: ∂f_i/∂x_j for an undamped spring,
// with the transverse term clamped at zero for compressed springs so that the system
// matrix stays positive definite (Choi & Ko 2002).
inline Eigen::Matrix3d springStiffnessBlock(double k, double l0, const Eigen::Vector3d& d) {
  const double l = d.norm();
  if (!(l > 0.0)) return k * Eigen::Matrix3d::Identity();
  const Eigen::Vector3d u = d / l;
  const double t = std::max(0.0, 1.0 - l0 / l);
  return k * (u * u.transpose()) + (k * t) * (Eigen::Matrix3d::Identity() - u * u.transpose());
}

}  // namespace ld::physics
