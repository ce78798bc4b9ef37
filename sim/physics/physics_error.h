#pragma once
// Misuse of the physics API (missing tissue properties, unknown method name, bad
// parameters). Numerical divergence is never thrown: the stability monitor records
// it in the state and recovers.
#include <stdexcept>
#include <string>

namespace ld::physics {

class PhysicsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The mesh lacks a property the physics needs (call attachTissueProperties first).
class MissingPropertyError : public PhysicsError {
 public:
  explicit MissingPropertyError(const std::string& name)
      : PhysicsError("tissue property '" + name + "' is missing; call attachTissueProperties first") {}
};

// A name (integrator, scene) that is not known.
class UnknownNameError : public PhysicsError {
 public:
  using PhysicsError::PhysicsError;
};

}  // namespace ld::physics
