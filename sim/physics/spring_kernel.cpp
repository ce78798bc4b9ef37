#include "sim/physics/spring_kernel.h"

#include <algorithm>
#include <atomic>
#include <cmath>

#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#if defined(__GNUC__) && !defined(__clang__)
// GCC 12's intrinsic headers self-initialise "undefined" vectors (gather, permute),
// which -Wuninitialized reports at every inlined use; the warning is about the header.
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include <immintrin.h>
#define LD_X86_KERNELS 1
// Built for these ISAs whatever the compile flags (no -march): chosen at run time.
#define LD_AVX2 __attribute__((target("avx2,fma")))
#define LD_AVX512 __attribute__((target("avx512f,avx512vl,avx2,fma")))
#endif

namespace ld::physics::detail {

// ---- portable reference ------------------------------------------------------

namespace {

// A group's squared move bound, and (when summed) its travel and the list of the groups
// past the limit (`!(t <= limit)`: a NaN is listed). Rounding of the sum is covered by
// the caller's travelPad, many ulps of the coordinates.
[[gnu::noinline, gnu::cold]] void listGroup(const BlockStep& c, std::size_t grp) {
  c.past->push_back(static_cast<std::uint32_t>(grp));
}
inline void recordGroupMove(const BlockStep& c, std::size_t grp, double bound2) {
  c.groupMove2[grp] = bound2;
  if (c.travel == nullptr) return;
  const double t = c.travel[grp] + (std::sqrt(bound2) + c.travelPad);
  c.travel[grp] = t;
  if (!(t <= c.travelLimit)) listGroup(c, grp);  // (out of line: a few groups a step)
}

// Large meshes: the vertex arrays of the group kAhead groups ahead are prefetched
// (six read streams besides the ranks' three; software prefetch measured 15-20 %
// faster at 100k triangles under load, 4-10 % slower where the data sits in L2/L3,
// hence only from kPrefetchFrom vertices on). Prefetching changes no result.
// Always inlined: GCC takes a function that only prefetches for pure and drops its calls.
constexpr std::size_t kAhead = 4;
#if defined(__GNUC__) || defined(__clang__)
__attribute__((always_inline)) inline void prefetchGroup(const BlockStep& c, std::size_t grp) {
  if (c.n < kPrefetchFrom || grp + kAhead >= (c.groups ? c.groups : c.g1)) return;
  const std::size_t t = kGroup * (grp + kAhead);
  for (const double* a : {c.x0, c.v0, c.home, c.ext})
    for (std::size_t o = 0; o < 3 * kGroup; o += 8) __builtin_prefetch(a + 3 * t + o);
  for (std::size_t o = 0; o < kGroup; o += 8) __builtin_prefetch(c.mass + t + o);
  if (c.energy)  // the stiffness is unread without the energy
    for (std::size_t o = 0; o < kGroup; o += 8) __builtin_prefetch(c.stiffness + t + o);
}
#else
inline void prefetchGroup(const BlockStep&, std::size_t) {}
#endif

double springForcesScalar(const SpringChunk& c) {
  double pe = 0.0;
  for (std::size_t t = 0; t < c.m; ++t) {
    const std::size_t i = c.lo[t], j = c.oth[t];
    const double* xi = c.x + 3 * i;
    const double* xj = c.x + 3 * j;
    const double dx = xj[0] - xi[0], dy = xj[1] - xi[1], dz = xj[2] - xi[2];
    const double l = std::sqrt(dx * dx + dy * dy + dz * dz);
    const double st = l - c.rest[t];
    const double kst = c.k[t] * st;
    pe += kst * st;
    const double q = l > 0.0 ? kst / l : 0.0;
    const double gx = q * dx, gy = q * dy, gz = q * dz;
    if (c.addLower) {
      double* o = c.f4 + 4 * i;
      o[0] += gx;
      o[1] += gy;
      o[2] += gz;
    }
    if (j < c.writeLimit) {
      double* fj = c.f4 + 4 * j;
      fj[0] -= gx;
      fj[1] -= gy;
      fj[2] -= gz;
    }
  }
  return pe;
}

// One vertex's integration and its share of the monitor's sums (f: its total spring force).
struct ScalarSums {
  double ke1 = 0, home1 = 0, v2 = 0, work = 0, maxc = 0, kv2 = 0;
};
template <bool Energy>
inline void integrateScalar(const BlockStep& c, std::size_t t, const double* f, ScalarSums& s) {
  const double m = c.mass[t], kt = Energy ? c.stiffness[t] : 0.0;
  const double im = m > 0.0 ? 1.0 / m : 0.0;  // as the cache's 1/mass, one stream fewer
  const bool live = im != 0.0;
  for (std::size_t a = 0; a < 3; ++a) {
    const std::size_t b = 3 * t + a;
    const double h = c.x0[b] - c.home[b];
    const double acc = (f[a] + c.ext[b]) - c.homeK * h;
    const double u = live ? c.damp * c.v0[b] + c.dt * (im * acc + c.g[a]) : 0.0;
    const double e = c.dt * u;
    const double p = c.x0[b] + e;
    c.v1[b] = u;
    c.x1[b] = p;
    const double uu = u * u;
    if constexpr (Energy) s.ke1 += m * uu;
    if constexpr (Energy) s.kv2 += kt * uu;
    s.v2 += uu;
    if constexpr (Energy) {
      s.maxc = std::max(s.maxc, uu);
      s.work += (c.ext[b] + m * c.g[a]) * e;
    }
    if (live) s.home1 += (p - c.home[b]) * (p - c.home[b]);
  }
}

// One spring of a lane (far end at x0 + J, k, rest; the lane's vertex at x, y, z)
// into its force sum and energy. Shared: the shared-K lane layout.
template <bool Shared, bool Energy>
inline void springTerm(const BlockStep& c, std::uint32_t J, double K, const double* rest, double x, double y, double z,
                       double& fx, double& fy, double& fz, double& pe) {
  const double* xj = c.x0 + J;
  const double dx = xj[0] - x, dy = xj[1] - y, dz = xj[2] - z;
  const double l2 = dx * dx + dy * dy + dz * dz;
  const double len = std::sqrt(l2);
  double w;
  if constexpr (Shared) {
    // (k·l − K)/l; k = 0 (padding, dead springs) gives nothing.
    const bool on = K != 0.0 && len > 0.0;
    if constexpr (Energy) pe += K * l2 - (on ? 2.0 * c.springK * len : 0.0);
    w = on ? (K * len - c.springK) / len : 0.0;
  } else {
    const double st = len - *rest;
    const double kst = K * st;
    if constexpr (Energy) pe += kst * st;
    w = len > 0.0 ? kst / len : 0.0;
  }
  fx += w * dx;
  fy += w * dy;
  fz += w * dz;
}

// A block's 8 lanes side by side, rank by rank (per lane the same operations in the
// same order as one vertex at a time): the rank's arrays are read once, not once a
// lane (~15 % faster than a vertex at a time); then the tail ranks of its lanes, in
// order (the same sums as a block padded to its largest degree, bit for bit). Shared:
// the shared-K lane layout.
template <bool Shared, bool Energy>
void blockStepScalar(const BlockStep& c, FinishSums& out) {
  ScalarSums s;
  double pe[kLanes] = {};
  const bool groupMoves = Energy && c.groupMove2 != nullptr;
  for (std::size_t grp = c.g0; grp < c.g1; ++grp) {
    prefetchGroup(c, grp);
    const std::size_t t = kGroup * grp;
    const double before = s.maxc;  // (max is exact: the total is the same either way)
    if (groupMoves) s.maxc = 0.0;
    for (std::size_t h = 0; h < 2; ++h) {
      const std::size_t blk = 2 * grp + h;
      double xs[kLanes], ys[kLanes], zs[kLanes], fx[kLanes] = {}, fy[kLanes] = {}, fz[kLanes] = {};
      for (std::size_t lane = 0; lane < kLanes; ++lane) {
        const std::size_t v = t + c.slotVertex[t + kLanes * h + lane], i = v < c.n ? v : t;
        xs[lane] = c.x0[3 * i];
        ys[lane] = c.x0[3 * i + 1];
        zs[lane] = c.x0[3 * i + 2];
      }
      for (std::size_t r = c.rankStart[blk]; r < c.rankStart[blk + 1]; ++r)
        for (std::size_t lane = 0; lane < kLanes; ++lane) {
          const std::size_t q = kLanes * r + lane;
          springTerm<Shared, Energy>(c, c.rankX[q], c.rankK[q], Shared ? nullptr : c.rankRest + q, xs[lane], ys[lane],
                                     zs[lane], fx[lane], fy[lane], fz[lane], pe[lane]);
        }
      for (std::size_t r = c.tailStart[grp]; r < c.tailStart[grp + 1]; ++r) {
        const std::size_t slot = c.tailSlot[r];
        if (slot / kLanes != h) continue;
        const std::size_t lane = slot % kLanes;
        for (std::size_t u = 0; u < kLanes; ++u) {
          const std::size_t q = kLanes * r + u;
          springTerm<Shared, Energy>(c, c.rankX[q], c.rankK[q], Shared ? nullptr : c.rankRest + q, xs[lane], ys[lane],
                                     zs[lane], fx[lane], fy[lane], fz[lane], pe[lane]);
        }
      }
      for (std::size_t lane = 0; lane < kLanes; ++lane) {
        const std::size_t i = t + c.slotVertex[t + kLanes * h + lane];
        if (i >= c.n) continue;
        double f[3] = {fx[lane], fy[lane], fz[lane]};
        if (c.extra[grp]) {
          double* fa = c.f4 + 4 * i;
          for (int a = 0; a < 3; ++a) f[a] += fa[a];
          std::fill_n(fa, 4, 0.0);
        }
        integrateScalar<Energy>(c, i, f, s);
      }
    }
    if (groupMoves) {
      recordGroupMove(c, grp, s.maxc * c.moveScale2);
      s.maxc = std::max(before, s.maxc);
    }
  }
  for (double p : pe) out.pe += p;
  out.ke1 += s.ke1;
  out.home1 += s.home1;
  out.v2 += s.v2;
  out.work += s.work;
  out.maxComp2 = std::max(out.maxComp2, s.maxc);
  out.kv2 += s.kv2;
}

// ---- AVX2 + FMA: 4 lanes ------------------------------------------------------

#ifdef LD_X86_KERNELS

LD_AVX2 inline double hsum(__m256d v) {
  const __m128d s = _mm_add_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd(v, 1));
  return _mm_cvtsd_f64(_mm_add_sd(s, _mm_unpackhi_pd(s, s)));
}
LD_AVX2 inline double hmax(__m256d v) {
  const __m128d s = _mm_max_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd(v, 1));
  return _mm_cvtsd_f64(_mm_max_sd(s, _mm_unpackhi_pd(s, s)));
}

