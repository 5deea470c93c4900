// The pivot of one column of a factorization, as Step 1 writes it for M
// (eq. 25-26) and Step 3.4 for W = T^T T: the same statements on other names
// (internal to the emit stage).
#pragma once

#include <string>
#include <vector>

#include "emit/kernel.hpp"

namespace jrgen::emit {

/// "if (!(d > tolerance * base)) return fail;": the pivot d of a column
/// against the tolerance relative to its original diagonal entry:
/// kMassPivotTolerance for M (Step 1), kPivotTolerance for T^T T (Step 3.4).
std::string pivot_test(const std::string& base, const std::string& fail, const std::string& tolerance);

/// Column j's diagonal of L D L^T (no square roots), and of its unscaled
/// form with --divide.
struct LdltPivot {
  std::vector<std::string> entries;  ///< E_n: row j's entries left of the diagonal
  std::vector<std::string> pivots;   ///< D_n: the pivots of their columns
  std::string base;                  ///< the original diagonal entry
  std::string diag;                  ///< where the pivot d goes
  std::string fail;                  ///< returned when d fails pivot_test()
  std::string inverse;               ///< "Dinv[j]", "Winv[j]": 1 / d ...
  bool reciprocal = true;            ///< ... or, when false, d itself ...
  std::string check;                 ///< ... for this digits test
  std::string tolerance;             ///< kMassPivotTolerance (M) or kPivotTolerance (T^T T)
};

/// Writes into `u`
///   const double w_n = E_n * D_n;             (`unscaled`: l_n = E_n / D_n)
///   const double d = base - sum_n w_n E_n;
///   pivot_test; diag = d; inverse = 1.0 / d (or = d);
///   E_n = l_n;                                (`unscaled` only)
/// and counts its operations in k.  Returns the names w_n (l_n), the scalar
/// factors of the column's rows below the diagonal.
std::vector<std::string> ldlt_pivot(Kernel& k, Kernel::Unit& u, const LdltPivot& c, bool unscaled);

}  // namespace jrgen::emit
