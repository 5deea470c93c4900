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

#include "jrgen/runtime.hpp"
#include "jrgen/simd.hpp"

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

/// Step 3.4 (a), dense: W = L_W L_W^T (or L_W D_W L_W^T) in place,
/// right-looking; Winv[j] = 1 / pivot j.  Returns -1, or the elimination
/// position whose pivot was <= pivot_tolerance * W[j, j] (or NaN), with the
/// pivot in *pivot.
std::int32_t schur_dense_factor(double* W, double* Winv, std::int32_t m, bool ldlt, double pivot_tolerance,
                                double* pivot);

/// Step 3.4 (b), dense: W lambda = z_m in place; z_m in user row order,
/// order[j] = kept row at elimination position j; work holds m doubles.
void schur_dense_solve(const double* W, const double* Winv, std::int32_t m, const std::int32_t* order, bool ldlt,
                       double* work, double* zm);

/// Step 3.4 fused: the factorization of schur_dense_factor() with the
/// forward substitution of z_m riding along (each pivot's unknown is
/// final as soon as the pivot is, and its column updates the rows below in
/// the same pass); work (m doubles) then holds the forward solution in
/// elimination order, and schur_dense_backward() finishes lambda.
std::int32_t schur_dense_factor_forward(double* W, double* Winv, std::int32_t m, const std::int32_t* order, bool ldlt,
                                        double pivot_tolerance, double* pivot, double* work, const double* zm);

/// Step 3.4, the backward substitution after schur_dense_factor_forward():
/// lambda into zm (user row order).
void schur_dense_backward(const double* W, const double* Winv, std::int32_t m, const std::int32_t* order, bool ldlt,
                          double* work, double* zm);

