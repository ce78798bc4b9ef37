#pragma once
// Exceptions for misuse of the mesh API (a stale or foreign handle, a missing
// property). Impossible topology edits do not throw: they return an invalid handle.
#include <stdexcept>
#include <string>

namespace ld::mesh {

class MeshError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

class InvalidHandleError : public MeshError {
 public:
  using MeshError::MeshError;
};

class PropertyError : public MeshError {
 public:
  using MeshError::MeshError;
};

}  // namespace ld::mesh
