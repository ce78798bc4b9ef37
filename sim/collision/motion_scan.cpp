#include "sim/collision/motion_scan.h"

#include <algorithm>
#include <atomic>
#include <cmath>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#if defined(__GNUC__) && !defined(__clang__)
// GCC 12's intrinsic headers self-initialise "undefined" vectors (conversions,
// reductions), which -Wuninitialized reports at every inlined use; the warning is
// about the header.
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include <immintrin.h>
#define LD_SCAN_X86 1
// Built for these ISAs whatever the compile flags (no -march): chosen at run time.
#define LD_AVX2 __attribute__((target("avx2")))
#define LD_AVX512 __attribute__((target("avx512f")))
#endif

namespace ld::collision {

namespace {

constexpr std::size_t kBlock = 24;  // coordinates of a block of 8 vertices

std::size_t scanPortable(const double* x, const float* a, std::size_t b, std::size_t nb, double theta, double& worst) {
  for (; b < nb; ++b) {
    const double* xc = x + kBlock * b;
    const float* ac = a + kBlock * b;
    double d = 0.0;
    bool loud = false;
    for (std::size_t k = 0; k < kBlock; ++k) {
      const double e = std::abs(xc[k] - static_cast<double>(ac[k]));
      d = std::max(d, e);
      loud = loud || !(e <= theta);
    }
    if (loud) return b;
    worst = std::max(worst, d);
  }
  return nb;
}

#if defined(__SSE2__)
// The larger of a register's two lanes (a running maximum handed back to the caller).
inline double lanesMax(__m128d v) { return std::max(_mm_cvtsd_f64(v), _mm_cvtsd_f64(_mm_unpackhi_pd(v, v))); }

// Two floats (8 bytes) widened to two doubles.
inline __m128d widen2(const float* p) {
  return _mm_cvtps_pd(_mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p))));
}

std::size_t scanSse2(const double* x, const float* a, std::size_t b, std::size_t nb, double theta, double& worst) {
  // The 12 differences of a block are combined as trees (depth 4, not a chain of 12
  // dependent max), the largest kept in a register across blocks. A NaN may vanish
  // from a max, never from a sum: a block whose sum is NaN counts as moved.
  const __m128d absMask = _mm_castsi128_pd(_mm_set1_epi64x(0x7fffffffffffffffLL));
  const __m128d th = _mm_set1_pd(theta);
  __m128d worstV = _mm_set1_pd(worst);
  for (; b < nb; ++b) {
    const double* xc = x + kBlock * b;
    const float* ac = a + kBlock * b;
    __m128d e[12];
    for (std::size_t k = 0; k < 12; ++k)
      e[k] = _mm_and_pd(_mm_sub_pd(_mm_loadu_pd(xc + 2 * k), widen2(ac + 2 * k)), absMask);
    __m128d mx[6], sm[6];
    for (std::size_t k = 0; k < 6; ++k) {
      mx[k] = _mm_max_pd(e[2 * k], e[2 * k + 1]);
      sm[k] = _mm_add_pd(e[2 * k], e[2 * k + 1]);
    }
    for (std::size_t k = 0; k < 3; ++k) {
      mx[k] = _mm_max_pd(mx[k], mx[k + 3]);
      sm[k] = _mm_add_pd(sm[k], sm[k + 3]);
    }
    const __m128d big = _mm_max_pd(_mm_max_pd(mx[0], mx[1]), mx[2]);
    const __m128d sum = _mm_add_pd(_mm_add_pd(sm[0], sm[1]), sm[2]);
    if (_mm_movemask_pd(_mm_or_pd(_mm_cmpnle_pd(big, th), _mm_cmpunord_pd(sum, sum))) != 0) break;
    worstV = _mm_max_pd(worstV, big);
  }
  worst = lanesMax(worstV);
  return b;
}
#endif

#ifdef LD_SCAN_X86
LD_AVX2 inline double lanesMax(__m256d v) {
  return lanesMax(_mm_max_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd(v, 1)));
}

LD_AVX2 std::size_t scanAvx2(const double* x, const float* a, std::size_t b, std::size_t nb, double theta,
                             double& worst) {
  // As the SSE2 build, 4 lanes: 6 differences a block, each anchor load widened as it
  // is read (vcvtps2pd from memory).
  const __m256d absMask = _mm256_castsi256_pd(_mm256_set1_epi64x(0x7fffffffffffffffLL));
  const __m256d th = _mm256_set1_pd(theta);
  __m256d worstV = _mm256_set1_pd(worst);
  for (; b < nb; ++b) {
    const double* xc = x + kBlock * b;
    const float* ac = a + kBlock * b;
    __m256d e[6];
    for (std::size_t k = 0; k < 6; ++k)
      e[k] =
          _mm256_and_pd(_mm256_sub_pd(_mm256_loadu_pd(xc + 4 * k), _mm256_cvtps_pd(_mm_loadu_ps(ac + 4 * k))), absMask);
    const __m256d big =
        _mm256_max_pd(_mm256_max_pd(_mm256_max_pd(e[0], e[1]), _mm256_max_pd(e[2], e[3])), _mm256_max_pd(e[4], e[5]));
    const __m256d sum =
        _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(e[0], e[1]), _mm256_add_pd(e[2], e[3])), _mm256_add_pd(e[4], e[5]));
    const __m256d loud = _mm256_or_pd(_mm256_cmp_pd(big, th, _CMP_NLE_UQ), _mm256_cmp_pd(sum, sum, _CMP_UNORD_Q));
    if (_mm256_movemask_pd(loud) != 0) break;
    worstV = _mm256_max_pd(worstV, big);
  }
  worst = lanesMax(worstV);
  return b;
}