namespace detail {

// ---- The square layout (m known at compile time) ------------------------------
//
// The packed layout starts every column at its diagonal, so a pair of rows
// is aligned in half the columns and the packed loops (constraint_solve.cpp)
// spend much of their time on odd first and last rows.  In the square layout
// column j starts at j * ld, ld = m rounded up to even, so rows 2i and
// 2i + 1 are one pair in every column, and with pivots and trailing columns
// taken two at a time (j and s even) every loop runs over whole pairs.  The
// loops then also compute entries above the diagonal (row s of column
// s + 1) and the padding row m (m odd); those entries are never read for a
// result: they only feed themselves.  The entries the factor reads get
// exactly the arithmetic of the packed loops, in the same order, so the
// factors and the forward solution are bitwise the same.  HMMWV (m = 16,
// k = 6; docs/benchmarks.md, run 13): the Gram part 225 -> 108 ns alone,
// the factor 4670 -> 4147 instructions (260 ns alone either way: likely
// bound by the chain from one pivot to the next), the whole solve 2-9 %
// faster (four A/B runs).
template <std::int32_t M>
inline constexpr std::int32_t kSquareLd = M + (M & 1);

// Step 3.3, dense part, square layout: W[j + r, j] = sum_i A[i, j + r] B[i, j]
// (as schur_dense_gram_loops), columns by pairs and rows by aligned pairs
// from the first column's diagonal.
template <std::int32_t K, std::int32_t M>
inline void schur_square_gram_loops(const double* __restrict A, const double* __restrict B, double* __restrict W) {
  constexpr std::int32_t ld = kSquareLd<M>;
  for (std::int32_t j = 0; j < M; j += 2) {
    double* c0 = W + static_cast<std::int64_t>(j) * ld;
    double* c1 = c0 + ld;
    const bool two = j + 1 < M;  // column j + 1 exists
    std::int32_t r = j;
    for (; r + 1 < M; r += 2) {  // rows r, r + 1
      v2d s0{}, s1{};
      for (std::int32_t i = 0; i < K; ++i) {
        const v2d a = load2(A + static_cast<std::int64_t>(i) * M + r);
        const double* b = B + static_cast<std::int64_t>(i) * M + j;
        if (i == 0) {
          s0 = a * b[0];
          if (two) s1 = a * b[1];
        } else {
          s0 += a * b[0];
          if (two) s1 += a * b[1];
        }
      }
      store2(c0 + r, s0);
      if (two) store2(c1 + r, s1);
    }
    if (r < M) {  // the last row alone (m odd)
      double s0 = 0.0, s1 = 0.0;
      for (std::int32_t i = 0; i < K; ++i) {
        const double a = A[static_cast<std::int64_t>(i) * M + r];
        const double* b = B + static_cast<std::int64_t>(i) * M + j;
        s0 = i == 0 ? a * b[0] : s0 + a * b[0];
        if (two) s1 = i == 0 ? a * b[1] : s1 + a * b[1];
      }
      c0[r] = s0;
      if (two) c1[r] = s1;
    }
  }
}

// Step 3.4 (a), square layout: the factorization (and with kForward the
// forward substitution of z, which holds ld doubles) of
// schur_dense_factor_loops, pivot pairs (j, j + 1) and trailing column pairs
// (s, s + 1) with j and s even, every row loop over aligned pairs.
template <bool kForward, std::int32_t M>
inline std::int32_t schur_square_factor_loops(double* __restrict W, double* __restrict Winv, bool ldlt,
                                              double pivot_tolerance, double* pivot, double* __restrict z) {
  constexpr std::int32_t ld = kSquareLd<M>;
  for (std::int32_t j = 0; j < M; ++j) Winv[j] = W[static_cast<std::int64_t>(j) * ld + j];
  auto take_pivot = [&](double d, std::int32_t j) {
    if (!(d > pivot_tolerance * Winv[j])) {
      *pivot = d;
      return false;
    }
    Winv[j] = 1.0 / d;
    return true;
  };
  double d0 = M > 0 ? W[0] : 0.0;  // pivot of column j, all earlier columns subtracted
  std::int32_t j = 0;
  for (; j + 1 < M; j += 2) {
    double* cj = W + static_cast<std::int64_t>(j) * ld;  // column j (rows from 0)
    double* c1 = cj + ld;                                // column j + 1
    if (!take_pivot(d0, j)) return j;
    const double d0inv = Winv[j];
    const double f = cj[j + 1] * d0inv;
    const double d1 = c1[j + 1] - cj[j + 1] * f;
    c1[j + 1] = d1;
    for (std::int32_t r = j + 2; r < ld; r += 2) store2(c1 + r, load2(c1 + r) - load2(cj + r) * f);
    double g0 = 0.0;
    if (kForward) {
      g0 = z[j] * d0inv;
      z[j + 1] -= cj[j + 1] * g0;
    }
    if (ldlt) cj[j + 1] = f;
    if (!take_pivot(d1, j + 1)) return j + 1;
    const double d1inv = Winv[j + 1];
    if (kForward) {
      const double g1 = z[j + 1] * d1inv;
      for (std::int32_t r = j + 2; r < ld; r += 2)
        store2(z + r, (load2(z + r) - load2(cj + r) * g0) - load2(c1 + r) * g1);
    }
    // Trailing columns s, s + 1 (s + 1 = m: the padding column, m odd):
    // rows s.. of both, so the diagonal entry of s (for s = j + 2 the next
    // pivot) rides in the first pair.
    for (std::int32_t s = j + 2; s < M; s += 2) {
      double* cs = W + static_cast<std::int64_t>(s) * ld;
      double* cs1 = cs + ld;
      const double f0 = cj[s] * d0inv, f1 = c1[s] * d1inv;
      const double h0 = cj[s + 1] * d0inv, h1 = c1[s + 1] * d1inv;
      for (std::int32_t r = s; r < ld; r += 2) {
        const v2d y = load2(cj + r), w = load2(c1 + r);
        store2(cs + r, (load2(cs + r) - y * f0) - w * f1);
        store2(cs1 + r, (load2(cs1 + r) - y * h0) - w * h1);
      }
      if (ldlt) {
        cj[s] = f0;
        c1[s] = f1;
        cj[s + 1] = h0;
        c1[s + 1] = h1;
      }
    }
    if (j + 2 < M) d0 = W[static_cast<std::int64_t>(j + 2) * ld + j + 2];  // the next pass's pivot
  }
  if (j < M && !take_pivot(d0, j)) return j;  // the last column alone (m odd)
  if (!ldlt) {
    for (std::int32_t i = 0; i < M; ++i) {
      double* c = W + static_cast<std::int64_t>(i) * ld;
      const double l = std::sqrt(c[i]);
      const double inv = l * Winv[i];  // sqrt(d) / d
      Winv[i] = inv;
      if (kForward) z[i] *= inv;
      // Rows i + 1 .. ld - 1 by pairs; for i even the pair (i, i + 1),
      // then the diagonal entry set.
      for (std::int32_t r = i & ~1; r < ld; r += 2) store2(c + r, load2(c + r) * inv);
      c[i] = l;
    }
  }
  return -1;
}

// Step 3.4 (b), square layout: the backward substitution of
// schur_dense_backward_loops on x (elimination order), by pairs of unknowns
// (j, j + 1), j even: both dot products over the rows j + 2 .. m - 1 share
// the loads of x, the farthest rows first and the pair solved last
// (j + 2, j + 3: kept in a register) at the end, so that the serial chain
// from one pair to the next is a product, a sum and the scalings.
template <std::int32_t M>
inline void schur_square_backward_loops(const double* __restrict W, const double* __restrict Winv, bool ldlt,
                                        double* __restrict x) {
  constexpr std::int32_t ld = kSquareLd<M>;
  constexpr std::int32_t last_pair = (M & ~1) - 2;  // first row of the last pair of unknowns
  v2d next{};                                       // x[j + 2], x[j + 3]
  double lone = 0.0;                                // x[m - 1], m odd
  if constexpr ((M & 1) != 0) {
    lone = x[M - 1] * Winv[M - 1];  // no rows below: y / d (L D L^T) or y / l (L L^T)
    x[M - 1] = lone;
  }
  for (std::int32_t j = last_pair; j >= 0; j -= 2) {
    const double* c0 = W + static_cast<std::int64_t>(j) * ld;
    const double* c1 = c0 + ld;
    double t0 = 0.0, t1 = 0.0;  // sum over rows r > j + 1 of L[r, j] x[r] and L[r, j + 1] x[r]
    if (j < last_pair) {
      v2d a0{}, a1{};
      for (std::int32_t r = j + 4; r + 1 < M; r += 2) {
        const v2d xr = load2(x + r);
        a0 += load2(c0 + r) * xr;
        a1 += load2(c1 + r) * xr;
      }
      a0 += load2(c0 + j + 2) * next;
      a1 += load2(c1 + j + 2) * next;
      t0 = sum2(a0);
      t1 = sum2(a1);
    }
    if constexpr ((M & 1) != 0) {
      t0 += c0[M - 1] * lone;
      t1 += c1[M - 1] * lone;
    }
    double s1 = ldlt ? x[j + 1] * Winv[j + 1] : x[j + 1];
    s1 -= t1;
    const double x1 = ldlt ? s1 : s1 * Winv[j + 1];
    double s0 = ldlt ? x[j] * Winv[j] : x[j];
    s0 = (s0 - t0) - c0[j + 1] * x1;
    const double x0 = ldlt ? s0 : s0 * Winv[j];
    next = set2(x0, x1);
    store2(x + j, next);
  }
}

template <std::int32_t M>
inline std::int32_t schur_square_factor_forward_all(double* W, double* Winv, const std::int32_t* order, bool ldlt,
                                                    double pivot_tolerance, double* pivot, double* work,
                                                    const double* zm) {
  for (std::int32_t j = 0; j < M; ++j) work[j] = zm[order[j]];
  if constexpr ((M & 1) != 0) work[M] = 0.0;  // the padding row
  return schur_square_factor_loops<true, M>(W, Winv, ldlt, pivot_tolerance, pivot, work);
}

template <std::int32_t M>
inline void schur_square_backward_all(const double* W, const double* Winv, const std::int32_t* order, bool ldlt,
                                      double* work, double* zm) {
  schur_square_backward_loops<M>(W, Winv, ldlt, work);
  for (std::int32_t j = 0; j < M; ++j) zm[order[j]] = work[j];
}

}  // namespace detail