// Four (x, y, z, ·) vectors transposed to x, y and z registers (loads and shuffles
// rather than gathers, which are slow on many CPUs).
LD_AVX2 inline void transpose4(const __m256d* d, __m256d* xyz) {
  const __m256d t0 = _mm256_unpacklo_pd(d[0], d[1]), t1 = _mm256_unpackhi_pd(d[0], d[1]);
  const __m256d t2 = _mm256_unpacklo_pd(d[2], d[3]), t3 = _mm256_unpackhi_pd(d[2], d[3]);
  xyz[0] = _mm256_permute2f128_pd(t0, t2, 0x20);
  xyz[1] = _mm256_permute2f128_pd(t1, t3, 0x20);
  xyz[2] = _mm256_permute2f128_pd(t0, t2, 0x31);
}

// 1/√l2 without the divider: a bit-trick estimate (the exponent halved and negated by
// an integer subtraction from a magic constant, ~3.4 % off, AVX2 has no rsqrt for
// doubles) and Steps Newton steps y ← y + y·(1/2 − (l²/2)·y·y) (the error e becomes
// 1.5e²: 4 steps from ~5 bits to about 1 ulp). Finite for l² = 0 (masked by the callers).
template <int Steps>
LD_AVX2 inline __m256d invSqrt4(__m256d l2) {
  const __m256i magic = _mm256_set1_epi64x(0x5FE6EB50C7B537A9LL);
  __m256d y = _mm256_castsi256_pd(_mm256_sub_epi64(magic, _mm256_srli_epi64(_mm256_castpd_si256(l2), 1)));
  const __m256d h = _mm256_mul_pd(l2, _mm256_set1_pd(0.5)), half = _mm256_set1_pd(0.5);
  for (int s = 0; s < Steps; ++s) y = _mm256_fmadd_pd(y, _mm256_fnmadd_pd(_mm256_mul_pd(h, y), y, half), y);
  return y;
}
constexpr int kNewtonAvx2 = 4;

// k(l − rest)/l of four springs with difference vectors d (x, y, z registers), 0 where
// l = 0; adds k(l − rest)² to pe. Rsqrt: k·(1 − rest·(1/l)) with 1/l from invSqrt4
// (the same factor with and without the energy: it does not use l).
template <bool Energy = true, bool Rsqrt = false>
LD_AVX2 inline __m256d springWeights4(const __m256d* d, __m256d rest, __m256d k, __m256d& pe) {
  const __m256d l2 = _mm256_fmadd_pd(d[2], d[2], _mm256_fmadd_pd(d[1], d[1], _mm256_mul_pd(d[0], d[0])));
  if constexpr (Rsqrt) {
    const __m256d y = invSqrt4<kNewtonAvx2>(l2);
    const __m256d pos = _mm256_cmp_pd(l2, _mm256_setzero_pd(), _CMP_GT_OQ);
    if constexpr (Energy) {
      const __m256d st = _mm256_sub_pd(_mm256_mul_pd(l2, y), rest);  // y is finite at l² = 0
      pe = _mm256_fmadd_pd(_mm256_mul_pd(k, st), st, pe);
    }
    return _mm256_and_pd(_mm256_mul_pd(k, _mm256_fnmadd_pd(rest, y, _mm256_set1_pd(1.0))), pos);
  }
  const __m256d l = _mm256_sqrt_pd(l2);
  const __m256d st = _mm256_sub_pd(l, rest);
  const __m256d kst = _mm256_mul_pd(k, st);
  if constexpr (Energy) pe = _mm256_fmadd_pd(kst, st, pe);
  return _mm256_and_pd(_mm256_div_pd(kst, l), _mm256_cmp_pd(l, _mm256_setzero_pd(), _CMP_GT_OQ));
}

// The same in the shared-K layout: (k·l − K)/l, 0 where k = 0 or l = 0; adds
// k·l² − 2K·l (where k ≠ 0) to pe. sharedK = K, twoK = 2K in every lane. Rsqrt:
// k − K·(1/l), l = l²·(1/l) for the energy.
template <bool Energy, bool Rsqrt = false>
LD_AVX2 inline __m256d sharedWeights4(const __m256d* d, __m256d k, __m256d sharedK, __m256d twoK, __m256d& pe) {
  const __m256d l2 = _mm256_fmadd_pd(d[2], d[2], _mm256_fmadd_pd(d[1], d[1], _mm256_mul_pd(d[0], d[0])));
  const __m256d zero = _mm256_setzero_pd();
  if constexpr (Rsqrt) {
    const __m256d y = invSqrt4<kNewtonAvx2>(l2);
    const __m256d on = _mm256_and_pd(_mm256_cmp_pd(l2, zero, _CMP_GT_OQ), _mm256_cmp_pd(k, zero, _CMP_NEQ_UQ));
    if constexpr (Energy)
      pe = _mm256_fnmadd_pd(_mm256_and_pd(on, twoK), _mm256_mul_pd(l2, y), _mm256_fmadd_pd(k, l2, pe));
    return _mm256_and_pd(_mm256_fnmadd_pd(sharedK, y, k), on);
  }
  const __m256d l = _mm256_sqrt_pd(l2);
  const __m256d on = _mm256_and_pd(_mm256_cmp_pd(l, zero, _CMP_GT_OQ), _mm256_cmp_pd(k, zero, _CMP_NEQ_UQ));
  if constexpr (Energy) pe = _mm256_fnmadd_pd(_mm256_and_pd(on, twoK), l, _mm256_fmadd_pd(k, l2, pe));
  return _mm256_and_pd(_mm256_div_pd(_mm256_fmsub_pd(k, l, sharedK), l), on);
}

