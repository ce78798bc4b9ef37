#pragma once
// The fat-box pass's scan (TriangleBvh::refitMoved, internal to sim/collision): which
// vertices moved farther than theta from their anchors. Positions are double, anchors
// float (rounded to nearest; the tree widens its boxes by that rounding). Builds chosen
// at run time: portable scalar code, SSE2 (2 lanes), AVX2 (4) and AVX-512 (8); no
// -march, so the library runs anywhere. Every build computes each |x - a| the same way
// (double subtraction of the anchor widened exactly) and only takes maxima, so all
// return bit-identical results.
#include <cstddef>
#include <optional>
#include <string_view>

namespace ld::collision {

enum class ScanKernel { Portable, Sse2, Avx2, Avx512 };

[[nodiscard]] std::string_view scanKernelName(ScanKernel k);
// Compiled in and supported by this CPU.
[[nodiscard]] bool scanKernelSupported(ScanKernel k);
// The build refitMoved uses: the widest supported one unless a test forced another.
[[nodiscard]] ScanKernel activeScanKernel();
// For tests and benchmarks: force a build (nullopt = automatic). Returns false (and
// changes nothing) when it is not supported here.
bool forceScanKernel(std::optional<ScanKernel> k);

namespace detail {

// Blocks of 8 vertices (24 coordinates of x and of a) from block b on: the first one
// with a coordinate farther than theta from its anchor, or a NaN difference (nb if
// none). `worst` takes the largest |x - a| of the blocks passed over.
std::size_t scanQuietBlocks(ScanKernel k, const double* x, const float* a, std::size_t b, std::size_t nb, double theta,
                            double& worst);

// a[i] = float(x[i]) (to nearest, as a static_cast) for i < n, with build k.
void anchorCoordinates(ScanKernel k, const double* x, float* a, std::size_t n);

}  // namespace detail
}  // namespace ld::collision
