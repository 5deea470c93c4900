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
#include <utility>

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

// The loops of the packed dense kernels (the generated code calls them for
// dense parts of more than 32 rows; up to 32 it calls the square-layout loops
// further below, which do the same arithmetic entry by entry).  They work on
// pairs of rows (jr::v2d: one SSE2 or NEON instruction per pair) and walk the
// packed columns with pointers; the arithmetic of each entry is that of the
// scalar formulas in the comments, in the order written there.

// x[0..n) -= y[0..n) * f, by pairs.
inline void axpy_sub(double* __restrict x, const double* __restrict y, double f, std::int32_t n) {
  std::int32_t r = 0;
  for (; r + 2 <= n; r += 2) store2(x + r, load2(x + r) - load2(y + r) * f);
  if (r < n) x[r] -= y[r] * f;
}

// x[0..n) = (x - y f) - z g, by pairs.
inline void axpy2_sub(double* __restrict x, const double* __restrict y, double f, const double* __restrict z,
                      double g, std::int32_t n) {
  std::int32_t r = 0;
  for (; r + 2 <= n; r += 2) store2(x + r, (load2(x + r) - load2(y + r) * f) - load2(z + r) * g);
  if (r < n) x[r] = (x[r] - y[r] * f) - z[r] * g;
}

// Two columns at once: x0[0..n) = (x0 - y f0) - z g0 and
// x1[0..n) = (x1 - y f1) - z g1, by pairs, each pair of y and z loaded once
// for both (the same arithmetic per entry as axpy2_sub).
inline void axpy2x2_sub(double* __restrict x0, double* __restrict x1, const double* __restrict y,
                        const double* __restrict z, double f0, double g0, double f1, double g1, std::int32_t n) {
  std::int32_t r = 0;
  for (; r + 2 <= n; r += 2) {
    const v2d yr = load2(y + r), zr = load2(z + r);
    store2(x0 + r, (load2(x0 + r) - yr * f0) - zr * g0);
    store2(x1 + r, (load2(x1 + r) - yr * f1) - zr * g1);
  }
  if (r < n) {
    x0[r] = (x0[r] - y[r] * f0) - z[r] * g0;
    x1[r] = (x1[r] - y[r] * f1) - z[r] * g1;
  }
}

// x[0..n) *= f, by pairs.
inline void scale(double* __restrict x, double f, std::int32_t n) {
  std::int32_t r = 0;
  for (; r + 2 <= n; r += 2) store2(x + r, load2(x + r) * f);
  if (r < n) x[r] *= f;
}

// W[j + r, j] = sum_i A[i, j + r] B[i, j] (i = 0..k-1, the first term
// assigned, the others added in order), two columns at a time: columns j and
// j + 1 share the loads of A for their rows j + 2 and below.
template <class K, class Size>
inline void schur_dense_gram_loops(const double* __restrict A, const double* __restrict B, K k, Size m,
                                   double* __restrict W) {
  double* col = W;
  std::int32_t j = 0;
  for (; j + 1 < m; j += 2) {
    double* col1 = col + (m - j);  // column j + 1, from its diagonal
    // The three entries of rows j and j + 1.
    double wjj = 0.0, wj1j = 0.0, wj1j1 = 0.0;
    for (std::int32_t i = 0; i < k; ++i) {
      const double* a = A + static_cast<std::int64_t>(i) * m + j;
      const double* b = B + static_cast<std::int64_t>(i) * m + j;
      if (i == 0) {
        wjj = a[0] * b[0];
        wj1j = a[1] * b[0];
        wj1j1 = a[1] * b[1];
      } else {
        wjj += a[0] * b[0];
        wj1j += a[1] * b[0];
        wj1j1 += a[1] * b[1];
      }
    }
    col[0] = wjj;
    col[1] = wj1j;
    col1[0] = wj1j1;
    // Rows j + 2 .. m - 1 of both columns: a pair of rows (value = load2)
    // or the odd last one (value = the double itself) starting at A + at.
    auto rows = [&](auto value, std::int64_t at) {
      decltype(value(at)) s0{}, s1{};
      for (std::int32_t i = 0; i < k; ++i) {
        const std::int64_t row = static_cast<std::int64_t>(i) * m;
        const auto a = value(row + at);
        if (i == 0) {
          s0 = a * B[row + j];
          s1 = a * B[row + j + 1];
        } else {
          s0 += a * B[row + j];
          s1 += a * B[row + j + 1];
        }
      }
      return std::make_pair(s0, s1);
    };
    const std::int32_t n = m - j - 2;
    std::int32_t r = 0;
    for (; r + 2 <= n; r += 2) {
      const auto [s0, s1] = rows([&](std::int64_t p) { return load2(A + p); }, j + 2 + r);
      store2(col + 2 + r, s0);
      store2(col1 + 1 + r, s1);
    }
    if (r < n) {
      const auto [s0, s1] = rows([&](std::int64_t p) { return A[p]; }, j + 2 + r);
      col[2 + r] = s0;
      col1[1 + r] = s1;
    }
    col = col1 + (m - j - 1);
  }
  if (j < m) {  // the last column alone (m odd)
    double s = 0.0;
    for (std::int32_t i = 0; i < k; ++i) {
      const std::int64_t at = static_cast<std::int64_t>(i) * m + j;
      s = i == 0 ? A[at] * B[at] : s + A[at] * B[at];
    }
    col[0] = s;
  }
}

