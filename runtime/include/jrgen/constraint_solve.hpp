// jrgen runtime: table-driven Step 3 (3.1-3.5) of the algorithm of Section 4.3
// (Negrut, Serban & Potra 1997), for closed-loop models whose straight-line
// Step 3 would be too large to compile (the generator chooses).  The same
// arithmetic as the generated straight-line code, as loops over plain tables:
//
//   T layout (Lemma 3): kept row g of cut c stores one entry per dof of the
//     cut's dof list (the dofs on the paths of its two bodies to the base, in
//     increasing Lemma 2 order), from row_t_start[g]; the entries of the
//     common ancestors (index >= num_distinct) hold no Phiq entry (it is 0
//     there) but T generally is non-zero there.
//   W = T^T T (or U^T D^-1 U with L D L^T) and its Cholesky factor, packed by
//     columns in a fill-reducing elimination order: position j is kept row
//     order[j]; column j holds the diagonal at W_col_start[j], then the rows
//     W_row[e] (elimination positions, ascending, fill included) up to
//     W_col_start[j + 1]; W_structural[e] is 0 for pure fill (Step 3.3 writes
//     0 there).  The factor's pattern must be closed under elimination (the
//     symbolic Cholesky factorization of that order).
//
// Index spaces: dofs are Lemma 2 dofs (runtime.hpp); kept rows, gamma, z_m and
// lambda are in the user's row order; W is in elimination positions.
#pragma once

#include <cmath>
#include <cstdint>
#include <type_traits>

#include "jrgen/runtime.hpp"

