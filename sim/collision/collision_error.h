#pragma once
// Exceptions for misuse of the collision API (a stale object id, a mesh that no
// longer matches its BVH). Geometric degeneracies never throw: they are results.
#include <stdexcept>

namespace ld::collision {

class CollisionError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

}  // namespace ld::collision
