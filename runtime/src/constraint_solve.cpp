// Table-driven Step 3 (constraint_solve.hpp), and the dense Schur kernels
// that the straight-line Step 3 calls too.  Each loop does the products of
// the generated straight-line code (generator/emit/loops.cpp), possibly summed
// in another order: results agree to rounding.
#include "jrgen/constraint_solve.hpp"

#include <cmath>

namespace jr {

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