// Right-looking, in the order of L D L^T: pivot d_j = w_jj, then every
// later column s gets w[r, s] -= w[r, j] * f_s with f_s = w[s, j] / d_j
// (one multiplication by 1/d_j), two pivot columns per pass over the
// trailing columns, which are updated two at a time.  The next pivots are
// carried in registers (d0 of the next pass is the first trailing
// diagonal, d1 the next column's diagonal), so the serial chain from one
// pivot to the next is one division, two multiplications and a
// subtraction, without a store and a reload; the square root of L L^T and
// its scaling of column j (L[r, j] = w[r, j] / sqrt(d_j)) come after the
// elimination, off that chain.  With L D L^T the f_s are the factor's
// entries themselves and are stored in place of w.  Winv holds the
// original diagonal until pivot j replaces it by 1 / d_j (and, L L^T, then
// 1 / sqrt(d_j)).
//
// kForward: z (elimination order) is forward-substituted in the same
// passes: u_j = z_j is final with pivot j, and the rows below get
// z_r -= w[r, j] * g_j, g_j = u_j / d_j (the unit factor's entry times
// u_j); L L^T then takes y_j = u_j / sqrt(d_j) in the scaling pass.
template <bool kForward, class Size>
inline std::int32_t schur_dense_factor_loops(double* W, double* Winv, Size m, bool ldlt, double pivot_tolerance,
                                             double* pivot, double* __restrict z) {
  {
    const double* diag = W;
    for (std::int32_t j = 0; j < m; ++j) {
      Winv[j] = diag[0];
      diag += m - j;
    }
  }
  // Pivot j, value d: 1 / d into Winv[j], or false if not positive.
  auto take_pivot = [&](double d, std::int32_t j) {
    if (!(d > pivot_tolerance * Winv[j])) {
      *pivot = d;
      return false;
    }
    Winv[j] = 1.0 / d;
    return true;
  };
  double* cj = W;
  double d0 = m > 0 ? W[0] : 0.0;  // pivot of column j, all earlier columns subtracted
  std::int32_t j = 0;
  for (; j + 1 < m; j += 2) {
    const std::int32_t len = m - j;  // rows j..m-1 of column j
    double* c1 = cj + len;           // column j + 1: rows j+1..m-1
    if (!take_pivot(d0, j)) return j;
    const double d0inv = Winv[j];
    const double f = cj[1] * d0inv;
    const double d1 = c1[0] - cj[1] * f;
    c1[0] = d1;
    axpy_sub(c1 + 1, cj + 2, f, len - 2);
    double g0 = 0.0;
    if (kForward) {
      g0 = z[j] * d0inv;
      z[j + 1] -= cj[1] * g0;
    }
    if (ldlt) cj[1] = f;
    if (!take_pivot(d1, j + 1)) return j + 1;
    const double d1inv = Winv[j + 1];
    if (kForward && len > 2) axpy2_sub(z + j + 2, cj + 2, g0, c1 + 1, z[j + 1] * d1inv, len - 2);
    // The trailing columns two at a time (s, s + 1): the diagonal entry of
    // column s first (for s = 2, the next pass's pivot), then the rows both
    // columns share, each pair of entries of the pivot columns loaded once.
    // The last column alone (len - 2 odd) has its diagonal entry only.
    double* cs = c1 + (len - 1);  // column j + s from its diagonal
    for (std::int32_t s = 2; s < len; s += 2) {
      const std::int32_t n = len - s;  // entries of column s; column s + 1 has n - 1
      const double f0 = cj[s] * d0inv, f1 = c1[s - 1] * d1inv;
      const double diag = (cs[0] - cj[s] * f0) - c1[s - 1] * f1;
      cs[0] = diag;
      if (s == 2) d0 = diag;  // the next pass's pivot
      if (n > 1) {
        const double h0 = cj[s + 1] * d0inv, h1 = c1[s] * d1inv;
        axpy2x2_sub(cs + 1, cs + n, cj + s + 1, c1 + s, f0, f1, h0, h1, n - 1);
        if (ldlt) {
          cj[s + 1] = h0;
          c1[s] = h1;
        }
      }
      if (ldlt) {
        cj[s] = f0;
        c1[s - 1] = f1;
      }
      cs += 2 * n - 1;
    }
    cj = c1 + (len - 1);
  }
  if (j < m && !take_pivot(d0, j)) return j;  // the last column alone (m odd)
  if (!ldlt) {
    double* c = W;
    for (std::int32_t i = 0; i < m; ++i) {
      const double l = std::sqrt(c[0]);
      const double inv = l * Winv[i];  // sqrt(d) / d
      c[0] = l;
      Winv[i] = inv;
      if (kForward) z[i] *= inv;
      scale(c + 1, inv, m - i - 1);
      c += m - i;
    }
  }
  return -1;
}

