#pragma once
// Typed index handles for mesh elements. A handle is an index into the mesh's
// element arrays; the type tag keeps a vertex index from being used as a face.
#include <cstdint>
#include <functional>
#include <limits>
#include <ostream>

namespace ld::mesh {

template <class Tag>
class Handle {
 public:
  using Index = std::uint32_t;
  static constexpr Index kInvalid = std::numeric_limits<Index>::max();

  constexpr Handle() = default;
  constexpr explicit Handle(Index i) : idx_(i) {}
  constexpr explicit Handle(std::size_t i) : idx_(static_cast<Index>(i)) {}
  constexpr explicit Handle(int i) : idx_(static_cast<Index>(i)) {}

  [[nodiscard]] constexpr Index idx() const { return idx_; }
  [[nodiscard]] constexpr bool isValid() const { return idx_ != kInvalid; }
  constexpr explicit operator bool() const { return isValid(); }
  constexpr auto operator<=>(const Handle&) const = default;

 private:
  Index idx_ = kInvalid;
};

struct VertexTag {};
struct EdgeTag {};
struct FaceTag {};
using Vertex = Handle<VertexTag>;
using Edge = Handle<EdgeTag>;
using Face = Handle<FaceTag>;

inline std::ostream& operator<<(std::ostream& os, Vertex v) {
  return os << 'v' << static_cast<long long>(v.isValid() ? v.idx() : -1);
}
inline std::ostream& operator<<(std::ostream& os, Edge e) {
  return os << 'e' << static_cast<long long>(e.isValid() ? e.idx() : -1);
}
inline std::ostream& operator<<(std::ostream& os, Face f) {
  return os << 'f' << static_cast<long long>(f.isValid() ? f.idx() : -1);
}

}  // namespace ld::mesh

template <class Tag>
struct std::hash<ld::mesh::Handle<Tag>> {
  std::size_t operator()(ld::mesh::Handle<Tag> h) const noexcept { return std::hash<std::uint32_t>{}(h.idx()); }
};