LD_AVX512 std::size_t scanAvx512(const double* x, const float* a, std::size_t b, std::size_t nb, double theta,
                                 double& worst) {
  // 8 lanes: 3 differences a block; each is compared with theta on its own (not
  // ordered-or-equal catches NaN), the masks or-ed, so no sum is needed.
  const __m512d th = _mm512_set1_pd(theta);
  __m512d worstV = _mm512_set1_pd(worst);
  for (; b < nb; ++b) {
    const double* xc = x + kBlock * b;
    const float* ac = a + kBlock * b;
    const __m512d e0 = _mm512_abs_pd(_mm512_sub_pd(_mm512_loadu_pd(xc), _mm512_cvtps_pd(_mm256_loadu_ps(ac))));
    const __m512d e1 = _mm512_abs_pd(_mm512_sub_pd(_mm512_loadu_pd(xc + 8), _mm512_cvtps_pd(_mm256_loadu_ps(ac + 8))));
    const __m512d e2 =
        _mm512_abs_pd(_mm512_sub_pd(_mm512_loadu_pd(xc + 16), _mm512_cvtps_pd(_mm256_loadu_ps(ac + 16))));
    const unsigned loud = static_cast<unsigned>(_mm512_cmp_pd_mask(e0, th, _CMP_NLE_UQ)) |
                          static_cast<unsigned>(_mm512_cmp_pd_mask(e1, th, _CMP_NLE_UQ)) |
                          static_cast<unsigned>(_mm512_cmp_pd_mask(e2, th, _CMP_NLE_UQ));
    if (loud != 0) break;
    worstV = _mm512_max_pd(worstV, _mm512_max_pd(_mm512_max_pd(e0, e1), e2));
  }
  worst = _mm512_reduce_max_pd(worstV);
  return b;
}
#endif

#ifdef LD_SCAN_X86
// anchorCoordinates' bulk, 4 and 8 coordinates at a time; returns how many were done.
LD_AVX2 std::size_t anchorAvx2(const double* x, float* a, std::size_t n) {
  std::size_t i = 0;
  for (; i + 4 <= n; i += 4) _mm_storeu_ps(a + i, _mm256_cvtpd_ps(_mm256_loadu_pd(x + i)));
  return i;
}
LD_AVX512 std::size_t anchorAvx512(const double* x, float* a, std::size_t n) {
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) _mm256_storeu_ps(a + i, _mm512_cvtpd_ps(_mm512_loadu_pd(x + i)));
  return i;
}
#endif

bool cpuSupports(ScanKernel k) {
  switch (k) {
    case ScanKernel::Portable:
      return true;
    case ScanKernel::Sse2:
#if defined(__SSE2__)
      return true;
#else
      return false;
#endif
#ifdef LD_SCAN_X86
    case ScanKernel::Avx2:
      __builtin_cpu_init();
      return __builtin_cpu_supports("avx2");
    case ScanKernel::Avx512:
      __builtin_cpu_init();
      return __builtin_cpu_supports("avx512f");
#else
    default:
      return false;
#endif
  }
  return false;
}

ScanKernel bestKernel() {
  static const ScanKernel best = cpuSupports(ScanKernel::Avx512) ? ScanKernel::Avx512
                                 : cpuSupports(ScanKernel::Avx2) ? ScanKernel::Avx2
                                 : cpuSupports(ScanKernel::Sse2) ? ScanKernel::Sse2
                                                                 : ScanKernel::Portable;
  return best;
}

std::atomic<int> gForced{-1};

}  // namespace

std::string_view scanKernelName(ScanKernel k) {
  switch (k) {
    case ScanKernel::Portable:
      return "portable";
    case ScanKernel::Sse2:
      return "sse2";
    case ScanKernel::Avx2:
      return "avx2";
    case ScanKernel::Avx512:
      return "avx512";
  }
  return "?";
}

bool scanKernelSupported(ScanKernel k) { return cpuSupports(k); }

ScanKernel activeScanKernel() {
  const int f = gForced.load(std::memory_order_relaxed);
  return f >= 0 ? static_cast<ScanKernel>(f) : bestKernel();
}

bool forceScanKernel(std::optional<ScanKernel> k) {
  if (k && !cpuSupports(*k)) return false;
  gForced.store(k ? static_cast<int>(*k) : -1, std::memory_order_relaxed);
  return true;
}

namespace detail {

std::size_t scanQuietBlocks(ScanKernel k, const double* x, const float* a, std::size_t b, std::size_t nb, double theta,
                            double& worst) {
  switch (k) {
#ifdef LD_SCAN_X86
    case ScanKernel::Avx512:
      return scanAvx512(x, a, b, nb, theta, worst);
    case ScanKernel::Avx2:
      return scanAvx2(x, a, b, nb, theta, worst);
#endif
#if defined(__SSE2__)
    case ScanKernel::Sse2:
      return scanSse2(x, a, b, nb, theta, worst);
#endif
    default:
      return scanPortable(x, a, b, nb, theta, worst);
  }
}

void anchorCoordinates(ScanKernel k, const double* x, float* a, std::size_t n) {
  std::size_t i = 0;
#ifdef LD_SCAN_X86
  if (k == ScanKernel::Avx512) i = anchorAvx512(x, a, n);
  if (k == ScanKernel::Avx2) i = anchorAvx2(x, a, n);
#endif
#if defined(__SSE2__)
  for (; k != ScanKernel::Portable && i + 2 <= n; i += 2)
    _mm_storel_epi64(reinterpret_cast<__m128i*>(a + i), _mm_castps_si128(_mm_cvtpd_ps(_mm_loadu_pd(x + i))));
#endif
  for (; i < n; ++i) a[i] = static_cast<float>(x[i]);
}

}  // namespace detail
}  // namespace ld::collision