// One spring's force (x, y, z, 0) into its lower vertex's sum and out of its far end.
LD_AVX2 inline void applySpring(const SpringChunk& c, std::size_t a, __m256d g) {
  if (c.addLower) {
    double* o = c.f4 + 4 * std::size_t{c.lo[a]};
    _mm256_storeu_pd(o, _mm256_add_pd(_mm256_loadu_pd(o), g));
  }
  if (c.oth[a] < c.writeLimit) {
    double* fj = c.f4 + 4 * std::size_t{c.oth[a]};
    _mm256_storeu_pd(fj, _mm256_sub_pd(_mm256_loadu_pd(fj), g));
  }
}

LD_AVX2 double springForcesAvx2(const SpringChunk& c) {
  const __m256d zero = _mm256_setzero_pd();
  const __m256i lanes = _mm256_setr_epi64x(0, 1, 2, 3);
  const __m256i xyz = _mm256_setr_epi64x(-1, -1, -1, 0);
  __m256d pe = zero;
  for (std::size_t t = 0; t < c.m; t += 4) {
    // Lanes past m repeat the last spring; rest and k load as 0 there, nothing stored.
    const std::size_t cnt = std::min<std::size_t>(4, c.m - t);
    const __m256i mask = _mm256_cmpgt_epi64(_mm256_set1_epi64x(static_cast<long long>(cnt)), lanes);
    // Difference vectors (x, y, z, 0) of 4 springs.
    __m256d d[4], dxyz[3];
    for (std::size_t u = 0; u < 4; ++u) {
      const std::size_t a = t + std::min(u, cnt - 1);
      d[u] = _mm256_sub_pd(_mm256_maskload_pd(c.x + 3 * std::size_t{c.oth[a]}, xyz),
                           _mm256_maskload_pd(c.x + 3 * std::size_t{c.lo[a]}, xyz));
    }
    transpose4(d, dxyz);
    const __m256d q = springWeights4(dxyz, _mm256_maskload_pd(c.rest + t, mask), _mm256_maskload_pd(c.k + t, mask), pe);
    alignas(32) double qs[4];
    _mm256_store_pd(qs, q);
    for (std::size_t u = 0; u < cnt; ++u) applySpring(c, t + u, _mm256_mul_pd(_mm256_set1_pd(qs[u]), d[u]));
  }
  return hsum(pe);
}

struct Acc2 {
  __m256d ke, home, v2, work, maxc, kv2;
};

// Four vertices (12 doubles, 3 registers) from arrays that hold all of them; the
// forces fa (x, y, z, 0 a vertex) regrouped to 3 a vertex.
template <bool Energy>
LD_AVX2 inline void finish4(const BlockStep& c, const __m256d* fa, const double* x0, const double* v0,
                            const double* home, const double* ext, const double* mass, const double* stiff, double* x1,
                            double* v1, const __m256d* grav, Acc2& acc) {
  const __m256d zero = _mm256_setzero_pd();
  const __m256d dt = _mm256_set1_pd(c.dt), damp = _mm256_set1_pd(c.damp), homeK = _mm256_set1_pd(c.homeK);
  const __m256d F[3] = {_mm256_blend_pd(fa[0], _mm256_permute4x64_pd(fa[1], 0x00), 0x8),
                        _mm256_blend_pd(_mm256_permute4x64_pd(fa[1], 0x09), _mm256_permute4x64_pd(fa[2], 0x40), 0xC),
                        _mm256_blend_pd(_mm256_permute4x64_pd(fa[3], 0x90), _mm256_permute4x64_pd(fa[2], 0x02), 0x1)};
  const __m256d mv = _mm256_loadu_pd(mass);
  // 1/mass (0 where mass ≤ 0), rounded as the cache's: one stream fewer to read.
  const __m256d imv = _mm256_and_pd(_mm256_div_pd(_mm256_set1_pd(1.0), mv), _mm256_cmp_pd(mv, zero, _CMP_GT_OQ));
  const __m256d im3[3] = {_mm256_permute4x64_pd(imv, 0x40), _mm256_permute4x64_pd(imv, 0xA5),
                          _mm256_permute4x64_pd(imv, 0xFE)};
  const __m256d m3[3] = {_mm256_permute4x64_pd(mv, 0x40), _mm256_permute4x64_pd(mv, 0xA5),
                         _mm256_permute4x64_pd(mv, 0xFE)};
  const __m256d kv = Energy ? _mm256_loadu_pd(stiff) : zero;
  const __m256d k3[3] = {_mm256_permute4x64_pd(kv, 0x40), _mm256_permute4x64_pd(kv, 0xA5),
                         _mm256_permute4x64_pd(kv, 0xFE)};
  for (int r = 0; r < 3; ++r) {
    const __m256d live = _mm256_cmp_pd(im3[r], zero, _CMP_NEQ_OQ);
    const __m256d X = _mm256_loadu_pd(x0 + 4 * r), H = _mm256_loadu_pd(home + 4 * r);
    const __m256d E = _mm256_loadu_pd(ext + 4 * r);
    const __m256d a = _mm256_fnmadd_pd(homeK, _mm256_sub_pd(X, H), _mm256_add_pd(F[r], E));
    const __m256d u = _mm256_and_pd(live, _mm256_fmadd_pd(damp, _mm256_loadu_pd(v0 + 4 * r),
                                                          _mm256_mul_pd(dt, _mm256_fmadd_pd(im3[r], a, grav[r]))));
    // x1 as one fused operation: GCC contracts dt·u + x0 where dt·u has no other use
    // (intrinsics are vector arithmetic to it), so spelling it out keeps the builds
    // with and without the monitor's sums (which use dt·u) bit-identical.
    const __m256d e = _mm256_mul_pd(dt, u);
    const __m256d p = _mm256_fmadd_pd(dt, u, X);
    _mm256_storeu_pd(v1 + 4 * r, u);
    _mm256_storeu_pd(x1 + 4 * r, p);
    const __m256d uu = _mm256_mul_pd(u, u);
    if constexpr (Energy) acc.ke = _mm256_fmadd_pd(m3[r], uu, acc.ke);
    if constexpr (Energy) acc.kv2 = _mm256_fmadd_pd(k3[r], uu, acc.kv2);
    acc.v2 = _mm256_add_pd(acc.v2, uu);
    if constexpr (Energy) {
      acc.maxc = _mm256_max_pd(acc.maxc, uu);
      acc.work = _mm256_fmadd_pd(_mm256_fmadd_pd(m3[r], grav[r], E), e, acc.work);
    }
    const __m256d qh = _mm256_and_pd(live, _mm256_sub_pd(p, H));
    acc.home = _mm256_fmadd_pd(qh, qh, acc.home);
  }
}

// Lanes q0 … q0 + 3 of one rank (their vertices' positions xi, (x, y, z, 0) a lane):
// difference vectors dxyz and force factors (returned).
template <bool Shared, bool Energy, bool Rsqrt>
LD_AVX2 inline __m256d terms4(const BlockStep& c, std::size_t q0, const __m256d* xi, __m256d* dxyz, __m256d& pe) {
  const __m256d sharedK = _mm256_set1_pd(c.springK), twoK = _mm256_set1_pd(2.0 * c.springK);
  const __m256i xyz = _mm256_setr_epi64x(-1, -1, -1, 0);
  const std::uint32_t* J = c.rankX + q0;
  __m256d d[4];
  for (std::size_t u = 0; u < 4; ++u) d[u] = _mm256_sub_pd(_mm256_maskload_pd(c.x0 + J[u], xyz), xi[u]);
  transpose4(d, dxyz);
  if constexpr (Shared)
    return sharedWeights4<Energy, Rsqrt>(dxyz, _mm256_loadu_pd(c.rankK + q0), sharedK, twoK, pe);
  else
    return springWeights4<Energy, Rsqrt>(dxyz, _mm256_loadu_pd(c.rankRest + q0), _mm256_loadu_pd(c.rankK + q0), pe);
}

