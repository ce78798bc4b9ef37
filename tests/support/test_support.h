#pragma once
// Helpers shared by the test suites: tolerance comparisons and the locations of
// third-party data (../shared/data) and bundled resources.
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <Eigen/Core>

#include "tests/support/data_paths.h"

namespace ld::test {

#define LD_REQUIRE_SHARED_DATA(var, rel)                                                             \
  const std::filesystem::path var = ::ld::test::sharedData(rel);                                     \
  if (var.empty())                                                                                   \
  GTEST_SKIP() << "third-party data " << (rel) << " not found under " << ::ld::test::sharedDataDir() \
               << " (../shared/data is absent); skipping"

inline ::testing::AssertionResult near(double a, double b, double absTol, double relTol = 0.0) {
  const double tol = std::max(absTol, relTol * std::max(std::abs(a), std::abs(b)));
  if (std::isfinite(a) && std::isfinite(b) && std::abs(a - b) <= tol) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << a << " vs " << b << " differ by " << std::abs(a - b) << " > tolerance "
                                       << tol;
}

template <class A, class B>
::testing::AssertionResult nearVec(const Eigen::MatrixBase<A>& a, const Eigen::MatrixBase<B>& b, double absTol) {
  const double d = (a - b).cwiseAbs().maxCoeff();
  if (std::isfinite(d) && d <= absTol) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "[" << a.transpose() << "] vs [" << b.transpose() << "] differ by " << d
                                       << " > " << absTol;
}

}  // namespace ld::test