namespace jr {

struct ConstraintSolveModel {
  std::int32_t ncuts;
  std::int32_t nc;                      ///< kept rows (m)
  const std::int32_t* cut_dof_start;    ///< (ncuts + 1) start of each cut's list in cut_dofs
  const std::int32_t* cut_dofs;         ///< Lemma 3 dof lists, ascending Lemma 2 dofs
  const std::int32_t* cut_parent_index; ///< per cut_dofs entry: index in the same cut's list of dof_parent, or -1
  const std::int32_t* cut_num_distinct; ///< (ncuts) dofs on one path only (a prefix of the list)
  const std::int32_t* row_cut;          ///< (nc) cut of kept row g
  const std::int32_t* row_t_start;      ///< (nc) first packed T entry of kept row g
  const std::int32_t* order;            ///< (nc) elimination position -> kept row
  const std::int32_t* W_col_start;      ///< (nc + 1) packed column starts of W (diagonal first)
  const std::int32_t* W_row;            ///< (W_col_start[nc]) elimination position of each entry
  const std::uint8_t* W_structural;     ///< (W_col_start[nc]) 1: non-zero in T^T T, 0: fill
};

/// Step 3.1: L T = Phiq^T in place (T holds the packed Phiq on entry), only
/// the rows of Lemma 3.  ldlt: L has a unit diagonal (U = L^-1 Phiq^T) and
/// Dinv is not read (may be nullptr); otherwise each entry is scaled by Dinv.
void constraint_solve_T(const Model& model, const ConstraintSolveModel& cs, const double* L, const double* Dinv,
                        bool ldlt, double* T);

/// Step 3.2: z_m = T^T z_n - gamma; with ldlt, V = D^-1 U (kept for Step
/// 3.3, same layout as T) and z_m = V^T y - gamma.  z (nv, Lemma 2 order).
void constraint_rhs(const ConstraintSolveModel& cs, const double* T, const double* Dinv, const double* z,
                    const double* gamma, bool ldlt, double* V, double* zm);

/// Step 3.3: W = A^T T over the structural entries (A = T, or V with ldlt),
/// summing over the dofs the two rows' cuts share; fill entries set to 0.
void constraint_schur(const ConstraintSolveModel& cs, const double* A, const double* T, double* W);

/// Step 3.4 (a): W = L_W L_W^T (or L_W D_W L_W^T, D_W on the diagonal) in
/// place, right-looking over the packed pattern; Winv[j] = 1 / pivot j.
/// Returns -1, or the kept row (user order) whose pivot was
/// <= pivot_tolerance * W[j, j] (or NaN), with that pivot in *pivot.
std::int32_t constraint_factor(const ConstraintSolveModel& cs, double* W, double* Winv, bool ldlt,
                               double pivot_tolerance, double* pivot);

/// Step 3.4 (b): W lambda = z_m in place (z_m and lambda in user row order).
void constraint_solve_lambda(const ConstraintSolveModel& cs, const double* W, const double* Winv, bool ldlt,
                             double* zm);

/// Step 3.5: z_n -= T lambda (y_n = T lambda, Step 4 then solves with z_n - y_n).
void constraint_update(const ConstraintSolveModel& cs, const double* T, const double* lambda, double* z);

// ---- Dense Schur kernels (used by the straight-line Step 3 too) ----------
//
// When some dofs are reached by every kept row (a floating base under all the
// loops: the HMMWV's chassis), every pair of rows shares a dof, so T^T T and
// its factor are dense: the generated code then calls these compact loops for
// the dense part instead of unrolling it (unrolled, Steps 3.3 and 3.4 of the
// HMMWV are 43 KB of machine code, and the whole solve outgrows the
// instruction caches; docs/benchmarks.md, run 4).  W is packed by columns,
// dense lower triangle: column j holds rows j..m-1 from j*m - j*(j-1)/2.

/// Step 3.3, dense part: W = A^T B, lower triangle, where A and B are k x m
/// row-major (row i: the entries of one dof for the m rows, in elimination
/// order).  With B = A (LL^T) or A = V = D^-1 U, B = U (LDL^T).
void schur_dense_gram(const double* A, const double* B, std::int32_t k, std::int32_t m, double* W);

/// Step 3.4 (a), dense: W = L_W L_W^T (or L_W D_W L_W^T) in place, left-looking;
/// Winv[j] = 1 / pivot j.  Returns -1, or the elimination position whose pivot
/// was <= pivot_tolerance * W[j, j] (or NaN), with the pivot in *pivot.
std::int32_t schur_dense_factor(double* W, double* Winv, std::int32_t m, bool ldlt, double pivot_tolerance,
                                double* pivot);

/// Step 3.4 (b), dense: W lambda = z_m in place; z_m in user row order,
/// order[j] = kept row at elimination position j; work holds m doubles.
void schur_dense_solve(const double* W, const double* Winv, std::int32_t m, const std::int32_t* order, bool ldlt,
                       double* work, double* zm);

namespace detail {

/// Column j of the dense packed lower triangle (rows j..m-1).
constexpr std::int32_t dense_col(std::int32_t j, std::int32_t m) { return j * m - j * (j - 1) / 2; }

// The loops of schur_dense_factor() and schur_dense_solve(), for a size m
// known at run time (std::int32_t) or at compile time (std::integral_constant:
// the _fixed variants below, which the generated code calls).
template <class Size>
inline std::int32_t schur_dense_factor_loops(double* W, double* Winv, Size m, bool ldlt, double pivot_tolerance,
                                             double* pivot) {
  for (std::int32_t j = 0; j < m; ++j) {
    double* __restrict col = W + dense_col(j, m);
    const std::int32_t len = m - j;
    const double original = col[0];
    // Left-looking: column j (rows j..m-1) less, for each column c left of
    // it, its rows from j times its entry in row j (times D_c with LDL^T).
    for (std::int32_t c = 0; c < j; ++c) {
      const double* __restrict lc = W + dense_col(c, m) + (j - c);
      const double a = ldlt ? lc[0] * W[dense_col(c, m)] : lc[0];
      for (std::int32_t r = 0; r < len; ++r) col[r] -= lc[r] * a;
    }
    const double d = col[0];
    if (!(d > pivot_tolerance * original)) {
      *pivot = d;
      return j;
    }
    const double diag = ldlt ? d : std::sqrt(d);
    col[0] = diag;
    const double inv = 1.0 / diag;
    Winv[j] = inv;
    for (std::int32_t r = 1; r < len; ++r) col[r] *= inv;
  }
  return -1;
}

template <class Size>
inline void schur_dense_solve_loops(const double* W, const double* Winv, Size m, const std::int32_t* order,
                                   bool ldlt, double* work, double* zm) {
  for (std::int32_t j = 0; j < m; ++j) work[j] = zm[order[j]];
  // Forward, by columns: y_j final, then subtracted from the rows below.
  for (std::int32_t j = 0; j < m; ++j) {
    const double* col = W + dense_col(j, m);
    if (!ldlt) work[j] *= Winv[j];
    const double y = work[j];
    for (std::int32_t r = 1; r < m - j; ++r) work[j + r] -= col[r] * y;
  }
  // Backward, by columns: column j against the rows below (the products
  // and their count as in the unrolled solve: no add to a zero), the row
  // just solved (j + 1) last, so that only its product waits for it: the
  // chain from one lambda to the next is one multiply and one subtraction,
  // not a subtraction per row below.
  for (std::int32_t j = m - 1; j >= 0; --j) {
    const double* col = W + dense_col(j, m);
    double s = ldlt ? work[j] * Winv[j] : work[j];
    for (std::int32_t r = m - j - 1; r >= 1; --r) s -= col[r] * work[j + r];
    work[j] = ldlt ? s : s * Winv[j];
  }
  for (std::int32_t j = 0; j < m; ++j) zm[order[j]] = work[j];
}

}  // namespace detail

/// schur_dense_factor() and schur_dense_solve() for m known at compile time:
/// the same loops and arithmetic (bitwise the same results), with every trip
/// count a constant the compiler can unroll (docs/benchmarks.md, run 6: the
/// HMMWV's m = 16 solve 2.01 -> 1.92 us).
template <std::int32_t M>
inline std::int32_t schur_dense_factor_fixed(double* W, double* Winv, bool ldlt, double pivot_tolerance,
                                             double* pivot) {
  return detail::schur_dense_factor_loops(W, Winv, std::integral_constant<std::int32_t, M>{}, ldlt, pivot_tolerance,
                                          pivot);
}

template <std::int32_t M>
inline void schur_dense_solve_fixed(const double* W, const double* Winv, const std::int32_t* order, bool ldlt,
                                    double* work, double* zm) {
  detail::schur_dense_solve_loops(W, Winv, std::integral_constant<std::int32_t, M>{}, order, ldlt, work, zm);
}

}  // namespace jr