// Four lanes (h … h + 3 of block blk) whose vertices' positions start at xiAt[u]: their
// springs, rank by rank, summed in registers, returned as (x, y, z, 0) a lane.
template <bool Shared, bool Energy, bool Rsqrt>
LD_AVX2 inline void springs4(const BlockStep& c, std::size_t blk, std::size_t h, const double* const* xiAt, __m256d* fa,
                             __m256d& pe) {
  const __m256d zero = _mm256_setzero_pd();
  const __m256i xyz = _mm256_setr_epi64x(-1, -1, -1, 0);
  __m256d xi[4];
  for (std::size_t u = 0; u < 4; ++u) xi[u] = _mm256_maskload_pd(xiAt[u], xyz);
  __m256d fx = zero, fy = zero, fz = zero;
  for (std::size_t r = c.rankStart[blk]; r < c.rankStart[blk + 1]; ++r) {
    __m256d dxyz[3];
    const __m256d w = terms4<Shared, Energy, Rsqrt>(c, kLanes * r + h, xi, dxyz, pe);
    fx = _mm256_fmadd_pd(w, dxyz[0], fx);
    fy = _mm256_fmadd_pd(w, dxyz[1], fy);
    fz = _mm256_fmadd_pd(w, dxyz[2], fz);
  }
  const __m256d t0 = _mm256_unpacklo_pd(fx, fy), t1 = _mm256_unpackhi_pd(fx, fy);
  const __m256d t2 = _mm256_unpacklo_pd(fz, zero), t3 = _mm256_unpackhi_pd(fz, zero);
  fa[0] = _mm256_permute2f128_pd(t0, t2, 0x20);
  fa[1] = _mm256_permute2f128_pd(t1, t3, 0x20);
  fa[2] = _mm256_permute2f128_pd(t0, t2, 0x31);
  fa[3] = _mm256_permute2f128_pd(t1, t3, 0x31);
}

// The group's tail ranks into its vertices' forces fv (vertex order, (x, y, z, 0)): 4
// lanes of a rank side by side, then added to the vertex's sum one after the other
// with the same fused steps as the blocks' ranks (bit for bit a block padded to its
// degree; the energy's rounding differs).
template <bool Shared, bool Energy, bool Rsqrt>
LD_AVX2 inline void tails4(const BlockStep& c, std::size_t grp, __m256d* fv, __m256d& pe) {
  const __m256i xyz = _mm256_setr_epi64x(-1, -1, -1, 0);
  const std::size_t t = kGroup * grp;
  for (std::uint32_t r = c.tailStart[grp], end = c.tailStart[grp + 1]; r < end;) {
    const std::uint8_t slot = c.tailSlot[r];
    const std::size_t v = c.slotVertex[t + slot];
    const __m256d x = _mm256_maskload_pd(c.x0 + 3 * (t + v), xyz);
    const __m256d xi[4] = {x, x, x, x};
    alignas(32) double sum[4], w[4], d[3][4];
    _mm256_store_pd(sum, fv[v]);
    for (; r < end && c.tailSlot[r] == slot; ++r)
      for (std::size_t h = 0; h < kLanes; h += 4) {
        __m256d dxyz[3];
        _mm256_store_pd(w, terms4<Shared, Energy, Rsqrt>(c, kLanes * r + h, xi, dxyz, pe));
        for (int a = 0; a < 3; ++a) _mm256_store_pd(d[a], dxyz[a]);
        for (std::size_t u = 0; u < 4; ++u)
          for (int a = 0; a < 3; ++a) sum[a] = std::fma(w[u], d[a][u], sum[a]);
      }
    fv[v] = _mm256_load_pd(sum);
  }
}

template <bool Shared, bool Energy, bool Rsqrt>
LD_AVX2 void blockStepAvx2(const BlockStep& c, FinishSums& s) {
  const __m256d zero = _mm256_setzero_pd();
  Acc2 acc{zero, zero, zero, zero, zero, zero};
  __m256d pe = zero;
  const __m256d grav[3] = {_mm256_setr_pd(c.g[0], c.g[1], c.g[2], c.g[0]),
                           _mm256_setr_pd(c.g[1], c.g[2], c.g[0], c.g[1]),
                           _mm256_setr_pd(c.g[2], c.g[0], c.g[1], c.g[2])};
  const bool groupMoves = Energy && c.groupMove2 != nullptr;
  for (std::size_t grp = c.g0; grp < c.g1; ++grp) {
    prefetchGroup(c, grp);
    const std::size_t t = kGroup * grp, rem = std::min(kGroup, c.n - t);
    const __m256d before = acc.maxc;
    if (groupMoves) acc.maxc = zero;
    // Forces a vertex of the group (lanes put back in vertex order).
    __m256d fv[kGroup];
    for (std::size_t q = 0; q < kGroup; q += 4) {
      const double* xiAt[4];
      std::size_t v[4];
      for (std::size_t u = 0; u < 4; ++u) {
        v[u] = c.slotVertex[t + q + u];
        xiAt[u] = c.x0 + 3 * (v[u] < rem ? t + v[u] : t);  // lanes past n: the group's first vertex
      }
      __m256d fa[4];
      springs4<Shared, Energy, Rsqrt>(c, 2 * grp + q / kLanes, q % kLanes, xiAt, fa, pe);
      for (std::size_t u = 0; u < 4; ++u) fv[v[u]] = fa[u];
    }
    tails4<Shared, Energy, Rsqrt>(c, grp, fv, pe);
    if (c.extra[grp])
      for (std::size_t u = 0; u < rem; ++u) {
        double* f4 = c.f4 + 4 * (t + u);
        fv[u] = _mm256_add_pd(fv[u], _mm256_loadu_pd(f4));
        _mm256_storeu_pd(f4, zero);
      }
    for (std::size_t q = 0; q < rem; q += 4) {
      const std::size_t t4 = t + q, rem4 = std::min<std::size_t>(4, rem - q), b = 3 * t4;
      if (rem4 == 4) {
        finish4<Energy>(c, fv + q, c.x0 + b, c.v0 + b, c.home + b, c.ext + b, c.mass + t4, c.stiffness + t4, c.x1 + b,
                        c.v1 + b, grav, acc);
        continue;
      }
      // The last 1–3 vertices through the same lanes, padded with massless zeros.
      double buf[6][12] = {}, mass[4] = {}, stiff[4] = {};
      const double* src[4] = {c.x0 + b, c.v0 + b, c.home + b, c.ext + b};
      for (int a = 0; a < 4; ++a) std::copy(src[a], src[a] + 3 * rem4, buf[a]);
      for (std::size_t u = rem4; u < 4; ++u) fv[q + u] = zero;
      std::copy(c.mass + t4, c.mass + t4 + rem4, mass);
      if constexpr (Energy) std::copy(c.stiffness + t4, c.stiffness + t4 + rem4, stiff);
      finish4<Energy>(c, fv + q, buf[0], buf[1], buf[2], buf[3], mass, stiff, buf[4], buf[5], grav, acc);
      std::copy(buf[4], buf[4] + 3 * rem4, c.x1 + b);
      std::copy(buf[5], buf[5] + 3 * rem4, c.v1 + b);
    }
    if (groupMoves) {
      recordGroupMove(c, grp, hmax(acc.maxc) * c.moveScale2);
      acc.maxc = _mm256_max_pd(acc.maxc, before);
    }
  }
  s.ke1 += hsum(acc.ke);
  s.home1 += hsum(acc.home);
  s.v2 += hsum(acc.v2);
  s.work += hsum(acc.work);
  s.maxComp2 = std::max(s.maxComp2, hmax(acc.maxc));
  s.kv2 += hsum(acc.kv2);
  s.pe += hsum(pe);
}

// ---- AVX-512: 8 lanes, masked tails ----------------------------------------------

