// Supernodal Steps 1, 2, 4 (jrgen/factor.hpp): dense supernodes with Eigen's
// blocked kernels, every other column with the scalar loops of factor_packed().
#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <cmath>

#include "jrgen/factor.hpp"
#include "kernels.hpp"

namespace jr {

namespace {

using DenseBlock = Eigen::Map<Eigen::MatrixXd, 0, Eigen::OuterStride<>>;
using ConstDenseBlock = Eigen::Map<const Eigen::MatrixXd, 0, Eigen::OuterStride<>>;

// Column j of L L^T, right-looking (factor_packed's loop body): pivot test,
// rank-1 update of the ancestors' columns, scaling of the ancestor rows.
bool factor_column(const Model& model, std::int32_t j, double* L, double* Dinv, double tol, double* pivot) {
  const std::int32_t* start = model.M_col_start;
  const std::int32_t* parent = model.dof_parent;
  const std::int32_t cj = start[j];
  const std::int32_t len = start[j + 1] - cj;
  const double d = L[cj];
  if (!(d > tol * Dinv[j])) {
    *pivot = d;
    return false;
  }
  double* col = L + cj + 1;
  const double dinv = 1.0 / d;
  const double rows = detail::row_scale(d, dinv, false, L + cj);
  Dinv[j] = rows;
  detail::update_ancestors(L, start, parent, parent[j], col, dinv, len - 1);
  for (std::int32_t a = 0; a < len - 1; ++a) col[a] *= rows;
  return true;
}

// Packed columns of a supernode <-> its dense block (lower trapezoid).
void packed_to_dense(const Model& model, const Supernode& sn, const double* L, double* S) {
  for (std::int32_t k = 0; k < sn.size; ++k) {
    const double* col = L + model.M_col_start[sn.first + k];
    double* dst = S + sn.offset + static_cast<std::int64_t>(k) * sn.rows + k;
    for (std::int32_t r = 0; r < sn.rows - k; ++r) dst[r] = col[r];
  }
}

}  // namespace

std::int32_t factor_supernodal(const Model& model, const Supernode* nodes, std::int32_t num_nodes, double* L,
                               double* S, double* Dinv, double pivot_tolerance, double* pivot) {
  const std::int32_t* start = model.M_col_start;
  const std::int32_t* parent = model.dof_parent;
  for (std::int32_t j = 0; j < model.nv; ++j) Dinv[j] = L[start[j]];
  std::int32_t next = 0;
  for (std::int32_t j = 0; j < model.nv;) {
    if (next >= num_nodes || j != nodes[next].first) {
      if (!factor_column(model, j, L, Dinv, pivot_tolerance, pivot)) return j;
      ++j;
      continue;
    }
    const Supernode& sn = nodes[next++];
    const std::int32_t s = sn.size, p = sn.rows - sn.size;
    packed_to_dense(model, sn, L, S);
    DenseBlock A(S + sn.offset, sn.rows, s, Eigen::OuterStride<>(sn.rows));
    auto D = A.topRows(s);
    bool ok = Eigen::internal::llt_inplace<double, Eigen::Lower>::blocked(D) < 0;
    for (std::int32_t k = 0; ok && k < s; ++k) {
      const double l = D(k, k);
      ok = l * l > pivot_tolerance * Dinv[sn.first + k];
    }
    if (!ok) {
      // The packed columns still hold M (updated by the descendants): the
      // scalar loops find the failing pivot exactly as factor_packed() would;
      // if they succeed after all (a pivot at the tolerance), their result is used.
      for (std::int32_t k = 0; k < s; ++k)
        if (!factor_column(model, sn.first + k, L, Dinv, pivot_tolerance, pivot)) return sn.first + k;
      packed_to_dense(model, sn, L, S);
      j += s;
      continue;
    }
    for (std::int32_t k = 0; k < s; ++k) Dinv[sn.first + k] = 1.0 / D(k, k);
    if (p > 0) {
      // Panel: L_AS = M_AS L_SS^-T; then M_AA -= L_AS L_AS^T on the packed
      // columns of the ancestor path a_0, a_1, ... (column a_u holds rows a_u..).
      auto P = A.bottomRows(p);
      D.triangularView<Eigen::Lower>().transpose().solveInPlace<Eigen::OnTheRight>(P);
      std::int32_t a = parent[sn.first + s - 1];
      for (std::int32_t u = 0; u < p; ++u, a = parent[a]) {
        Eigen::Map<Eigen::VectorXd> col(L + start[a], p - u);
        col.noalias() -= P.bottomRows(p - u) * P.row(u).transpose();
      }
    }
    j += s;
  }
  return -1;
}

void forward_supernodal(const Model& model, const Supernode* nodes, std::int32_t num_nodes, const double* L,
                        const double* S, const double* Dinv, double* z) {
  const std::int32_t* start = model.M_col_start;
  const std::int32_t* parent = model.dof_parent;
  std::int32_t next = 0;
  for (std::int32_t j = 0; j < model.nv;) {
    if (next >= num_nodes || j != nodes[next].first) {
      z[j] *= Dinv[j];
      const double zj = z[j];
      const double* col = L + start[j] + 1;
      std::int32_t r = parent[j];
      for (std::int32_t a = 0; r >= 0; ++a, r = parent[r]) z[r] -= col[a] * zj;
      ++j;
      continue;
    }
    const Supernode& sn = nodes[next++];
    const std::int32_t s = sn.size, p = sn.rows - sn.size;
    ConstDenseBlock A(S + sn.offset, sn.rows, s, Eigen::OuterStride<>(sn.rows));
    Eigen::Map<Eigen::VectorXd> x(z + sn.first, s);
    A.topRows(s).triangularView<Eigen::Lower>().solveInPlace(x);
    std::int32_t a = parent[sn.first + s - 1];
    for (std::int32_t u = 0; u < p; ++u, a = parent[a]) z[a] -= A.row(s + u).dot(x);
    j += s;
  }
}

void backward_supernodal(const Model& model, const Supernode* nodes, std::int32_t num_nodes, const double* L,
                         const double* S, const double* Dinv, double* z) {
  const std::int32_t* start = model.M_col_start;
  const std::int32_t* parent = model.dof_parent;
  std::int32_t next = num_nodes - 1;
  for (std::int32_t j = model.nv - 1; j >= 0;) {
    if (next < 0 || j != nodes[next].first + nodes[next].size - 1) {
      double sum = z[j];
      const double* col = L + start[j] + 1;
      std::int32_t r = parent[j];
      for (std::int32_t a = 0; r >= 0; ++a, r = parent[r]) sum -= col[a] * z[r];
      z[j] = sum * Dinv[j];
      --j;
      continue;
    }
    const Supernode& sn = nodes[next--];
    const std::int32_t s = sn.size, p = sn.rows - sn.size;
    ConstDenseBlock A(S + sn.offset, sn.rows, s, Eigen::OuterStride<>(sn.rows));
    Eigen::Map<Eigen::VectorXd> x(z + sn.first, s);
    std::int32_t a = parent[sn.first + s - 1];
    for (std::int32_t u = 0; u < p; ++u, a = parent[a]) x.noalias() -= z[a] * A.row(s + u).transpose();
    A.topRows(s).transpose().triangularView<Eigen::Upper>().solveInPlace(x);
    j -= s;
  }
}

}  // namespace jr
