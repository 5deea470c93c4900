// Table-driven Step 3 (constraint_solve.hpp), and the dense Schur kernels
// that the straight-line Step 3 calls too.  Each loop does the products of
// the generated straight-line code (generator/emit/loops.cpp), possibly summed
// in another order: results agree to rounding.
#include "jrgen/constraint_solve.hpp"

#include <cmath>
#include <utility>

namespace jr {
namespace detail {
namespace {

// The loops of the packed dense kernels (the generated code calls them for
// dense parts of more than 32 rows; up to 32 it calls the square-layout
// loops of constraint_solve.hpp, which do the same arithmetic entry by
// entry).  They work on pairs of rows (jr::v2d: one SSE2 or NEON instruction
// per pair) and walk the packed columns with pointers; the arithmetic of
// each entry is that of the scalar formulas in the comments, in the order
// written there.

// x[0..n) -= y[0..n) * f, by pairs.
void axpy_sub(double* __restrict x, const double* __restrict y, double f, std::int32_t n) {
  std::int32_t r = 0;
  for (; r + 2 <= n; r += 2) store2(x + r, load2(x + r) - load2(y + r) * f);
  if (r < n) x[r] -= y[r] * f;
}

// x[0..n) = (x - y f) - z g, by pairs.
void axpy2_sub(double* __restrict x, const double* __restrict y, double f, const double* __restrict z,
                      double g, std::int32_t n) {
  std::int32_t r = 0;
  for (; r + 2 <= n; r += 2) store2(x + r, (load2(x + r) - load2(y + r) * f) - load2(z + r) * g);
  if (r < n) x[r] = (x[r] - y[r] * f) - z[r] * g;
}

// Two columns at once: x0[0..n) = (x0 - y f0) - z g0 and
// x1[0..n) = (x1 - y f1) - z g1, by pairs, each pair of y and z loaded once
// for both (the same arithmetic per entry as axpy2_sub).
void axpy2x2_sub(double* __restrict x0, double* __restrict x1, const double* __restrict y,
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
void scale(double* __restrict x, double f, std::int32_t n) {
  std::int32_t r = 0;
  for (; r + 2 <= n; r += 2) store2(x + r, load2(x + r) * f);
  if (r < n) x[r] *= f;
}

// W[j + r, j] = sum_i A[i, j + r] B[i, j] (i = 0..k-1, the first term
// assigned, the others added in order), two columns at a time: columns j and
// j + 1 share the loads of A for their rows j + 2 and below.
void schur_dense_gram_loops(const double* __restrict A, const double* __restrict B, std::int32_t k, std::int32_t m,
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
template <bool kForward>
std::int32_t schur_dense_factor_loops(double* W, double* Winv, std::int32_t m, bool ldlt, double pivot_tolerance,
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
void schur_dense_forward_loops(const double* W, const double* Winv, std::int32_t m, bool ldlt,
                               double* __restrict work) {
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

void schur_dense_backward_loops(const double* W, const double* Winv, std::int32_t m, bool ldlt,
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
void schur_dense_backward_all(const double* W, const double* Winv, std::int32_t m, const std::int32_t* order, bool ldlt,
                                     double* work, double* zm) {
  schur_dense_backward_loops(W, Winv, m, ldlt, work);
  for (std::int32_t j = 0; j < m; ++j) zm[order[j]] = work[j];
}

void schur_dense_solve_all(const double* W, const double* Winv, std::int32_t m, const std::int32_t* order, bool ldlt,
                                  double* work, double* zm) {
  for (std::int32_t j = 0; j < m; ++j) work[j] = zm[order[j]];
  schur_dense_forward_loops(W, Winv, m, ldlt, work);
  schur_dense_backward_all(W, Winv, m, order, ldlt, work, zm);
}

std::int32_t schur_dense_factor_forward_all(double* W, double* Winv, std::int32_t m, const std::int32_t* order,
                                                   bool ldlt, double pivot_tolerance, double* pivot, double* work,
                                                   const double* zm) {
  for (std::int32_t j = 0; j < m; ++j) work[j] = zm[order[j]];
  return schur_dense_factor_loops<true>(W, Winv, m, ldlt, pivot_tolerance, pivot, work);
}

}  // namespace
}  // namespace detail

void constraint_solve_T(const Model& model, const ConstraintSolveModel& cs, const double* L, const double* Dinv,
                        bool ldlt, double* T) {
  for (std::int32_t g = 0; g < cs.nc; ++g) {
    const std::int32_t c = cs.row_cut[g];
    const std::int32_t first = cs.cut_dof_start[c], n = cs.cut_dof_start[c + 1] - first;
    const std::int32_t* dofs = cs.cut_dofs + first;
    const std::int32_t* parent = cs.cut_parent_index + first;
    double* t = T + cs.row_t_start[g];
    // Common ancestors: Phiq is exactly 0 there (not stored).
    for (std::int32_t i = cs.cut_num_distinct[c]; i < n; ++i) t[i] = 0.0;
    // Right-looking forward substitution: dof i is final once its
    // descendants on the paths are done (they come first, Lemma 2); it is
    // then subtracted from its ancestors, which are all in the list.
    for (std::int32_t i = 0; i < n; ++i) {
      const std::int32_t d = dofs[i];
      if (!ldlt) t[i] *= Dinv[d];
      const double ti = t[i];
      const double* Lcol = L + model.M_col_start[d];
      std::int32_t k = 1;
      for (std::int32_t a = parent[i]; a >= 0; a = parent[a], ++k) t[a] -= Lcol[k] * ti;
    }
  }
}

void constraint_rhs(const ConstraintSolveModel& cs, const double* T, const double* Dinv, const double* z,
                    const double* gamma, bool ldlt, double* V, double* zm) {
  for (std::int32_t g = 0; g < cs.nc; ++g) {
    const std::int32_t c = cs.row_cut[g];
    const std::int32_t first = cs.cut_dof_start[c], n = cs.cut_dof_start[c + 1] - first;
    const std::int32_t* dofs = cs.cut_dofs + first;
    const double* t = T + cs.row_t_start[g];
    double s = 0.0;
    if (ldlt) {
      double* v = V + cs.row_t_start[g];
      for (std::int32_t i = 0; i < n; ++i) {
        v[i] = t[i] * Dinv[dofs[i]];
        s += v[i] * z[dofs[i]];
      }
    } else {
      for (std::int32_t i = 0; i < n; ++i) s += t[i] * z[dofs[i]];
    }
    zm[g] = s - gamma[g];
  }
}

void constraint_schur(const ConstraintSolveModel& cs, const double* A, const double* T, double* W) {
  // Sum over the dofs both rows' cuts share (a merge of two ascending lists).
  auto entry = [&](std::int32_t ga, std::int32_t gb) {
    const std::int32_t ca = cs.row_cut[ga], cb = cs.row_cut[gb];
    const std::int32_t* da = cs.cut_dofs + cs.cut_dof_start[ca];
    const std::int32_t* db = cs.cut_dofs + cs.cut_dof_start[cb];
    const std::int32_t na = cs.cut_dof_start[ca + 1] - cs.cut_dof_start[ca];
    const std::int32_t nb = cs.cut_dof_start[cb + 1] - cs.cut_dof_start[cb];
    const double* a = A + cs.row_t_start[ga];
    const double* b = T + cs.row_t_start[gb];
    double s = 0.0;
    for (std::int32_t i = 0, k = 0; i < na && k < nb;) {
      if (da[i] < db[k]) {
        ++i;
      } else if (db[k] < da[i]) {
        ++k;
      } else {
        s += a[i++] * b[k++];
      }
    }
    return s;
  };
  for (std::int32_t j = 0; j < cs.nc; ++j) {
    const std::int32_t gj = cs.order[j];
    for (std::int32_t e = cs.W_col_start[j]; e < cs.W_col_start[j + 1]; ++e)
      W[e] = cs.W_structural[e] ? entry(cs.order[cs.W_row[e]], gj) : 0.0;
  }
}

std::int32_t constraint_factor(const ConstraintSolveModel& cs, double* W, double* Winv, bool ldlt,
                               double pivot_tolerance, double* pivot) {
  // The pivot test compares with the diagonal of T^T T before elimination:
  // kept in Winv until column j is reached.
  for (std::int32_t j = 0; j < cs.nc; ++j) Winv[j] = W[cs.W_col_start[j]];
  for (std::int32_t j = 0; j < cs.nc; ++j) {
    const std::int32_t begin = cs.W_col_start[j], end = cs.W_col_start[j + 1];
    const double d = W[begin];
    if (!(d > pivot_tolerance * Winv[j])) {
      if (pivot) *pivot = d;
      return cs.order[j];
    }
    double inv;
    if (ldlt) {
      inv = 1.0 / d;
    } else {
      W[begin] = std::sqrt(d);
      inv = 1.0 / W[begin];
    }
    Winv[j] = inv;
    if (!ldlt)
      for (std::int32_t e = begin + 1; e < end; ++e) W[e] *= inv;
    // Outer product of the column into the columns of its rows: for row a of
    // column j, the rows b >= a of column j sit in column a's pattern (fill
    // closed under elimination), found by a merge.  With L D L^T, column j is
    // scaled from the last row up, so the unscaled c_a = L[a,j] d is at hand.
    for (std::int32_t ea = end - 1; ea > begin; --ea) {
      const std::int32_t a = cs.W_row[ea];
      double ca = W[ea];
      if (ldlt) W[ea] = ca * inv;
      else ca = W[ea];
      std::int32_t p = cs.W_col_start[a];  // diagonal of column a
      W[p] -= W[ea] * ca;
      for (std::int32_t eb = ea + 1; eb < end; ++eb) {
        const std::int32_t b = cs.W_row[eb];
        do ++p; while (cs.W_row[p] != b);
        W[p] -= W[eb] * ca;
      }
    }
  }
  return -1;
}

void constraint_solve_lambda(const ConstraintSolveModel& cs, const double* W, const double* Winv, bool ldlt,
                             double* zm) {
  for (std::int32_t j = 0; j < cs.nc; ++j) {  // forward, L_W y = z_m (unit diagonal with ldlt)
    const std::int32_t gj = cs.order[j];
    if (!ldlt) zm[gj] *= Winv[j];
    const double y = zm[gj];
    for (std::int32_t e = cs.W_col_start[j] + 1; e < cs.W_col_start[j + 1]; ++e) zm[cs.order[cs.W_row[e]]] -= W[e] * y;
  }
  for (std::int32_t j = cs.nc - 1; j >= 0; --j) {  // backward, L_W^T lambda = y (D_W^-1 first with ldlt)
    const std::int32_t gj = cs.order[j];
    double s = ldlt ? zm[gj] * Winv[j] : zm[gj];
    // The rows below, farthest first: the row solved just before (the
    // nearest) enters last, as in schur_dense_solve().
    for (std::int32_t e = cs.W_col_start[j + 1] - 1; e > cs.W_col_start[j]; --e) s -= W[e] * zm[cs.order[cs.W_row[e]]];
    zm[gj] = ldlt ? s : s * Winv[j];
  }
}

void constraint_update(const ConstraintSolveModel& cs, const double* T, const double* lambda, double* z) {
  for (std::int32_t g = 0; g < cs.nc; ++g) {
    const std::int32_t c = cs.row_cut[g];
    const std::int32_t first = cs.cut_dof_start[c], n = cs.cut_dof_start[c + 1] - first;
    const std::int32_t* dofs = cs.cut_dofs + first;
    const double* t = T + cs.row_t_start[g];
    const double l = lambda[g];
    for (std::int32_t i = 0; i < n; ++i) z[dofs[i]] -= t[i] * l;
  }
}

// ---- Dense Schur kernels ----

void schur_dense_gram(const double* A, const double* B, std::int32_t k, std::int32_t m, double* W) {
  detail::schur_dense_gram_loops(A, B, k, m, W);
}

std::int32_t schur_dense_factor(double* W, double* Winv, std::int32_t m, bool ldlt, double pivot_tolerance,
                                double* pivot) {
  return detail::schur_dense_factor_loops<false>(W, Winv, m, ldlt, pivot_tolerance, pivot, nullptr);
}

void schur_dense_solve(const double* W, const double* Winv, std::int32_t m, const std::int32_t* order, bool ldlt,
                       double* work, double* zm) {
  detail::schur_dense_solve_all(W, Winv, m, order, ldlt, work, zm);
}

std::int32_t schur_dense_factor_forward(double* W, double* Winv, std::int32_t m, const std::int32_t* order, bool ldlt,
                                        double pivot_tolerance, double* pivot, double* work, const double* zm) {
  return detail::schur_dense_factor_forward_all(W, Winv, m, order, ldlt, pivot_tolerance, pivot, work, zm);
}

void schur_dense_backward(const double* W, const double* Winv, std::int32_t m, const std::int32_t* order, bool ldlt,
                          double* work, double* zm) {
  detail::schur_dense_backward_all(W, Winv, m, order, ldlt, work, zm);
}

}  // namespace jr