// Eight (x, y, z, ·) vectors transposed to x, y and z registers: 11 shuffles (with
// 16 three-lane loads, that beats 3 gathers, ~12 cycles each here).
LD_AVX512 inline void transpose8(const __m256d* d, __m512d* xyz) {
  const __m512i xy = _mm512_setr_epi64(0, 4, 8, 12, 1, 5, 9, 13), zz = _mm512_setr_epi64(2, 6, 10, 14, 2, 6, 10, 14);
  __m512d p[4];
  for (int u = 0; u < 4; ++u) p[u] = _mm512_insertf64x4(_mm512_castpd256_pd512(d[2 * u]), d[2 * u + 1], 1);
  const __m512d xyLo = _mm512_permutex2var_pd(p[0], xy, p[1]), xyHi = _mm512_permutex2var_pd(p[2], xy, p[3]);
  const __m512d zLo = _mm512_permutex2var_pd(p[0], zz, p[1]), zHi = _mm512_permutex2var_pd(p[2], zz, p[3]);
  xyz[0] = _mm512_shuffle_f64x2(xyLo, xyHi, 0x44);
  xyz[1] = _mm512_shuffle_f64x2(xyLo, xyHi, 0xEE);
  xyz[2] = _mm512_shuffle_f64x2(zLo, zHi, 0x44);
}

// 1/√l2 without the divider: rsqrt14 (relative error < 2^-14) and Steps Newton steps
// y ← y + y·(1/2 − (l²/2)·y·y) (the error e becomes 1.5e²: 2 steps give about 1 ulp;
// written as a correction to y, the last rounding is y's own). rsqrt14(0) = ∞: the
// callers mask l² = 0.
template <int Steps>
LD_AVX512 inline __m512d invSqrt8(__m512d l2) {
  const __m512d h = _mm512_mul_pd(l2, _mm512_set1_pd(0.5)), half = _mm512_set1_pd(0.5);
  __m512d y = _mm512_rsqrt14_pd(l2);
  for (int s = 0; s < Steps; ++s) y = _mm512_fmadd_pd(y, _mm512_fnmadd_pd(_mm512_mul_pd(h, y), y, half), y);
  return y;
}
constexpr int kNewtonAvx512 = 2;

// k(l − rest)/l of eight springs with difference vectors d (x, y, z registers), 0
// where l = 0; adds k(l − rest)² to pe. Rsqrt: k·(1 − rest·(1/l)), 1/l from invSqrt8
// (on this Intel core sqrt and div share one divider, ~28 cycles a rank; on a Zen 5
// they measured faster than rsqrt14 and Newton). Otherwise sqrt and div, rounded as
// the scalar path is.
template <bool Energy = true, bool Rsqrt = false>
LD_AVX512 inline __m512d springWeights8(const __m512d* d, __m512d rest, __m512d k, __m512d& pe) {
  const __m512d l2 = _mm512_fmadd_pd(d[2], d[2], _mm512_fmadd_pd(d[1], d[1], _mm512_mul_pd(d[0], d[0])));
  const __mmask8 pos = _mm512_cmp_pd_mask(l2, _mm512_setzero_pd(), _CMP_GT_OQ);
  if constexpr (Rsqrt) {
    const __m512d y = invSqrt8<kNewtonAvx512>(l2);
    const __m512d g = _mm512_fnmadd_pd(rest, y, _mm512_set1_pd(1.0));  // 1 − rest/l
    const __m512d w = _mm512_maskz_mul_pd(pos, k, g);
    // k(l − rest)² = l²·(1 − rest/l)·w (0 where l = 0: g is not finite there).
    if constexpr (Energy) pe = _mm512_fmadd_pd(_mm512_maskz_mul_pd(pos, l2, g), w, pe);
    return w;
  }
  const __m512d l = _mm512_sqrt_pd(l2);
  const __m512d st = _mm512_sub_pd(l, rest);
  const __m512d kst = _mm512_mul_pd(k, st);
  if constexpr (Energy) pe = _mm512_fmadd_pd(kst, st, pe);
  return _mm512_maskz_div_pd(pos, kst, l);
}

// The same in the shared-K layout: (k·l − K)/l, 0 where k = 0 or l = 0; adds
// k·l² − 2K·l (where k ≠ 0) to pe. sharedK = K, twoK = 2K in every lane. Rsqrt:
// k − K·(1/l), l = l²·(1/l) for the energy.
template <bool Energy, bool Rsqrt = false>
LD_AVX512 inline __m512d sharedWeights8(const __m512d* d, __m512d k, __m512d sharedK, __m512d twoK, __m512d& pe) {
  const __m512d l2 = _mm512_fmadd_pd(d[2], d[2], _mm512_fmadd_pd(d[1], d[1], _mm512_mul_pd(d[0], d[0])));
  const __m512d zero = _mm512_setzero_pd();
  // Padding lanes and dead springs point at the lane's own vertex (l = 0), so l > 0
  // alone masks them (lanes past n, which point elsewhere, are never stored); the
  // energy needs k ≠ 0 too (those lanes' −2K·l would count).
  const __mmask8 pos = _mm512_cmp_pd_mask(l2, zero, _CMP_GT_OQ);
  const __mmask8 on = Energy ? __mmask8(pos & _mm512_cmp_pd_mask(k, zero, _CMP_NEQ_UQ)) : pos;
  if constexpr (Rsqrt) {
    const __m512d y = invSqrt8<kNewtonAvx512>(l2);
    // k·l² − 2K·l = l²·(k − 2K/l): two operations (0 where k = 0 or l = 0).
    if constexpr (Energy) pe = _mm512_fmadd_pd(l2, _mm512_maskz_fnmadd_pd(on, twoK, y, k), pe);
    return _mm512_maskz_fnmadd_pd(on, sharedK, y, k);
  }
  const __m512d l = _mm512_sqrt_pd(l2);
  if constexpr (Energy) pe = _mm512_mask3_fnmadd_pd(twoK, l, _mm512_fmadd_pd(k, l2, pe), on);
  return _mm512_maskz_div_pd(on, _mm512_fmsub_pd(k, l, sharedK), l);
}

LD_AVX512 double springForcesAvx512(const SpringChunk& c) {
  const __m512d zero = _mm512_setzero_pd();
  __m512d pe = zero;
  // The arrays of the other integrators are not padded: the three-lane loads must stay
  // masked (fault-suppressed). With a constant mask GCC 12 may turn them into plain
  // 4-double loads (reading 8 bytes past the array at the last vertex); a mask it
  // cannot see through keeps them masked.
  unsigned xyzBits = 0x7;
  asm("" : "+r"(xyzBits));
  const __mmask8 xyz = __mmask8(xyzBits);
  for (std::size_t t = 0; t < c.m; t += 8) {
    const std::size_t cnt = std::min<std::size_t>(8, c.m - t);
    const __mmask8 mk = __mmask8((1u << cnt) - 1u);
    // Difference vectors (x, y, z, 0) of the 8 springs; lanes past m repeat the last
    // spring (rest and k load as 0 there; not applied).
    __m256d d[8];
    for (std::size_t u = 0; u < 8; ++u) {
      const std::size_t a = t + std::min(u, cnt - 1);
      d[u] = _mm256_sub_pd(_mm256_maskz_loadu_pd(xyz, c.x + 3 * std::size_t{c.oth[a]}),
                           _mm256_maskz_loadu_pd(xyz, c.x + 3 * std::size_t{c.lo[a]}));
    }
    __m512d dxyz[3];
    transpose8(d, dxyz);
    const __m512d q =
        springWeights8(dxyz, _mm512_maskz_loadu_pd(mk, c.rest + t), _mm512_maskz_loadu_pd(mk, c.k + t), pe);
    alignas(64) double qs[8];
    _mm512_store_pd(qs, q);
    for (std::size_t u = 0; u < cnt; ++u) applySpring(c, t + u, _mm256_mul_pd(_mm256_set1_pd(qs[u]), d[u]));
  }
  return _mm512_reduce_add_pd(pe);
}

// Index tables between the flat layout of 8 vertices (3 registers: x0 y0 z0 x1 …)
// and one register an axis (lane = vertex): two-source permutes of the first two
// registers, then a masked permute from the third.
struct Regroup {
  alignas(64) long long toAxis[3][8], toAxisLast[3][8], toFlat[3][8], toFlatZ[3][8];
  __mmask8 axisLast[3], flatZ[3];
};
constexpr Regroup makeRegroup() {
  Regroup g{};
  for (int a = 0; a < 3; ++a)
    for (int v = 0; v < 8; ++v) {
      const int comp = 3 * v + a, reg = comp / 8, pos = comp % 8;
      g.toAxis[a][v] = reg < 2 ? pos + 8 * reg : 0;
      g.toAxisLast[a][v] = pos;
      if (reg == 2) g.axisLast[a] = __mmask8(g.axisLast[a] | (1u << v));
    }
  for (int r = 0; r < 3; ++r)
    for (int p = 0; p < 8; ++p) {
      const int comp = 8 * r + p, v = comp / 3, a = comp % 3;
      g.toFlat[r][p] = a < 2 ? v + 8 * a : 0;
      g.toFlatZ[r][p] = v;
      if (a == 2) g.flatZ[r] = __mmask8(g.flatZ[r] | (1u << p));
    }
  return g;
}
constexpr Regroup kRegroup = makeRegroup();

