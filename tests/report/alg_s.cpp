#include "alg_s.hpp"

#include <algorithm>
#include <cmath>

namespace jrgen::report {

AlgS::AlgS(const topology::Tree& tree, const double* M, const double* Q, const double* Phiq, const double* gamma)
    : M_(M), Q_(Q), Phiq_(Phiq), gamma_(gamma) {
  rt_ = std::make_unique<analysis::RuntimeModel>(tree, Eigen::Vector3d::Zero());
  model_ = &rt_->model();
  nv_ = tree.nv;
  nc_ = tree.nc();
  dof_user_.assign(tree.dof_user.begin(), tree.dof_user.end());
  // Packed column j holds rows j, parent(j), parent(parent(j)), ... (eq. 18).
  M_src_.resize(tree.nnz());
  for (int j = 0; j < nv_; ++j) {
    int k = tree.M_col_start[j];
    for (int r = j; r >= 0; r = tree.dof_parent[r]) M_src_[k++] = tree.dof_user[r] + nv_ * tree.dof_user[j];
  }
  // Lemma 3: the rows of T for the kept rows of cut c are the dofs on the
  // paths from k and l to the base (tree.cuts[c].dofs, ascending).
  std::int32_t row = 0, t = 0;
  for (const topology::Cut& c : tree.cuts) {
    CutBlock b;
    b.dofs.assign(c.dofs.begin(), c.dofs.end());
    b.first_row = row;
    b.rows = static_cast<std::int32_t>(c.kept_rows.size());
    b.T_start = t;
    for (std::int32_t r = 0; r < b.rows; ++r)
      for (std::int32_t d : b.dofs) T_src_.push_back(row + r + nc_ * tree.dof_user[d]);
    row += b.rows;
    t += b.rows * static_cast<std::int32_t>(b.dofs.size());
    cuts_.push_back(std::move(b));
  }
  // Step 3.3 pattern: (T^T T)_{ab} is structurally zero unless the dof lists
  // of cuts a and b intersect.
  for (std::int32_t a = 0; a < static_cast<std::int32_t>(cuts_.size()); ++a)
    for (std::int32_t b = 0; b <= a; ++b) {
      Overlap o{a, b, {}, {}};
      const auto& da = cuts_[a].dofs;
      const auto& db = cuts_[b].dofs;
      for (std::size_t i = 0, j = 0; i < da.size() && j < db.size();) {
        if (da[i] < db[j]) {
          ++i;
        } else if (db[j] < da[i]) {
          ++j;
        } else {
          o.pos_a.push_back(static_cast<std::int32_t>(i++));
          o.pos_b.push_back(static_cast<std::int32_t>(j++));
        }
      }
      if (!o.pos_a.empty()) overlaps_.push_back(std::move(o));
    }
  // Row access for Steps 2 and 4, as the generated table-driven solvers have it.
  entry_row_.resize(tree.nnz());
  row_start_.resize(nv_ + 1);
  row_entry_.resize(std::max(tree.nnz() - nv_, 1));
  row_col_.resize(row_entry_.size());
  jr::fill_packed_rows(*model_, entry_row_.data(), row_start_.data(), row_entry_.data(), row_col_.data());
  rows_ = {entry_row_.data(), row_start_.data(), row_entry_.data(), row_col_.data()};
  L_.resize(tree.nnz());
  Dinv_.resize(nv_);
  z_.resize(nv_);
  T_.resize(t);
  zm_.resize(nc_);
  W_.assign(static_cast<std::size_t>(nc_) * nc_, 0.0);  // zero blocks stay zero
  G_.resize(W_.size());
  lambda_.resize(nc_);
  y_.resize(nv_);
  x_.resize(nv_);
  w_.assign(nv_, 0.0);
  qdd_.resize(nv_);
}

int AlgS::step1() {
  for (std::size_t k = 0; k < M_src_.size(); ++k) L_[k] = M_[M_src_[k]];
  double pivot = 0;
  return jr::factor_packed(*model_, L_.data(), Dinv_.data(), false, 1e-14, &pivot) < 0 ? jr::kSuccess
                                                                                     : jr::kMassNotPositiveDefinite;
}

void AlgS::step2() {
  for (int j = 0; j < nv_; ++j) z_[j] = Q_[dof_user_[j]];
  jr::forward_packed(*model_, rows_, L_.data(), Dinv_.data(), false, z_.data());
}

void AlgS::step3_1() {
  const std::int32_t* parent = model_->dof_parent;
  const std::int32_t* start = model_->M_col_start;
  double* w = w_.data();
  for (const CutBlock& b : cuts_) {
    const std::size_t nd = b.dofs.size();
    for (std::int32_t r = 0; r < b.rows; ++r) {
      double* t = T_.data() + b.T_start + r * nd;
      const std::int32_t* src = T_src_.data() + b.T_start + r * nd;
      // Scatter the row of Phiq over its Lemma 3 dofs, forward-substitute
      // column by column (descendants first, eq. 18: column j of L touches
      // only j's ancestors, which are all in the list), gather T's column.
      for (std::size_t i = 0; i < nd; ++i) w[b.dofs[i]] = Phiq_[src[i]];
      for (std::size_t i = 0; i < nd; ++i) {
        const std::int32_t j = b.dofs[i];
        const double tj = w[j] * Dinv_[j];
        w[j] = tj;
        const double* col = L_.data() + start[j];
        std::int32_t k = 1;
        for (std::int32_t a = parent[j]; a >= 0; a = parent[a]) w[a] -= col[k++] * tj;
      }
      for (std::size_t i = 0; i < nd; ++i) t[i] = w[b.dofs[i]];
    }
  }
}

void AlgS::step3_2() {
  for (const CutBlock& b : cuts_) {
    const std::size_t nd = b.dofs.size();
    for (std::int32_t r = 0; r < b.rows; ++r) {
      const double* t = T_.data() + b.T_start + r * nd;
      double s = -gamma_[b.first_row + r];
      for (std::size_t i = 0; i < nd; ++i) s += t[i] * z_[b.dofs[i]];
      zm_[b.first_row + r] = s;
    }
  }
}

void AlgS::step3_3() {
  // Lower triangle of W = T^T T (column-major, nc x nc), over overlapping pairs only.
  for (const Overlap& o : overlaps_) {
    const CutBlock& A = cuts_[o.a];
    const CutBlock& B = cuts_[o.b];
    const std::size_t na = A.dofs.size(), nb = B.dofs.size(), n = o.pos_a.size();
    for (std::int32_t ra = 0; ra < A.rows; ++ra) {
      const double* ta = T_.data() + A.T_start + ra * na;
      const std::int32_t rb_end = o.a == o.b ? ra + 1 : B.rows;
      for (std::int32_t rb = 0; rb < rb_end; ++rb) {
        const double* tb = T_.data() + B.T_start + rb * nb;
        double s = 0;
        for (std::size_t i = 0; i < n; ++i) s += ta[o.pos_a[i]] * tb[o.pos_b[i]];
        W_[(A.first_row + ra) + static_cast<std::size_t>(nc_) * (B.first_row + rb)] = s;
      }
    }
  }
}

int AlgS::step3_4() {
  // Dense Cholesky W = G G^T (lower, column-major, left-looking), then
  // G G^T lambda = z_m.  W is positive definite when Phiq has full rank.
  const int n = nc_;
  double* G = G_.data();
  for (int j = 0; j < n; ++j) {
    for (int i = j; i < n; ++i) {
      double s = W_[i + n * j];
      for (int k = 0; k < j; ++k) s -= G[i + n * k] * G[j + n * k];
      if (i == j) {
        if (!(s > 1e-14 * W_[j + n * j])) return jr::kConstraintsSingular;
        G[j + n * j] = std::sqrt(s);
      } else {
        G[i + n * j] = s / G[j + n * j];
      }
    }
  }
  for (int i = 0; i < n; ++i) {
    double s = zm_[i];
    for (int k = 0; k < i; ++k) s -= G[i + n * k] * lambda_[k];
    lambda_[i] = s / G[i + n * i];
  }
  for (int i = n - 1; i >= 0; --i) {
    double s = lambda_[i];
    for (int k = i + 1; k < n; ++k) s -= G[k + n * i] * lambda_[k];
    lambda_[i] = s / G[i + n * i];
  }
  return jr::kSuccess;
}

void AlgS::step3_5() {
  std::copy(z_.begin(), z_.end(), y_.begin());
  for (const CutBlock& b : cuts_) {
    const std::size_t nd = b.dofs.size();
    for (std::int32_t r = 0; r < b.rows; ++r) {
      const double* t = T_.data() + b.T_start + r * nd;
      const double l = lambda_[b.first_row + r];
      for (std::size_t i = 0; i < nd; ++i) y_[b.dofs[i]] -= t[i] * l;
    }
  }
}

void AlgS::step4() {
  const double* y = nc_ > 0 ? y_.data() : z_.data();  // a tree: y_n = z_n
  std::copy(y, y + nv_, x_.begin());
  jr::backward_packed(*model_, rows_, L_.data(), Dinv_.data(), false, x_.data());
  for (int j = 0; j < nv_; ++j) qdd_[dof_user_[j]] = x_[j];
}

int AlgS::solve() {
  if (const int s = step1()) return s;
  step2();
  if (nc_ > 0) {
    step3_1();
    step3_2();
    step3_3();
    if (const int s = step3_4()) return s;
    step3_5();
  }
  step4();
  return jr::kSuccess;
}

void AlgS::run_step(int k) {
  switch (k) {
    case 0: step1(); break;
    case 1: step2(); break;
    case 2: step3_1(); break;
    case 3: step3_2(); break;
    case 4: step3_3(); break;
    case 5: step3_4(); break;
    case 6: step3_5(); break;
    default: step4(); break;
  }
}

}  // namespace jrgen::report
