// One helper for numeric comparisons (docs/conventions.md, "Tests"): relative error of a
// result against a reference, normwise, with an absolute floor for results
// that are legitimately near zero.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <limits>

namespace jrgen::testing {

constexpr double kEps = std::numeric_limits<double>::epsilon();

/// ||x - ref|| / max(||ref||, floor), Frobenius/2-norm.
template <typename A, typename B>
double relative_error(const Eigen::MatrixBase<A>& x, const Eigen::MatrixBase<B>& ref, double floor = 1e-300) {
  return (x - ref).norm() / std::max(ref.norm(), floor);
}

}  // namespace jrgen::testing