LD_AVX512 inline __m512i idx512(const long long* p) { return _mm512_load_si512(static_cast<const void*>(p)); }

struct Acc512 {
  __m512d ke, home, v2, work, maxc, kv2;
};

struct Consts512 {
  __m512d zero, dt, damp, homeK, grav[3], sharedK, twoK;
  __m512i spread[3], regroup[3], toAxis[3], toAxisLast[3], toFlat[3], toFlatZ[3];
};

// One block's springs (lanes at positions xi, one register an axis), rank by rank:
// far ends (x, y, z) by three-lane loads, transposed to axis registers (16 loads and
// shuffles beat gathers here), summed per lane in registers.
// One rank of 8 lanes (lane q of the ranks: far-end offsets, k and, per-spring
// layout, rest): terms8 gives its difference vectors dxyz and force factors (returned),
// rank8 adds them into the lanes' sums.
// The far ends are plain 4-double loads (x, y, z and the next vertex's x, which the
// transpose drops): 5-6 % faster than masked three-lane loads on a Zen 5 (GCC can fold
// the upper half into vinsertf64x4 from memory), and in bounds because every array the
// step reads positions from has one more double allocated past its last vertex
// (BlockStep::x0, padPositions in mass_spring.cpp).
template <bool Shared, bool Energy, bool Rsqrt>
LD_AVX512 inline __m512d terms8(const BlockStep& c, const Consts512& k, std::size_t q, const __m512d* xi, __m512d* dxyz,
                                __m512d& pe) {
  const std::uint32_t* J = c.rankX + q;
  __m256d d[8];
  for (std::size_t u = 0; u < 8; ++u) d[u] = _mm256_loadu_pd(c.x0 + J[u]);
  transpose8(d, dxyz);
  for (int a = 0; a < 3; ++a) dxyz[a] = _mm512_sub_pd(dxyz[a], xi[a]);
  if constexpr (Shared)
    return sharedWeights8<Energy, Rsqrt>(dxyz, _mm512_load_pd(c.rankK + q), k.sharedK, k.twoK, pe);
  else
    return springWeights8<Energy, Rsqrt>(dxyz, _mm512_load_pd(c.rankRest + q), _mm512_load_pd(c.rankK + q), pe);
}
template <bool Shared, bool Energy, bool Rsqrt>
LD_AVX512 inline void rank8(const BlockStep& c, const Consts512& k, std::size_t q, const __m512d* xi, __m512d* f,
                            __m512d& pe) {
  __m512d dxyz[3];
  const __m512d w = terms8<Shared, Energy, Rsqrt>(c, k, q, xi, dxyz, pe);
  for (int a = 0; a < 3; ++a) f[a] = _mm512_fmadd_pd(w, dxyz[a], f[a]);
}

// The group's two blocks (lanes at positions xi[h], one register an axis), rank by
// rank, both blocks in one loop while both have ranks (two independent chains of
// sqrt and div in flight), then the rest of the longer one; sums in registers.
template <bool Shared, bool Energy, bool Rsqrt>
LD_AVX512 inline void springs8x2(const BlockStep& c, const Consts512& k, std::size_t grp, const __m512d (*xi)[3],
                                 __m512d (*f)[3], __m512d& pe) {
  __m512d a[3] = {k.zero, k.zero, k.zero}, b[3] = {k.zero, k.zero, k.zero};
  __m512d ea = pe, eb = k.zero;
  const std::uint32_t r0 = c.rankStart[2 * grp], r1 = c.rankStart[2 * grp + 1], r2 = c.rankStart[2 * grp + 2];
  const std::size_t both = std::min(r1 - r0, r2 - r1);
  std::size_t qa = kLanes * r0, qb = kLanes * r1;
  for (std::size_t r = 0; r < both; ++r, qa += kLanes, qb += kLanes) {
    rank8<Shared, Energy, Rsqrt>(c, k, qa, xi[0], a, ea);
    rank8<Shared, Energy, Rsqrt>(c, k, qb, xi[1], b, eb);
  }
  for (; qa < kLanes * r1; qa += kLanes) rank8<Shared, Energy, Rsqrt>(c, k, qa, xi[0], a, ea);
  for (; qb < kLanes * r2; qb += kLanes) rank8<Shared, Energy, Rsqrt>(c, k, qb, xi[1], b, eb);
  for (int q = 0; q < 3; ++q) {
    f[0][q] = a[q];
    f[1][q] = b[q];
  }
  pe = _mm512_add_pd(ea, eb);
}

// The group's tail ranks into the blocks' lane sums f (slot order): the 8 lanes of a
// rank side by side (the vertex's position broadcast from xi), then added to its sum
// one after the other with the same fused steps as a block's ranks, so the force is
// bit for bit the one of a block padded to its degree. (The energy is summed 8 wide:
// its rounding differs.)
// The lane sums go to memory once a group (not once a vertex), so that one vertex's
// chain of fused steps does not wait for the previous vertex's through the register
// they share: the chains of a group's tail vertices overlap.
template <bool Shared, bool Energy, bool Rsqrt>
LD_AVX512 inline void tails8(const BlockStep& c, const Consts512& k, std::size_t grp, const __m512d (*xi)[3],
                             __m512d (*f)[3], __m512d& pe) {
  const std::uint32_t first = c.tailStart[grp], end = c.tailStart[grp + 1];
  if (first == end) return;
  alignas(64) double sum[2][3][8];
  for (int h = 0; h < 2; ++h)
    for (int a = 0; a < 3; ++a) _mm512_store_pd(sum[h][a], f[h][a]);
  for (std::uint32_t r = first; r < end;) {
    const std::uint8_t slot = c.tailSlot[r];
    const std::size_t h = slot / kLanes, lane = slot % kLanes;
    const __m512i at = _mm512_set1_epi64(static_cast<long long>(lane));
    __m512d xb[3];
    for (int a = 0; a < 3; ++a) xb[a] = _mm512_permutexvar_pd(at, xi[h][a]);
    double s[3] = {sum[h][0][lane], sum[h][1][lane], sum[h][2][lane]};
    for (; r < end && c.tailSlot[r] == slot; ++r) {
      alignas(64) double w[8], d[3][8];
      __m512d dxyz[3];
      _mm512_store_pd(w, terms8<Shared, Energy, Rsqrt>(c, k, kLanes * r, xb, dxyz, pe));
      for (int a = 0; a < 3; ++a) _mm512_store_pd(d[a], dxyz[a]);
      for (std::size_t u = 0; u < kLanes; ++u)
        for (int a = 0; a < 3; ++a) s[a] = std::fma(w[u], d[a][u], s[a]);
    }
    for (int a = 0; a < 3; ++a) sum[h][a][lane] = s[a];
  }
  for (int h = 0; h < 2; ++h)
    for (int a = 0; a < 3; ++a) f[h][a] = _mm512_load_pd(sum[h][a]);
}

