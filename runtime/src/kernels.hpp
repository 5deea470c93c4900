// Small loops shared by the runtime's table-driven factorizations
// (runtime.cpp, supernodal.cpp, parallel.cpp).  Internal: not installed.
#pragma once

#include <cmath>
#include <cstdint>

namespace jr::detail {

/// y[0, n) -= f x[0, n).  Callers pass two distinct columns of the packed
/// factor (column j and one of its ancestors, Lemma 2): the ranges never
/// overlap.  Saying so lets the compiler drop the run-time overlap test it
/// would otherwise put around each of these short updates (the table-driven
/// Step 1 runs one per entry of L), and the two-way unrolling suits the short
/// lengths (a few ancestors per column).
/// Measured with callgrind on the 10 015-dof tree of tests/bench: 23.0M ->
/// 17.3M instructions for four factorizations.
inline void subtract_scaled(double* __restrict y, const double* __restrict x, double f, std::int32_t n) {
  std::int32_t i = 0;
  for (; i + 1 < n; i += 2) {
    y[i] -= x[i] * f;
    y[i + 1] -= x[i + 1] * f;
  }
  if (i < n) y[i] -= x[i] * f;
}

/// The scale of column j's rows in the factor, from its pivot d > 0 (its
/// diagonal entry after its descendants' updates, eq. 25) and dinv = 1 / d:
/// 1 / d for L D L^T; for L L^T, 1 / l = l / d, with l = sqrt(d) written to
/// *diag.  Both factorizations update the ancestors with the unscaled rows w
/// of column j and f = w * dinv (update_ancestors), since l_a l_b = w_a w_b / d
/// for L L^T: one division is then the only operation between a pivot and the
/// updates that the next columns wait for.  The square root and the scaling
/// of the rows are off that chain; Step 1 of a 1059-dof random tree took 14.2
/// us with them on it and 10.0 us so (docs/benchmarks.md, run 6).
inline double row_scale(double d, double dinv, bool ldlt, double* diag) {
  if (ldlt) return dinv;
  const double l = std::sqrt(d);
  *diag = l;
  return l * dinv;
}

/// The update of Step 1 (eq. 18 with Lemma 2, right-looking) that column j
/// makes to the columns of its n ancestors s_0 = s, s_1 = parent[s_0], ...:
///
///     L[s_a, s_b] -= col[b] * f_a,   f_a = col[a] * scale,   0 <= a <= b < n,
///
/// where col[0, n) are column j's ancestor rows, not yet scaled, and scale =
/// 1 / pivot (row_scale).  Column s_a stores rows s_a, s_{a+1}, ...
/// contiguously from start[s_a], so row s_b sits at start[s_a] + (b - a).
///
/// Short columns are the common case in trees (a few ancestors each), and a
/// loop over a length that changes from call to call costs a mispredicted
/// branch per call.  Lengths up to kMaxFixedAncestors therefore go through a
/// fully unrolled body for that exact length (one indirect jump per column);
/// the arithmetic, and its order for every entry of L, is that of the loops.
inline constexpr std::int32_t kMaxFixedAncestors = 16;

template <int P>
inline void update_ancestors_fixed(double* L, const std::int32_t* start, const std::int32_t* parent, std::int32_t s,
                                   const double* col, double scale) {
  double c[P];
  double* y[P];
#pragma GCC unroll 16
  for (int a = 0; a < P; ++a) {
    c[a] = col[a];
    y[a] = L + start[s];
    s = parent[s];
  }
#pragma GCC unroll 16
  for (int a = 0; a < P; ++a) {
    const double f = c[a] * scale;
#pragma GCC unroll 16
    for (int b = a; b < P; ++b) y[a][b - a] -= c[b] * f;
  }
}

inline void update_ancestors(double* L, const std::int32_t* start, const std::int32_t* parent, std::int32_t s,
                             const double* col, double scale, std::int32_t n) {
  static_assert(kMaxFixedAncestors == 16, "the cases below list the lengths 1 to 16");
  switch (n) {
    case 0: return;
#define JR_FIXED_CASE(P) \
  case P: update_ancestors_fixed<P>(L, start, parent, s, col, scale); return;
    JR_FIXED_CASE(1) JR_FIXED_CASE(2) JR_FIXED_CASE(3) JR_FIXED_CASE(4)
    JR_FIXED_CASE(5) JR_FIXED_CASE(6) JR_FIXED_CASE(7) JR_FIXED_CASE(8)
    JR_FIXED_CASE(9) JR_FIXED_CASE(10) JR_FIXED_CASE(11) JR_FIXED_CASE(12)
    JR_FIXED_CASE(13) JR_FIXED_CASE(14) JR_FIXED_CASE(15) JR_FIXED_CASE(16)
#undef JR_FIXED_CASE
    default:
      for (std::int32_t a = 0; a < n; ++a, s = parent[s])
        subtract_scaled(L + start[s], col + a, col[a] * scale, n - a);
  }
}

}  // namespace jr::detail