/// The dense Steps 3.3 and 3.4 in the square layout, for m known at compile
/// time (what generated solvers with m <= 32 call): W holds ld x ld doubles,
/// ld = m rounded up to even (jr::detail::kSquareLd<m>), column j from
/// j * ld, the lower triangle in use; work holds ld doubles.  The same
/// arithmetic as schur_dense_gram() and schur_dense_factor_forward() entry
/// by entry (bitwise the same W, factor and forward solution), and
/// schur_dense_backward()'s products and subtractions in another order.
template <std::int32_t K, std::int32_t M>
inline void schur_square_gram_fixed(const double* A, const double* B, double* W) {
  detail::schur_square_gram_loops<K, M>(A, B, W);
}

template <std::int32_t M>
inline std::int32_t schur_square_factor_forward_fixed(double* W, double* Winv, const std::int32_t* order, bool ldlt,
                                                      double pivot_tolerance, double* pivot, double* work,
                                                      const double* zm) {
  return detail::schur_square_factor_forward_all<M>(W, Winv, order, ldlt, pivot_tolerance, pivot, work, zm);
}

template <std::int32_t M>
inline void schur_square_backward_fixed(const double* W, const double* Winv, const std::int32_t* order, bool ldlt,
                                        double* work, double* zm) {
  detail::schur_square_backward_all<M>(W, Winv, order, ldlt, work, zm);
}

}  // namespace jr