// Integration of vertices t … t + rem − 1 (rem ≤ 8; X: their positions, flat, loaded
// with the masks mk; f: their spring forces, one register an axis).
template <bool Energy>
LD_AVX512 inline void finish8(const BlockStep& c, const Consts512& k, std::size_t t, std::size_t rem, bool extra,
                              const __m512d* X, const __mmask8* mk, const __m512d* f, Acc512& acc) {
  const std::size_t b = 3 * t;
  __m512d F[3];
  for (int r = 0; r < 3; ++r)
    F[r] = _mm512_mask_permutexvar_pd(_mm512_permutex2var_pd(f[0], k.toFlat[r], f[1]), kRegroup.flatZ[r], k.toFlatZ[r],
                                      f[2]);
  if (extra) {
    // Forces of the springs added since the rebuild (f4, 4 a vertex; zeroed here).
    __m512d fa[4];
    for (std::size_t u = 0; u < 4; ++u) {
      const __mmask8 two = __mmask8((rem > 2 * u ? 0x0Fu : 0u) | (rem > 2 * u + 1 ? 0xF0u : 0u));
      double* f4 = c.f4 + 4 * t + 8 * u;
      fa[u] = _mm512_maskz_loadu_pd(two, f4);
      _mm512_mask_storeu_pd(f4, two, k.zero);
    }
    for (int r = 0; r < 3; ++r) F[r] = _mm512_add_pd(F[r], _mm512_permutex2var_pd(fa[r], k.regroup[r], fa[r + 1]));
  }
  const __mmask8 vm = __mmask8((1u << rem) - 1u);
  const __m512d mv = _mm512_maskz_loadu_pd(vm, c.mass + t);
  // 1/mass (0 where mass ≤ 0), rounded as the cache's: one stream fewer to read.
  const __m512d imv = _mm512_maskz_div_pd(_mm512_cmp_pd_mask(mv, k.zero, _CMP_GT_OQ), _mm512_set1_pd(1.0), mv);
  const __m512d kv = Energy ? _mm512_maskz_loadu_pd(vm, c.stiffness + t) : k.zero;
  for (std::size_t r = 0; r < 3; ++r) {
    const std::size_t o = b + 8 * r;
    const __m512d im3 = _mm512_permutexvar_pd(k.spread[r], imv), m3 = _mm512_permutexvar_pd(k.spread[r], mv);
    const __m512d k3 = _mm512_permutexvar_pd(k.spread[r], kv);
    const __mmask8 live = _mm512_cmp_pd_mask(im3, k.zero, _CMP_NEQ_OQ);
    const __m512d H = _mm512_maskz_loadu_pd(mk[r], c.home + o);
    const __m512d E = _mm512_maskz_loadu_pd(mk[r], c.ext + o);
    const __m512d a = _mm512_fnmadd_pd(k.homeK, _mm512_sub_pd(X[r], H), _mm512_add_pd(F[r], E));
    const __m512d u = _mm512_maskz_fmadd_pd(live, k.damp, _mm512_maskz_loadu_pd(mk[r], c.v0 + o),
                                            _mm512_mul_pd(k.dt, _mm512_fmadd_pd(im3, a, k.grav[r])));
    const __m512d e = _mm512_mul_pd(k.dt, u);
    const __m512d p = _mm512_fmadd_pd(k.dt, u, X[r]);  // fused, as in finish4
    _mm512_mask_storeu_pd(c.v1 + o, mk[r], u);
    _mm512_mask_storeu_pd(c.x1 + o, mk[r], p);
    const __m512d uu = _mm512_mul_pd(u, u);
    if constexpr (Energy) acc.ke = _mm512_fmadd_pd(m3, uu, acc.ke);
    if constexpr (Energy) acc.kv2 = _mm512_fmadd_pd(k3, uu, acc.kv2);
    acc.v2 = _mm512_add_pd(acc.v2, uu);
    if constexpr (Energy) {
      acc.maxc = _mm512_max_pd(acc.maxc, uu);
      acc.work = _mm512_fmadd_pd(_mm512_fmadd_pd(m3, k.grav[r], E), e, acc.work);
    }
    const __m512d qh = _mm512_maskz_sub_pd(live, p, H);
    acc.home = _mm512_fmadd_pd(qh, qh, acc.home);
  }
}

LD_AVX512 inline __m512i lanes8(const std::uint8_t* p) {
  return _mm512_cvtepu8_epi64(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p)));
}

template <bool Shared, bool Energy, bool Rsqrt>
LD_AVX512 void blockStepAvx512(const BlockStep& c, FinishSums& s) {
  Consts512 k;
  k.zero = _mm512_setzero_pd();
  k.sharedK = _mm512_set1_pd(c.springK);
  k.twoK = _mm512_set1_pd(2.0 * c.springK);
  k.dt = _mm512_set1_pd(c.dt);
  k.damp = _mm512_set1_pd(c.damp);
  k.homeK = _mm512_set1_pd(c.homeK);
  const double g0 = c.g[0], g1 = c.g[1], g2 = c.g[2];
  k.grav[0] = _mm512_setr_pd(g0, g1, g2, g0, g1, g2, g0, g1);
  k.grav[1] = _mm512_setr_pd(g2, g0, g1, g2, g0, g1, g2, g0);
  k.grav[2] = _mm512_setr_pd(g1, g2, g0, g1, g2, g0, g1, g2);
  // Register r of 8 vertices holds components 8r … 8r+7: vertex (8r + lane) / 3.
  k.spread[0] = _mm512_setr_epi64(0, 0, 0, 1, 1, 1, 2, 2);
  k.spread[1] = _mm512_setr_epi64(2, 3, 3, 3, 4, 4, 4, 5);
  k.spread[2] = _mm512_setr_epi64(5, 5, 6, 6, 6, 7, 7, 7);
  k.regroup[0] = _mm512_setr_epi64(0, 1, 2, 4, 5, 6, 8, 9);
  k.regroup[1] = _mm512_setr_epi64(2, 4, 5, 6, 8, 9, 10, 12);
  k.regroup[2] = _mm512_setr_epi64(5, 6, 8, 9, 10, 12, 13, 14);
  for (int a = 0; a < 3; ++a) {
    k.toAxis[a] = idx512(kRegroup.toAxis[a]);
    k.toAxisLast[a] = idx512(kRegroup.toAxisLast[a]);
    k.toFlat[a] = idx512(kRegroup.toFlat[a]);
    k.toFlatZ[a] = idx512(kRegroup.toFlatZ[a]);
  }
  Acc512 acc{k.zero, k.zero, k.zero, k.zero, k.zero, k.zero};
  __m512d pe = k.zero;
  const bool groupMoves = Energy && c.groupMove2 != nullptr;
  for (std::size_t grp = c.g0; grp < c.g1; ++grp) {
    prefetchGroup(c, grp);
    const std::size_t t = kGroup * grp;
    const std::size_t rem = std::min(kGroup, c.n - t), comps = 3 * rem;
    const __m512d before = acc.maxc;
    if (groupMoves) acc.maxc = k.zero;
    // Positions of the 16 vertices, flat (6 registers), then one register an axis
    // a half; lanes past n load as 0 (their springs are padding).
    __mmask8 mk[6];
    __m512d X[6];
    for (std::size_t r = 0; r < 6; ++r) {
      const std::size_t lo = 8 * r;
      const std::size_t cnt = comps > lo ? std::min<std::size_t>(8, comps - lo) : 0;
      mk[r] = __mmask8((1u << cnt) - 1u);
      X[r] = _mm512_maskz_loadu_pd(mk[r], c.x0 + 3 * t + lo);
    }
    __m512d axis[2][3];
    for (int h = 0; h < 2; ++h)
      for (int a = 0; a < 3; ++a)
        axis[h][a] = _mm512_mask_permutexvar_pd(_mm512_permutex2var_pd(X[3 * h], k.toAxis[a], X[3 * h + 1]),
                                                kRegroup.axisLast[a], k.toAxisLast[a], X[3 * h + 2]);
    // Each block's lanes are the group's vertices in slot order.
    __m512d f[2][3], xi[2][3];
    for (std::size_t h = 0; h < 2; ++h) {
      const __m512i sv = lanes8(c.slotVertex + t + kLanes * h);
      for (int a = 0; a < 3; ++a) xi[h][a] = _mm512_permutex2var_pd(axis[0][a], sv, axis[1][a]);
    }
    springs8x2<Shared, Energy, Rsqrt>(c, k, grp, xi, f, pe);
    tails8<Shared, Energy, Rsqrt>(c, k, grp, xi, f, pe);
    const bool extra = c.extra[grp] != 0;
    for (std::size_t h = 0; h < 2 && kLanes * h < rem; ++h) {
      const __m512i vs = lanes8(c.vertexSlot + t + kLanes * h);
      __m512d fv[3];
      for (int a = 0; a < 3; ++a) fv[a] = _mm512_permutex2var_pd(f[0][a], vs, f[1][a]);
      finish8<Energy>(c, k, t + kLanes * h, std::min(kLanes, rem - kLanes * h), extra, X + 3 * h, mk + 3 * h, fv, acc);
    }
    if (groupMoves) {
      recordGroupMove(c, grp, _mm512_reduce_max_pd(acc.maxc) * c.moveScale2);
      acc.maxc = _mm512_max_pd(acc.maxc, before);
    }
  }
  s.ke1 += _mm512_reduce_add_pd(acc.ke);
  s.home1 += _mm512_reduce_add_pd(acc.home);
  s.v2 += _mm512_reduce_add_pd(acc.v2);
  s.work += _mm512_reduce_add_pd(acc.work);
  s.maxComp2 = std::max(s.maxComp2, _mm512_reduce_max_pd(acc.maxc));
  s.kv2 += _mm512_reduce_add_pd(acc.kv2);
  s.pe += _mm512_reduce_add_pd(pe);
}

