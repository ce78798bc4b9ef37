#pragma once
// The spring loops (internal to sim/physics) in three builds chosen at run time:
// portable scalar code, AVX2+FMA (4 lanes) and AVX-512 (8). All are double precision:
// the symplectic step (blockStep: vertex-centric, each vertex sums its own springs) and
// the force pass of the other integrators (springForces: each spring once, scattered to
// both ends). Every lane computes the same operations whatever the group it falls in
// (tails are masked or padded, never done by a different scalar loop), so a vertex's
// result does not depend on where a thread's range starts: the two-thread step stays
// bit-identical to one thread on each path.
// Paths differ from each other in the last bits (fused multiply-add; in the symplectic
// step the force factor's 1/l from rsqrt and Newton steps, within 1 ulp: see Factor).
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string_view>
#include <vector>

namespace ld::physics::detail {

enum class Kernel { Scalar, Avx2, Avx512 };

[[nodiscard]] std::string_view kernelName(Kernel k);
// Compiled in and supported by this CPU.
[[nodiscard]] bool kernelSupported(Kernel k);
// The path the step uses: the best supported one unless a test forced another.
[[nodiscard]] Kernel activeKernel();
// For tests and benchmarks: force a path (nullopt = automatic). Returns false (and
// changes nothing) when the path is not supported here.
bool forceKernel(std::optional<Kernel> k);

// How the vector paths get each spring's 1/l (the scalar path, the portable reference,
// always takes sqrt and div):
//  - Rsqrt: an estimate of 1/√(l²) refined by Newton steps to within 1 ulp, no divider
//    (AVX-512: rsqrt14, 14 bits, and 2 steps; AVX2: a bit-trick estimate, ~5 bits, and
//    4 steps); the force factor is then k − K·(1/l) (shared K) or k·(1 − rest·(1/l))
//    (per spring);
//  - SqrtDiv: sqrt and div, (k·l − K)/l and k(l − rest)/l, rounded as the scalar path.
// Both mask l² = 0 and k = 0 the same way (the factor is exactly 0 there). Default
// (defaultFactor), by measurement: Rsqrt on AVX-512 on Intel CPUs (on an Intel Xeon at
// 2.6 GHz, whose one divider takes ~28 cycles for a rank's sqrt and div, the step is
// 25–35 % faster), SqrtDiv elsewhere: on AVX2 (Rsqrt with 4 steps measured 10–20 %
// slower on that Xeon) and on AMD CPUs (sqrt and div measured faster on a Zen 5).
enum class Factor { SqrtDiv, Rsqrt };
[[nodiscard]] std::string_view factorName(Factor f);
[[nodiscard]] Factor defaultFactor(Kernel k);
// The factor path k uses: its default unless a test or benchmark forced one.
[[nodiscard]] Factor activeFactor(Kernel k);
void forceFactor(std::optional<Factor> f);  // nullopt = each path's default
// Newton steps path k takes after its estimate (0: the path divides).
[[nodiscard]] int newtonSteps(Kernel k);
// For tests: out[i] = 1/√l2[i] as path k's Rsqrt factor computes it, with `steps`
// Newton steps (0 … 6; newtonSteps(k) is the step's); the scalar path divides. Call
// with denormals flushed, as the step runs. Valid for l² in [2^-1021, DBL_MAX]
// (below, 0.5·l² is flushed); l² = 0 gives a non-finite or huge value (the step
// masks it).
void invSqrt(Kernel k, const double* l2, double* out, std::size_t n, int steps);

// Springs [0, m) of one chunk (vertex indices of both ends, rest, k). Each spring's
// force g = k(l − rest)/l · (x_j − x_i) is added to f4[4·i] (unless addLower is off)
// and subtracted from f4[4·j] when j < writeLimit, in spring order. The force buffer
// holds 4 doubles a vertex (x, y, z, unused) so that each update is one 4-wide
// read-modify-write.
struct SpringChunk {
  const double* x = nullptr;  // positions, 3 a vertex
  const std::uint32_t* lo = nullptr;
  const std::uint32_t* oth = nullptr;
  const double* rest = nullptr;
  const double* k = nullptr;
  bool addLower = true;
  double* f4 = nullptr;
  std::size_t writeLimit = 0;
  std::size_t m = 0;
};
// Returns Σ k (l − rest)² over the chunk (twice the energy).
double springForces(Kernel kern, const SpringChunk& c);

// The symplectic step, vertex-centric. Vertices come in groups of kGroup = 16
// consecutive ones, split into two blocks of kLanes = 8 lanes, one vertex a lane;
// lanes are sorted by degree within the group (slotVertex: the vertex, as an offset in
// the group, of each lane slot; vertexSlot: the inverse), so that a block of
// high-degree vertices and one of low-degree vertices pad less than consecutive ones
// would. Block b (2 a group) holds ranks [rankStart[b], rankStart[b+1]); rank r has,
// for every lane, the far end (rankX = 3·j, the offset of x_j), k and rest of that
// lane's vertex's r-th neighbour (by index: the order the lower-vertex scatter summed
// in), padded with k = rest = 0 and the lane's own vertex (dead springs too; lanes past n: the group's first vertex).
// Each vertex sums its own springs (each spring is evaluated at both ends: no scatter, no shared writes; any split into
// group ranges gives the same bits), adds f4 (4 doubles a vertex, set by the springs added since the last rebuild) on
// groups flagged in `extra` (and zeroes it), and integrates (each spring's force factor w below): v1 = live·((1 −
// dt·c)·v0 + dt·(im·(f + ext − homeK·(x0 − home)) + g)), x1 = x0 + dt·v1, im = 1/mass (0 where mass ≤ 0, as the cache's
// invMass), live = (im ≠ 0). All arrays are whole (indexed by vertex); positions and velocities 3 doubles a vertex. Two
// lane layouts:
//  - per spring (rankRest set, 20 bytes a lane: far end, k, rest):
//    w = k(l − rest)/l, padding k = rest = 0;
//  - shared K (rankRest null, 12 bytes a lane: far end, k). Every spring's rest is
//    K/k for one K of the mesh (the thesis's k = K/rest; springK = K), so
//    w = (k·l − K)/l, and 0 where k = 0 (padding, dead springs) or l = 0. The ranks
//    stream 40 % fewer bytes; the rounding differs from the other layout in the last
//    bits. The spring energy k(l − K/k)² = k·l² − 2K·l + K·rest is summed without its
//    constant part (the caller adds K·Σ rest over the lanes: see FinishSums::pe).

inline constexpr std::size_t kLanes = 8;
inline constexpr std::size_t kGroup = 16;
// From this many vertices on, the step prefetches the vertex arrays a few groups ahead
// (the data no longer sits in L2/L3; below, the prefetches cost more than they save).
inline constexpr std::size_t kPrefetchFrom = 16384;
struct BlockStep {
  // x0 must have one more double readable past its last vertex (3n + 1): the AVX-512
  // path loads each far end as 4 doubles.
  const double *x0 = nullptr, *v0 = nullptr, *home = nullptr, *ext = nullptr;
  const double* mass = nullptr;       // one per vertex (1/mass is derived: one stream fewer)
  const double* stiffness = nullptr;  // one per vertex: Σ k of its springs
  double *x1 = nullptr, *v1 = nullptr;
  const std::uint32_t* rankStart = nullptr;  // per block
  const std::uint32_t* rankX = nullptr;      // kLanes per rank
  const double *rankK = nullptr, *rankRest = nullptr;
  // Tail ranks of group g: [tailStart[g], tailStart[g + 1]) (absolute rank indices, by
  // slot ascending); all 8 lanes of tail rank r are springs of the vertex in lane slot
  // tailSlot[r] (0–15), padded like the blocks' ranks (far end the vertex itself,
  // k = rest = 0). They add to that vertex's sum after its block's ranks.
  const std::uint32_t* tailStart = nullptr;
  const std::uint8_t* tailSlot = nullptr;
  const std::uint8_t *slotVertex = nullptr, *vertexSlot = nullptr;  // kGroup per group
  double* f4 = nullptr;
  const std::uint8_t* extra = nullptr;  // per group: f4 holds forces for it
  std::size_t n = 0;                    // vertices
  std::size_t g0 = 0, g1 = 0;           // groups to step
  std::size_t groups = 0;               // groups in the mesh (the prefetch's bound; 0: g1)
  double dt = 0, damp = 1, homeK = 0;
  double springK = 0;  // K of the shared-K layout (rankRest null)
  bool rsqrt = false;  // Factor::Rsqrt (vector paths; the scalar path divides)
  // The monitor's sums: off, only Σ|v1|² and the home sum are taken (enough to see a
  // non-finite step); pe, kv2, ke1, work and maxComp2 stay 0 and `stiffness` is not
  // read (a step without the monitor needs none of them).
  bool energy = true;
  double g[3] = {0, 0, 0};
  // With the monitor's sums: per group, the largest squared velocity component times
  // moveScale2 (dt² and room for roundings: a squared bound on the group's vertices'
  // moves per coordinate), at groupMove2[grp]. Null: not taken.
  double* groupMove2 = nullptr;
  double moveScale2 = 0;
  // With groupMove2: each bound's square root plus travelPad is added to travel[grp];
  // a group whose sum is then not <= travelLimit goes onto *past. Null: not summed.
  double* travel = nullptr;
  double travelLimit = 0, travelPad = 0;
  std::vector<std::uint32_t>* past = nullptr;
};
// Raw sums for the stability monitor (accumulated): Σ m|v1|², Σ_live |x1 − home|²,
// Σ |v1|², Σ (ext + m·g)·(x1 − x0), the largest squared velocity component (3 × it
// bounds the largest |v1|²), Σ stiffness·|v1|² (bounds the spring energy change), and
// Σ k (l − rest)² over the ranks at x0 (four times the spring energy; in the shared-K
// layout Σ (k·l² − 2K·l) over the lanes with k ≠ 0: add K·Σ rest for the same sum).
struct FinishSums {
  double ke1 = 0, home1 = 0, v2 = 0, work = 0, maxComp2 = 0, kv2 = 0, pe = 0;
};
void blockStep(Kernel kern, const BlockStep& c, FinishSums& s);

}  // namespace ld::physics::detail
