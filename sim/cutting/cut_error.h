#pragma once
// Exceptions for misuse of the cutting API (an unknown object id, bad parameters).
// Geometric trouble while cutting is never thrown: the cut stops where it cannot go
// on and the event is counted in CutStats.
#include <stdexcept>
#include <string>

namespace ld::cutting {

class CutError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

}  // namespace ld::cutting