#endif  // LD_X86_KERNELS

bool cpuSupports(Kernel k) {
  switch (k) {
    case Kernel::Scalar:
      return true;
#ifdef LD_X86_KERNELS
    case Kernel::Avx2:
      __builtin_cpu_init();
      return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    case Kernel::Avx512:
      __builtin_cpu_init();
      return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
             __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#else
    default:
      return false;
#endif
  }
  return false;
}

Kernel bestKernel() {
  static const Kernel best = cpuSupports(Kernel::Avx512) ? Kernel::Avx512
                             : cpuSupports(Kernel::Avx2) ? Kernel::Avx2
                                                         : Kernel::Scalar;
  return best;
}

std::atomic<int> gForced{-1};
std::atomic<int> gForcedFactor{-1};

#ifdef LD_X86_KERNELS
template <int Steps>
LD_AVX512 void invSqrtAvx512(const double* l2, double* out, std::size_t n) {
  for (std::size_t t = 0; t < n; t += 8) {
    const __mmask8 mk = __mmask8((1u << std::min<std::size_t>(8, n - t)) - 1u);
    _mm512_mask_storeu_pd(out + t, mk, invSqrt8<Steps>(_mm512_mask_loadu_pd(_mm512_set1_pd(1.0), mk, l2 + t)));
  }
}
template <int Steps>
LD_AVX2 void invSqrtAvx2(const double* l2, double* out, std::size_t n) {
  for (std::size_t t = 0; t < n; t += 4) {
    alignas(32) double buf[4] = {1.0, 1.0, 1.0, 1.0};
    const std::size_t cnt = std::min<std::size_t>(4, n - t);
    std::copy(l2 + t, l2 + t + cnt, buf);
    _mm256_store_pd(buf, invSqrt4<Steps>(_mm256_load_pd(buf)));
    std::copy(buf, buf + cnt, out + t);
  }
}
template <int Steps>
void invSqrtSteps(Kernel k, const double* l2, double* out, std::size_t n) {
  if (k == Kernel::Avx512) invSqrtAvx512<Steps>(l2, out, n);
  if (k == Kernel::Avx2) invSqrtAvx2<Steps>(l2, out, n);
}
#endif

}  // namespace

std::string_view kernelName(Kernel k) {
  switch (k) {
    case Kernel::Scalar:
      return "scalar";
    case Kernel::Avx2:
      return "avx2";
    case Kernel::Avx512:
      return "avx512";
  }
  return "?";
}

bool kernelSupported(Kernel k) { return cpuSupports(k); }

Kernel activeKernel() {
  const int f = gForced.load(std::memory_order_relaxed);
  return f >= 0 ? static_cast<Kernel>(f) : bestKernel();
}

bool forceKernel(std::optional<Kernel> k) {
  if (k && !kernelSupported(*k)) return false;
  gForced.store(k ? static_cast<int>(*k) : -1, std::memory_order_relaxed);
  return true;
}

std::string_view factorName(Factor f) { return f == Factor::Rsqrt ? "rsqrt" : "sqrt-div"; }

Factor defaultFactor(Kernel k) {
  // Measured: on an Intel Xeon (one divider for sqrt and div) rsqrt wins on AVX-512 and
  // loses on AVX2; on an AMD Zen 5 sqrt and div won on AVX-512 too.
#ifdef LD_X86_KERNELS
  static const bool intel = [] {
    __builtin_cpu_init();
    return __builtin_cpu_is("intel") != 0;
  }();
  return k == Kernel::Avx512 && intel ? Factor::Rsqrt : Factor::SqrtDiv;
#else
  (void)k;
  return Factor::SqrtDiv;
#endif
}

Factor activeFactor(Kernel k) {
  const int f = gForcedFactor.load(std::memory_order_relaxed);
  return f >= 0 ? static_cast<Factor>(f) : defaultFactor(k);
}

void forceFactor(std::optional<Factor> f) {
  gForcedFactor.store(f ? static_cast<int>(*f) : -1, std::memory_order_relaxed);
}

int newtonSteps(Kernel k) {
#ifdef LD_X86_KERNELS
  if (k == Kernel::Avx512) return kNewtonAvx512;
  if (k == Kernel::Avx2) return kNewtonAvx2;
#endif
  (void)k;
  return 0;
}

void invSqrt(Kernel k, const double* l2, double* out, std::size_t n, int steps) {
#ifdef LD_X86_KERNELS
  if (k != Kernel::Scalar && kernelSupported(k)) {
    switch (steps) {
      case 0:
        return invSqrtSteps<0>(k, l2, out, n);
      case 1:
        return invSqrtSteps<1>(k, l2, out, n);
      case 2:
        return invSqrtSteps<2>(k, l2, out, n);
      case 3:
        return invSqrtSteps<3>(k, l2, out, n);
      case 4:
        return invSqrtSteps<4>(k, l2, out, n);
      case 5:
        return invSqrtSteps<5>(k, l2, out, n);
      default:
        return invSqrtSteps<6>(k, l2, out, n);
    }
  }
#endif
  (void)steps;
  for (std::size_t i = 0; i < n; ++i) out[i] = 1.0 / std::sqrt(l2[i]);
}

double springForces(Kernel kern, const SpringChunk& c) {
  switch (kern) {
#ifdef LD_X86_KERNELS
    case Kernel::Avx512:
      return springForcesAvx512(c);
    case Kernel::Avx2:
      return springForcesAvx2(c);
#endif
    default:
      return springForcesScalar(c);
  }
}

namespace {
// One path's builds (lane layout × energy sums × factor).
template <template <bool, bool, bool> class Path, bool Rsqrt>
void dispatchLayout(const BlockStep& c, FinishSums& s) {
  if (c.rankRest)
    c.energy ? Path<false, true, Rsqrt>::run(c, s) : Path<false, false, Rsqrt>::run(c, s);
  else
    c.energy ? Path<true, true, Rsqrt>::run(c, s) : Path<true, false, Rsqrt>::run(c, s);
}
template <template <bool, bool, bool> class Path>
void dispatch(const BlockStep& c, FinishSums& s) {
  c.rsqrt ? dispatchLayout<Path, true>(c, s) : dispatchLayout<Path, false>(c, s);
}
template <bool Shared, bool Energy, bool>
struct ScalarPath {  // the reference: always sqrt and div
  static void run(const BlockStep& c, FinishSums& s) { blockStepScalar<Shared, Energy>(c, s); }
};
#ifdef LD_X86_KERNELS
template <bool Shared, bool Energy, bool Rsqrt>
struct Avx2Path {
  static void run(const BlockStep& c, FinishSums& s) { blockStepAvx2<Shared, Energy, Rsqrt>(c, s); }
};
template <bool Shared, bool Energy, bool Rsqrt>
struct Avx512Path {
  static void run(const BlockStep& c, FinishSums& s) { blockStepAvx512<Shared, Energy, Rsqrt>(c, s); }
};
#endif
}  // namespace

void blockStep(Kernel kern, const BlockStep& c, FinishSums& s) {
  switch (kern) {
#ifdef LD_X86_KERNELS
    case Kernel::Avx512:
      return dispatch<Avx512Path>(c, s);
    case Kernel::Avx2:
      return dispatch<Avx2Path>(c, s);
#endif
    default:
      return dispatch<ScalarPath>(c, s);
  }
}

}  // namespace ld::physics::detail
