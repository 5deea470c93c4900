// Subtree kernels of Steps 1, 2, 4 (jrgen/factor.hpp; Corollary 3 of Section
// 5).  The loops are those of factor_packed(), forward_packed() and
// backward_packed() restricted to a range of dofs; the generated code runs
// the subtrees as OpenMP tasks (the runtime itself has no threads).
#include <cmath>

#include "jrgen/factor.hpp"
#include "kernels.hpp"

namespace jr {

namespace {

// Column j, right-looking (as factor_packed()).  The first `own` ancestors'
// columns are updated in place; the updates of the ancestors after them (a
// subtree's path, numbered from 0) are accumulated into U (path x path,
// column-major).  own = depth(j) and U = nullptr update everything in place.
bool factor_column(const Model& model, std::int32_t j, double* L, double* Dinv, bool ldlt, double tol,
                   double* pivot, std::int32_t own, std::int32_t path, double* U) {
  const std::int32_t* start = model.M_col_start;
  const std::int32_t* parent = model.dof_parent;
  const std::int32_t cj = start[j];
  const std::int32_t na = start[j + 1] - cj - 1;  // ancestors
  const double d = L[cj];
  if (!(d > tol * Dinv[j])) {
    *pivot = d;
    return false;
  }
  double* col = L + cj + 1;
  const double scale = 1.0 / d;
  const double rows = detail::row_scale(d, scale, ldlt, L + cj);
  Dinv[j] = rows;
  // The update is col[b] * (col[a] / d) with the rows not yet scaled (row_scale).
  std::int32_t s = parent[j];
  for (std::int32_t a = 0; a < own; ++a, s = parent[s]) {
    const double f = col[a] * scale;
    detail::subtract_scaled(L + start[s], col + a, f, na - a);
  }
  for (std::int32_t a = own; a < na; ++a) {
    const double f = col[a] * scale;
    double* cu = U + static_cast<std::int64_t>(a - own) * path - own;
    for (std::int32_t b = a; b < na; ++b) cu[b] += col[b] * f;
  }
  for (std::int32_t a = 0; a < na; ++a) col[a] *= rows;
  return true;
}

std::int32_t depth(const Model& model, std::int32_t j) { return model.M_col_start[j + 1] - model.M_col_start[j] - 1; }

void forward_row(const Model& model, std::int32_t j, const double* L, const double* Dinv, bool ldlt, double* z,
                 std::int32_t own, double* u) {
  if (!ldlt) z[j] *= Dinv[j];
  const double zj = z[j];
  const double* col = L + model.M_col_start[j] + 1;
  const std::int32_t na = depth(model, j);
  std::int32_t r = model.dof_parent[j];
  for (std::int32_t a = 0; a < own; ++a, r = model.dof_parent[r]) z[r] -= col[a] * zj;
  for (std::int32_t a = own; a < na; ++a) u[a - own] += col[a] * zj;
}

void backward_row(const Model& model, std::int32_t j, const double* L, const double* Dinv, bool ldlt, double* z) {
  double s = ldlt ? z[j] * Dinv[j] : z[j];
  const double* col = L + model.M_col_start[j] + 1;
  std::int32_t r = model.dof_parent[j];
  for (std::int32_t a = 0; r >= 0; ++a, r = model.dof_parent[r]) s -= col[a] * z[r];
  z[j] = ldlt ? s : s * Dinv[j];
}

}  // namespace

void save_diagonal(const Model& model, const double* L, double* Dinv) {
  for (std::int32_t j = 0; j < model.nv; ++j) Dinv[j] = L[model.M_col_start[j]];
}

std::int32_t factor_subtree(const Model& model, const Subtree& t, double* L, double* Dinv, bool ldlt,
                            double pivot_tolerance, double* pivot, double* U) {
  for (std::int64_t k = 0; k < static_cast<std::int64_t>(t.path) * t.path; ++k) U[k] = 0.0;
  for (std::int32_t j = t.first; j <= t.root; ++j)
    if (!factor_column(model, j, L, Dinv, ldlt, pivot_tolerance, pivot, depth(model, j) - t.path, t.path, U))
      return j;
  return -1;
}

void apply_subtree_update(const Model& model, const Subtree& t, const double* U, double* L) {
  std::int32_t a = model.dof_parent[t.root];
  for (std::int32_t u = 0; u < t.path; ++u, a = model.dof_parent[a]) {
    double* col = L + model.M_col_start[a];
    const double* cu = U + static_cast<std::int64_t>(u) * t.path;
    for (std::int32_t v = u; v < t.path; ++v) col[v - u] -= cu[v];
  }
}

std::int32_t factor_separator(const Model& model, const Subtree* trees, std::int32_t num_trees, double* L,
                              double* Dinv, bool ldlt, double pivot_tolerance, double* pivot) {
  std::int32_t next = 0;
  for (std::int32_t j = 0; j < model.nv; ++j) {
    if (next < num_trees && j == trees[next].first) {
      j = trees[next++].root;
      continue;
    }
    if (!factor_column(model, j, L, Dinv, ldlt, pivot_tolerance, pivot, depth(model, j), 0, nullptr)) return j;
  }
  return -1;
}

void forward_subtree(const Model& model, const Subtree& t, const double* L, const double* Dinv, bool ldlt,
                     double* z, double* u) {
  for (std::int32_t k = 0; k < t.path; ++k) u[k] = 0.0;
  for (std::int32_t j = t.first; j <= t.root; ++j) forward_row(model, j, L, Dinv, ldlt, z, depth(model, j) - t.path, u);
}

void apply_subtree_forward(const Model& model, const Subtree& t, const double* u, double* z) {
  std::int32_t a = model.dof_parent[t.root];
  for (std::int32_t k = 0; k < t.path; ++k, a = model.dof_parent[a]) z[a] -= u[k];
}

void forward_separator(const Model& model, const Subtree* trees, std::int32_t num_trees, const double* L,
                       const double* Dinv, bool ldlt, double* z) {
  std::int32_t next = 0;
  for (std::int32_t j = 0; j < model.nv; ++j) {
    if (next < num_trees && j == trees[next].first) {
      j = trees[next++].root;
      continue;
    }
    forward_row(model, j, L, Dinv, ldlt, z, depth(model, j), nullptr);
  }
}

void backward_separator(const Model& model, const Subtree* trees, std::int32_t num_trees, const double* L,
                        const double* Dinv, bool ldlt, double* z) {
  std::int32_t next = num_trees - 1;
  for (std::int32_t j = model.nv - 1; j >= 0; --j) {
    if (next >= 0 && j == trees[next].root) {
      j = trees[next--].first;
      continue;
    }
    backward_row(model, j, L, Dinv, ldlt, z);
  }
}

void backward_subtree(const Model& model, const Subtree& t, const double* L, const double* Dinv, bool ldlt,
                      double* z) {
  for (std::int32_t j = t.root; j >= t.first; --j) backward_row(model, j, L, Dinv, ldlt, z);
}

}  // namespace jr