// Both substitutions keep the two rows next to the one being solved in
// registers, so that the serial chain from one unknown to the next is a
// product, a subtraction and the scaling, never a store and a reload:
//  * forward, by columns: y_j final, then row j + 1 (register a) and row
//    j + 2 (register b, read from memory, where the columns up to j - 1
//    have already been subtracted) less L[., j] y_j, rows j + 3 and below
//    in memory, by pairs;
//  * backward, by dot products: row j less its rows j + 3 and below (pairs,
//    all solved at least three steps before), then less row j + 2 and, last,
//    row j + 1, the two most recent unknowns, kept in registers.
// Each entry gets its products in the order of the unrolled solve's
// arithmetic count (one product and one subtraction each).  Both work in
// place on work (elimination order).
template <class Size>
inline void schur_dense_forward_loops(const double* W, const double* Winv, Size m, bool ldlt, double* __restrict work) {
  const double* cj = W;
  double a = m > 0 ? work[0] : 0.0, b = m > 1 ? work[1] : 0.0;
  for (std::int32_t j = 0; j < m; ++j) {
    const std::int32_t len = m - j;
    const double y = ldlt ? a : a * Winv[j];
    work[j] = y;
    if (len > 1) a = b - cj[1] * y;
    if (len > 2) b = work[j + 2] - cj[2] * y;
    if (len > 3) axpy_sub(work + j + 3, cj + 3, y, len - 3);
    cj += len;
  }
}

template <class Size>
inline void schur_dense_backward_loops(const double* W, const double* Winv, Size m, bool ldlt,
                                       double* __restrict work) {
  const double* cj = W + static_cast<std::int64_t>(m) * (m + 1) / 2;
  double x1 = 0.0, x2 = 0.0;  // the unknowns at positions j + 1 and j + 2
  for (std::int32_t j = m - 1; j >= 0; --j) {
    const std::int32_t len = m - j;
    cj -= len;
    double s = ldlt ? work[j] * Winv[j] : work[j];
    if (len > 3) {
      const std::int32_t n = len - 3;  // rows j + 3 .. m - 1
      const double* c = cj + 3;
      const double* x = work + j + 3;
      double t;
      if (n >= 2) {
        v2d acc = load2(c) * load2(x);
        std::int32_t r = 2;
        for (; r + 2 <= n; r += 2) acc += load2(c + r) * load2(x + r);
        t = sum2(acc);
        if (r < n) t += c[r] * x[r];
      } else {
        t = c[0] * x[0];
      }
      s -= t;
    }
    if (len > 2) s -= cj[2] * x2;
    if (len > 1) s -= cj[1] * x1;
    const double xj = ldlt ? s : s * Winv[j];
    work[j] = xj;
    x2 = x1;
    x1 = xj;
  }
}

// The public kernels below and in constraint_solve.cpp: z_m (user row
// order) gathered into work (elimination order) and lambda scattered back.
template <class Size>
inline void schur_dense_backward_all(const double* W, const double* Winv, Size m, const std::int32_t* order, bool ldlt,
                                     double* work, double* zm) {
  schur_dense_backward_loops(W, Winv, m, ldlt, work);
  for (std::int32_t j = 0; j < m; ++j) zm[order[j]] = work[j];
}

template <class Size>
inline void schur_dense_solve_all(const double* W, const double* Winv, Size m, const std::int32_t* order, bool ldlt,
                                  double* work, double* zm) {
  for (std::int32_t j = 0; j < m; ++j) work[j] = zm[order[j]];
  schur_dense_forward_loops(W, Winv, m, ldlt, work);
  schur_dense_backward_all(W, Winv, m, order, ldlt, work, zm);
}

template <class Size>
inline std::int32_t schur_dense_factor_forward_all(double* W, double* Winv, Size m, const std::int32_t* order,
                                                   bool ldlt, double pivot_tolerance, double* pivot, double* work,
                                                   const double* zm) {
  for (std::int32_t j = 0; j < m; ++j) work[j] = zm[order[j]];
  return schur_dense_factor_loops<true>(W, Winv, m, ldlt, pivot_tolerance, pivot, work);
}

// ---- The square layout (m known at compile time) ------------------------------
//
// The packed layout starts every column at its diagonal, so a pair of rows
// is aligned in half the columns and the loops above spend much of their
// time on odd first and last rows.  In the square layout column j starts
// at j * ld, ld = m rounded up to even, so rows 2i and 2i + 1 are one pair in
// every column, and with pivots and trailing columns taken two at a time
// (j and s even) every loop runs over whole pairs.  The loops then also
// compute entries above the diagonal (row s of column s + 1) and the
// padding row m (m odd); those entries are never read for a result: they
// only feed themselves.  The entries the factor reads get exactly the
// arithmetic of schur_dense_factor_loops above, in the same order, so the
// factors and the forward solution are bitwise the same.  HMMWV (m = 16, k =
// 6; docs/benchmarks.md, run 13): the Gram part 225 -> 108 ns alone, the
// factor 4670 -> 4147 instructions (260 ns alone either way: likely
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
