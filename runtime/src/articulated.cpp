// jrgen runtime: the articulated-body algorithm (RBDA Table 7.1) and the
// recursive Newton-Euler algorithm with accelerations.  Formulas (a), (b),
// (e), (f) are shared with runtime.cpp (spatial.hpp); (c) is written here for
// the articulated inertias (6 x 6 matrices, which runtime.cpp never forms).
// With X_PC = (R, p), P = [p]x, motions map P -> C by M = [[R^T, 0], [-R^T P, R^T]]
// and forces C -> P by F = M^T = [[1, P], [0, 1]] diag(R, R), so an inertia
// maps C -> P by
//   (g) I_P = F I_C F^T: with A', B', C' the blocks of I_C rotated by R
//       (A' = R A R^T, ...), and B'' = B' + P C',
//       I_P = [[A' + P B'^T - B'' P,  B''], [B''^T,  C']].
#include "jrgen/articulated.hpp"

#include "spatial.hpp"

#include <Eigen/Geometry>  // cross products
#include <algorithm>
#include <cmath>
#include <type_traits>

namespace jr {

namespace {

using spatial::cross_force;
using spatial::cross_motion;
using spatial::force_to_parent;
using spatial::motion_to_child;

using Eigen::Matrix3d;
using Eigen::Vector3d;

Matrix3d skew(const Vector3d& p) {
  Matrix3d P;
  P << 0.0, -p.z(), p.y(), p.z(), 0.0, -p.x(), -p.y(), p.x(), 0.0;
  return P;
}

// The body's rigid inertia about its origin as the 6 x 6 map (c):
// [[I_o, [h]x], [[h]x^T, m 1]], h = m c, I_o = I_com + m (|c|^2 1 - c c^T).
Matrix6d rigid_inertia(const BodyModel& bm) {
  const Vector3d c(bm.com[0], bm.com[1], bm.com[2]);
  Matrix3d Ic;
  Ic << bm.I_com[0], bm.I_com[3], bm.I_com[4], bm.I_com[3], bm.I_com[1], bm.I_com[5], bm.I_com[4], bm.I_com[5],
      bm.I_com[2];
  const Matrix3d H = skew(bm.mass * c);
  Matrix6d I;
  I.topLeftCorner<3, 3>() = Ic + bm.mass * (c.squaredNorm() * Matrix3d::Identity() - c * c.transpose());
  I.topRightCorner<3, 3>() = H;
  I.bottomLeftCorner<3, 3>() = H.transpose();
  I.bottomRightCorner<3, 3>() = bm.mass * Matrix3d::Identity();
  return I;
}

// (g): I_P += F I_C F^T.
void add_inertia_to_parent(const BodyState& b, const Matrix6d& I_C, Matrix6d& I_P) {
  const Matrix3d& R = b.R;
  const Matrix3d A = R * I_C.topLeftCorner<3, 3>() * R.transpose();
  const Matrix3d B = R * I_C.topRightCorner<3, 3>() * R.transpose();
  const Matrix3d C = R * I_C.bottomRightCorner<3, 3>() * R.transpose();
  const Matrix3d P = skew(b.p);
  const Matrix3d B2 = B + P * C;
  I_P.topLeftCorner<3, 3>() += A + P * B.transpose() - B2 * P;
  I_P.topRightCorner<3, 3>() += B2;
  I_P.bottomLeftCorner<3, 3>() += B2.transpose();
  I_P.bottomRightCorner<3, 3>() += C;
}

// Joint velocity v_J = S qd and c_J = (dS/dt) qd (floating, planar: the
// translation is expressed in the joint frame), as in runtime.cpp.
void joint_velocity(const BodyModel& bm, const BodyState& b, const double* v_user, Vector6d& vJ, Vector6d& cJ) {
  const double* qd = v_user + bm.v_user;
  vJ.setZero();
  for (int k = 0; k < bm.nv; ++k) vJ += b.S.col(k) * qd[k];
  cJ.setZero();
  if (bm.kind == JointKind::kFloating || bm.kind == JointKind::kPlanar)
    cJ.tail<3>() = -vJ.head<3>().cross(vJ.tail<3>());
}

// Pass 1, root first: v_i = X v_p + v_J, c_i = c_J + v_i x v_J, IA_i = I_i,
// pA_i = v_i x* I_i v_i.
void velocity_pass(const Model& model, BodyState* bodies, ArticulatedState* work, const double* v) {
  Vector6d vJ, cJ;
  for (std::int32_t i = model.nb - 1; i >= 0; --i) {
    const BodyModel& bm = model.bodies[i];
    BodyState& b = bodies[i];
    ArticulatedState& w = work[i];
    joint_velocity(bm, b, v, vJ, cJ);
    b.v = bm.parent < 0 ? vJ : Vector6d(motion_to_child(b, bodies[bm.parent].v) + vJ);
    w.c = cJ + cross_motion(b.v, vJ);
    w.IA = rigid_inertia(bm);
    w.pA = cross_force(b.v, w.IA * b.v);
  }
}

// The local pivot ratios (LocalPivotRatio): pass 2 adds each child's
// removed part g^T D_c^-1 g, g = U_c^T X_c^T S_p, into the parent's a (free
// until pass 3), then compares every pivot of the parent with its diagonal
// entry plus that.
template <int N>
void removed_from_parent(const Model& model, const BodyState* bodies, ArticulatedState* work, std::int32_t i,
                         const Eigen::Matrix<double, 6, N>& U, const Eigen::Matrix<double, N, N>& Dinv) {
  const std::int32_t p = model.bodies[i].parent;
  for (int k = 0; k < model.bodies[p].nv; ++k) {
    const Eigen::Matrix<double, N, 1> g = U.transpose() * motion_to_child(bodies[i], bodies[p].S.col(k));
    work[p].a[k] += g.dot(Dinv * g);
  }
}

// L D L^T of the joint's D in its own dof order (that of Step 1), and D^-1.
// Returns -1, or the first k whose pivot is not positive (NaN included).
template <int N>
int factor_joint(const Eigen::Matrix<double, N, N>& D, double* pivots, Eigen::Matrix<double, N, N>& Dinv) {
  if constexpr (N == 1) {
    pivots[0] = D(0, 0);
    if (!(pivots[0] > 0.0)) return 0;
    Dinv(0, 0) = 1.0 / pivots[0];
    return -1;
  }
  Eigen::Matrix<double, N, N> L = Eigen::Matrix<double, N, N>::Identity();
  for (int j = 0; j < N; ++j) {
    double d = D(j, j);
    for (int k = 0; k < j; ++k) d -= L(j, k) * L(j, k) * pivots[k];
    pivots[j] = d;
    if (!(d > 0.0)) return j;
    for (int i = j + 1; i < N; ++i) {
      double s = D(i, j);
      for (int k = 0; k < j; ++k) s -= L(i, k) * L(j, k) * pivots[k];
      L(i, j) = s / d;
    }
  }
  // D^-1 = L^-T diag(1 / d) L^-1.
  Eigen::Matrix<double, N, N> Linv = L.template triangularView<Eigen::UnitLower>().solve(
      Eigen::Matrix<double, N, N>::Identity());
  Eigen::Matrix<double, N, 1> dinv;
  for (int j = 0; j < N; ++j) dinv[j] = 1.0 / pivots[j];
  Dinv = Linv.transpose() * dinv.asDiagonal() * Linv;
  return -1;
}

// Pass 2 for one body with N dofs: U = IA S, D = S^T U, u = tau - damping qd
// - S^T pA; then Ia = IA - U D^-1 U^T and pa = pA + Ia c + U D^-1 u go to the
// parent.  Returns -1 or the failing dof of the joint (0 .. N-1).
template <int N, bool kDamping>
int articulated_body(const Model& model, BodyState* bodies, ArticulatedState* work, std::int32_t i, const double* v,
                     const double* tau, double* pivots, LocalPivotRatio* ratio) {
  const BodyModel& bm = model.bodies[i];
  const BodyState& b = bodies[i];
  ArticulatedState& w = work[i];
  const auto S = b.S.leftCols<N>();
  const Eigen::Matrix<double, 6, N> U = w.IA * S;
  const Eigen::Matrix<double, N, N> D = S.transpose() * U;
  Eigen::Matrix<double, N, N> Dinv;
  if (const int k = factor_joint<N>(D, pivots + bm.v_lem, Dinv); k >= 0) return k;
  if (ratio != nullptr) {
    for (int k = 0; k < N; ++k) {
      const double r = pivots[bm.v_lem + k] / (D(k, k) + w.a[k]);
      if (!(r >= ratio->min)) {
        ratio->min = r;
        ratio->dof = bm.v_lem + k;
      }
    }
    if (bm.parent >= 0) removed_from_parent<N>(model, bodies, work, i, U, Dinv);
  }
  w.Dinv.topLeftCorner<N, N>() = Dinv;
  const Eigen::Matrix<double, 6, N> W = U * Dinv;
  w.W.leftCols<N>() = W;
  Eigen::Matrix<double, N, 1> u = -S.transpose() * w.pA;
  for (int k = 0; k < N; ++k) {
    u[k] += tau[bm.v_user + k];
    if constexpr (kDamping) u[k] -= bm.damping * v[bm.v_user + k];
  }
  w.u.head<N>() = u;
  if (bm.parent < 0) return -1;
  const Matrix6d Ia = w.IA - W * U.transpose();
  const Vector6d pa = w.pA + Ia * w.c + W * u;
  add_inertia_to_parent(b, Ia, work[bm.parent].IA);
  work[bm.parent].pA += force_to_parent(b, pa);
  return -1;
}

// Pass 3 for one body: a' = X a_p + c (c = 0 at zero velocity), qdd = D^-1 u
// - W^T a', a = a' + S qdd.
template <int N, bool kVelocity>
void acceleration(const BodyModel& bm, const BodyState& b, ArticulatedState& w, const Vector6d& a_parent,
                  double* qdd_lem) {
  Vector6d a = motion_to_child(b, a_parent);
  if constexpr (kVelocity) a += w.c;
  const Eigen::Matrix<double, N, 1> qdd =
      w.Dinv.topLeftCorner<N, N>() * w.u.head<N>() - w.W.leftCols<N>().transpose() * a;
  for (int k = 0; k < N; ++k) qdd_lem[bm.v_lem + k] = qdd[k];
  w.a = a + b.S.leftCols<N>() * qdd;
}

// The joint kinds have 1, 3 or 6 dofs (runtime.hpp); every count up to 6 is
// dispatched all the same.
template <typename F>
auto by_dofs(std::int32_t nv, F&& f) {
  switch (nv) {
    case 1: return f(std::integral_constant<int, 1>());
    case 2: return f(std::integral_constant<int, 2>());
    case 3: return f(std::integral_constant<int, 3>());
    case 4: return f(std::integral_constant<int, 4>());
    case 5: return f(std::integral_constant<int, 5>());
    default: return f(std::integral_constant<int, 6>());
  }
}

template <bool kVelocity>
void acceleration_pass(const Model& model, const BodyState* bodies, ArticulatedState* work, const Vector6d& a_base,
                       double* qdd_lem) {
  for (std::int32_t i = model.nb - 1; i >= 0; --i) {
    const BodyModel& bm = model.bodies[i];
    const Vector6d& a_parent = bm.parent < 0 ? a_base : work[bm.parent].a;
    by_dofs(bm.nv, [&](auto n) { acceleration<decltype(n)::value, kVelocity>(bm, bodies[i], work[i], a_parent, qdd_lem); });
  }
}

constexpr double kEps = 0x1p-52;

// The rounding floor of the residual r = tau - (M qdd + h) that inverse_dynamics
// just computed (each body's subtree force f_j left in bodies[i].f), added to
// |r| in place: r_j <- |r_j| + eps |S_j^T| |f_j|, plus, with bounds B_j >= M_jj,
// eps sqrt(B_j) sum_k sqrt(B_k) |qdd_k| >= eps (|M| |qdd|)_j (|M_jk| <=
// sqrt(M_jj M_kk)), the floor of a backward-stable solve.  Shared by the
// error estimates of the tree and closed-loop routes.
void mass_residual_floor(const Model& model, const BodyState* bodies, const double* qdd_lem,
                         const double* diagonal_bounds, double* r) {
  double moment = 0.0;
  if (diagonal_bounds != nullptr)
    for (std::int32_t j = 0; j < model.nv; ++j) moment += std::sqrt(diagonal_bounds[j]) * std::abs(qdd_lem[j]);
  for (std::int32_t i = 0; i < model.nb; ++i) {
    const BodyModel& bm = model.bodies[i];
    const BodyState& b = bodies[i];
    const double n = b.f.head<3>().norm(), f = b.f.tail<3>().norm();
    for (int k = 0; k < bm.nv; ++k) {
      const std::int32_t j = bm.v_lem + k;
      const double bound = diagonal_bounds != nullptr ? kEps * std::sqrt(diagonal_bounds[j]) * moment : 0.0;
      r[j] = std::abs(r[j]) + kEps * (b.S.col(k).head<3>().norm() * n + b.S.col(k).tail<3>().norm() * f) + bound;
    }
  }
}

}  // namespace

template <bool kGravity, bool kDamping>
std::int32_t articulated_dynamics(const Model& model, BodyState* bodies, ArticulatedState* work, const double* v,
                                  const double* tau, double* qdd_lem, double* pivots_lem, LocalPivotRatio* ratio) {
  velocity_pass(model, bodies, work, v);
  if (ratio != nullptr) {
    *ratio = LocalPivotRatio();
    for (std::int32_t i = 0; i < model.nb; ++i) work[i].a.setZero();
  }
  for (std::int32_t i = 0; i < model.nb; ++i) {
    const int k = by_dofs(model.bodies[i].nv, [&](auto n) {
      return articulated_body<decltype(n)::value, kDamping>(model, bodies, work, i, v, tau, pivots_lem, ratio);
    });
    if (k >= 0) return model.bodies[i].v_lem + k;
  }
  // Gravity as the base's acceleration -g (as jr::bias_forces).
  Vector6d a_base = Vector6d::Zero();
  if constexpr (kGravity) a_base.tail<3>() = -Vector3d(model.gravity[0], model.gravity[1], model.gravity[2]);
  acceleration_pass<true>(model, bodies, work, a_base, qdd_lem);
  return -1;
}

template std::int32_t articulated_dynamics<false, false>(const Model&, BodyState*, ArticulatedState*, const double*,
                                                         const double*, double*, double*, LocalPivotRatio*);
template std::int32_t articulated_dynamics<false, true>(const Model&, BodyState*, ArticulatedState*, const double*,
                                                        const double*, double*, double*, LocalPivotRatio*);
template std::int32_t articulated_dynamics<true, false>(const Model&, BodyState*, ArticulatedState*, const double*,
                                                        const double*, double*, double*, LocalPivotRatio*);
template std::int32_t articulated_dynamics<true, true>(const Model&, BodyState*, ArticulatedState*, const double*,
                                                       const double*, double*, double*, LocalPivotRatio*);

std::int32_t articulated_dynamics(const Model& model, BodyState* bodies, ArticulatedState* work, const double* v,
                                  const double* tau, double* qdd_lem, double* pivots_lem, bool gravity,
                                  bool damping, LocalPivotRatio* ratio) {
  if (gravity)
    return damping ? articulated_dynamics<true, true>(model, bodies, work, v, tau, qdd_lem, pivots_lem, ratio)
                   : articulated_dynamics<true, false>(model, bodies, work, v, tau, qdd_lem, pivots_lem, ratio);
  return damping ? articulated_dynamics<false, true>(model, bodies, work, v, tau, qdd_lem, pivots_lem, ratio)
                 : articulated_dynamics<false, false>(model, bodies, work, v, tau, qdd_lem, pivots_lem, ratio);
}

void articulated_solve(const Model& model, const BodyState* bodies, ArticulatedState* work, double* x_lem) {
  // Pass 2 at zero velocity: pA_i is the sum of the children's pa = pA + U D^-1 u
  // (Ia c = 0), u_i = f_i - S_i^T pA_i.
  for (std::int32_t i = 0; i < model.nb; ++i) work[i].pA.setZero();
  for (std::int32_t i = 0; i < model.nb; ++i) {
    const BodyModel& bm = model.bodies[i];
    ArticulatedState& w = work[i];
    by_dofs(bm.nv, [&](auto n) {
      constexpr int N = decltype(n)::value;
      const Eigen::Matrix<double, N, 1> u =
          Eigen::Map<const Eigen::Matrix<double, N, 1>>(x_lem + bm.v_lem) - bodies[i].S.leftCols<N>().transpose() * w.pA;
      w.u.head<N>() = u;
      if (bm.parent >= 0) work[bm.parent].pA += force_to_parent(bodies[i], w.pA + w.W.leftCols<N>() * u);
    });
  }
  acceleration_pass<false>(model, bodies, work, Vector6d::Zero(), x_lem);
}

template <bool kGravity, bool kDamping>
void inverse_dynamics(const Model& model, BodyState* bodies, const double* v, const double* qdd_lem,
                      double* tau_lem) {
  // Forward sweep: a_i = X a_p + S qdd + c_J + v_i x v_J, f_i = I a_i + v_i x* I v_i.
  Vector6d a_base = Vector6d::Zero();
  if constexpr (kGravity) a_base.tail<3>() = -Vector3d(model.gravity[0], model.gravity[1], model.gravity[2]);
  Vector6d vJ, cJ;
  for (std::int32_t i = model.nb - 1; i >= 0; --i) {
    const BodyModel& bm = model.bodies[i];
    BodyState& b = bodies[i];
    joint_velocity(bm, b, v, vJ, cJ);
    const bool root = bm.parent < 0;
    b.v = root ? vJ : Vector6d(motion_to_child(b, bodies[bm.parent].v) + vJ);
    b.a = motion_to_child(b, root ? a_base : bodies[bm.parent].a) + cJ + cross_motion(b.v, vJ);
    for (int k = 0; k < bm.nv; ++k) b.a += b.S.col(k) * qdd_lem[bm.v_lem + k];
    const Matrix6d I = rigid_inertia(bm);
    b.f = I * b.a + cross_force(b.v, I * b.v);
  }
  // Backward sweep: tau_i = S^T f_i (+ damping qd), f_p += X* f_i.
  for (std::int32_t i = 0; i < model.nb; ++i) {
    const BodyModel& bm = model.bodies[i];
    BodyState& b = bodies[i];
    for (int k = 0; k < bm.nv; ++k) {
      double t = b.S.col(k).dot(b.f);
      if constexpr (kDamping) t += bm.damping * v[bm.v_user + k];
      tau_lem[bm.v_lem + k] = t;
    }
    if (bm.parent >= 0) bodies[bm.parent].f += force_to_parent(b, b.f);
  }
}

template void inverse_dynamics<false, false>(const Model&, BodyState*, const double*, const double*, double*);
template void inverse_dynamics<false, true>(const Model&, BodyState*, const double*, const double*, double*);
template void inverse_dynamics<true, false>(const Model&, BodyState*, const double*, const double*, double*);
template void inverse_dynamics<true, true>(const Model&, BodyState*, const double*, const double*, double*);

void inverse_dynamics(const Model& model, BodyState* bodies, const double* v, const double* qdd_lem,
                      double* tau_lem, bool gravity, bool damping) {
  if (gravity) {
    if (damping) inverse_dynamics<true, true>(model, bodies, v, qdd_lem, tau_lem);
    else inverse_dynamics<true, false>(model, bodies, v, qdd_lem, tau_lem);
  } else {
    if (damping) inverse_dynamics<false, true>(model, bodies, v, qdd_lem, tau_lem);
    else inverse_dynamics<false, false>(model, bodies, v, qdd_lem, tau_lem);
  }
}

double articulated_error_estimate(const Model& model, BodyState* bodies, ArticulatedState* work, const double* v,
                                  const double* tau, const double* qdd_lem, double* scratch, bool gravity,
                                  bool damping, const double* diagonal_bounds) {
  const std::int32_t nv = model.nv;
  double* r = scratch;
  double* d = scratch + nv;
  inverse_dynamics(model, bodies, v, qdd_lem, r, gravity, damping);
  for (std::int32_t j = 0; j < nv; ++j) d[j] = r[j] = tau[model.dof_user[j]] - r[j];
  articulated_solve(model, bodies, work, d);
  double d1 = 0.0, x = 0.0;
  for (std::int32_t j = 0; j < nv; ++j) {
    d1 = std::max(d1, std::abs(d[j]));
    x = std::max(x, std::abs(qdd_lem[j]));
  }
  // w = |r| + the rounding floor of each residual entry (mass_residual_floor),
  // into r; then Hager's step: z = M^-1 w, d2 = M^-1 (sign(z) w).
  mass_residual_floor(model, bodies, qdd_lem, diagonal_bounds, r);
  for (std::int32_t j = 0; j < nv; ++j) d[j] = r[j];
  articulated_solve(model, bodies, work, d);
  double e = d1;
  for (std::int32_t j = 0; j < nv; ++j) {
    e = std::max(e, std::abs(d[j]));
    d[j] = std::copysign(r[j], d[j]);
  }
  articulated_solve(model, bodies, work, d);
  for (std::int32_t j = 0; j < nv; ++j) e = std::max(e, std::abs(d[j]));
  return x > 0.0 ? e / x : e;
}

namespace {

// Kept row r of every cut, in Phi order: f(cut, r, its packed entries).
template <typename F>
void for_each_kept_row(const ConstraintModel& cm, const double* Phiq_p, F&& f) {
  for (std::int32_t c = 0; c < cm.ncuts; ++c) {
    const CutModel& cut = cm.cuts[c];
    std::int32_t kept = 0;
    for (int r = 0; r < cut_kind_rows(cut.kind); ++r) {
      if (!(cut.row_mask >> r & 1)) continue;
      f(cut, cut.first_row + kept, Phiq_p + cut.phiq_start + static_cast<std::int64_t>(kept) * cut.num_dofs);
      ++kept;
    }
  }
}

// The packed layout of a row (runtime.hpp, "Packed constraint Jacobian"):
// f(index, dof) for the dofs on the paths of k and l to the base in
// increasing Lemma 2 order, skipping those on both paths (entries exactly 0,
// never written by jr::constraint_terms) except for a mimic row (runtime.hpp).
template <typename F>
void for_each_row_entry(const Model& model, const CutModel& cut, F&& f) {
  std::int32_t dk = cut.body_k >= 0 ? model.bodies[cut.body_k].v_lem : -1;
  std::int32_t dl = cut.body_l >= 0 ? model.bodies[cut.body_l].v_lem : -1;
  for (std::int32_t index = 0; dk >= 0 || dl >= 0; ++index) {
    const bool on_k = dk >= 0 && (dl < 0 || dk <= dl), on_l = dl >= 0 && (dk < 0 || dl <= dk);
    if (!(on_k && on_l) || cut.kind == CutKind::kMimic) f(index, on_k ? dk : dl);  // mimic: every dof
    if (on_k) dk = model.dof_parent[dk];
    if (on_l) dl = model.dof_parent[dl];
  }
}

// In-place L D L^T of the symmetric W (n x n, column-major, lower triangle
// read): L below the diagonal, the diagonal kept, pivots in d.  Returns -1,
// or the first row whose pivot is not above tolerance * W[j, j].
std::int32_t factor_w(double* W, std::int32_t n, double tolerance, double* d) {
  for (std::int32_t j = 0; j < n; ++j) {
    double p = W[j + n * j];
    for (std::int32_t k = 0; k < j; ++k) p -= W[j + n * k] * W[j + n * k] * d[k];
    d[j] = p;
    if (!(p > tolerance * W[j + n * j])) return j;
    for (std::int32_t i = j + 1; i < n; ++i) {
      double s = W[i + n * j];
      for (std::int32_t k = 0; k < j; ++k) s -= W[i + n * k] * W[j + n * k] * d[k];
      W[i + n * j] = s / p;
    }
  }
  return -1;
}

// x = (L D L^T)^-1 x with the factor of factor_w.
void solve_w(const double* L, std::int32_t n, const double* d, double* x) {
  for (std::int32_t j = 0; j < n; ++j)
    for (std::int32_t i = j + 1; i < n; ++i) x[i] -= L[i + n * j] * x[j];
  for (std::int32_t j = 0; j < n; ++j) x[j] /= d[j];
  for (std::int32_t j = n - 1; j >= 0; --j)
    for (std::int32_t i = j + 1; i < n; ++i) x[j] -= L[i + n * j] * x[i];
}

constexpr double kWPivotTolerance = 1e-9;  // Step 3's kPivotTolerance (templates/solver.cpp.tmpl)

}  // namespace

template <bool kGravity, bool kDamping>
std::int32_t articulated_closed(const Model& model, const ConstraintModel& cm, BodyState* bodies,
                                ArticulatedState* work, const double* Phiq_packed, const double* gamma,
                                const double* v, const double* tau, double* qdd_lem, double* lambda,
                                double* pivots_lem, double* W_pivots, double* scratch, LocalPivotRatio* ratio) {
  // a0 = M^-1 (tau - h), in qdd_lem.
  const std::int32_t status =
      articulated_dynamics<kGravity, kDamping>(model, bodies, work, v, tau, qdd_lem, pivots_lem, ratio);
  if (status >= 0) return status;
  const std::int32_t nv = model.nv, nc = cm.nc;
  double* Y = scratch;
  double* W = scratch + static_cast<std::int64_t>(nc) * nv;
  // Column r of Y = M^-1 (row r of Phiq)^T.
  for_each_kept_row(cm, Phiq_packed, [&](const CutModel& cut, std::int32_t r, const double* row) {
    double* y = Y + static_cast<std::int64_t>(r) * nv;
    for (std::int32_t j = 0; j < nv; ++j) y[j] = 0.0;
    for_each_row_entry(model, cut, [&](std::int32_t index, std::int32_t dof) { y[dof] = row[index]; });
    articulated_solve(model, bodies, work, y);
  });
  // Row r of W = Phiq Y up to the diagonal (W is symmetric; factor_w reads
  // the lower triangle) and of the right-hand side Phiq a0 - gamma.
  for_each_kept_row(cm, Phiq_packed, [&](const CutModel& cut, std::int32_t r, const double* row) {
    for (std::int32_t s = 0; s <= r; ++s) W[r + static_cast<std::int64_t>(nc) * s] = 0.0;
    double b = 0.0;
    for_each_row_entry(model, cut, [&](std::int32_t index, std::int32_t dof) {
      const double e = row[index];
      b += e * qdd_lem[dof];
      for (std::int32_t s = 0; s <= r; ++s)
        W[r + static_cast<std::int64_t>(nc) * s] += e * Y[static_cast<std::int64_t>(s) * nv + dof];
    });
    lambda[r] = b - gamma[r];
  });
  if (const std::int32_t r = factor_w(W, nc, kWPivotTolerance, W_pivots); r >= 0) return nv + r;
  solve_w(W, nc, W_pivots, lambda);
  // qdd = a0 - Y lambda.
  for (std::int32_t s = 0; s < nc; ++s) {
    const double* y = Y + static_cast<std::int64_t>(s) * nv;
    for (std::int32_t j = 0; j < nv; ++j) qdd_lem[j] -= y[j] * lambda[s];
  }
  return -1;
}

#define JR_ARTICULATED_CLOSED(G, D)                                                                              \
  template std::int32_t articulated_closed<G, D>(const Model&, const ConstraintModel&, BodyState*,              \
                                                 ArticulatedState*, const double*, const double*, const double*, \
                                                 const double*, double*, double*, double*, double*, double*, \
                                                 LocalPivotRatio*);
JR_ARTICULATED_CLOSED(false, false)
JR_ARTICULATED_CLOSED(false, true)
JR_ARTICULATED_CLOSED(true, false)
JR_ARTICULATED_CLOSED(true, true)
#undef JR_ARTICULATED_CLOSED

std::int32_t articulated_closed(const Model& model, const ConstraintModel& cm, BodyState* bodies,
                                ArticulatedState* work, const double* Phiq_packed, const double* gamma,
                                const double* v, const double* tau, double* qdd_lem, double* lambda,
                                double* pivots_lem, double* W_pivots, double* scratch, bool gravity, bool damping,
                                LocalPivotRatio* ratio) {
  auto call = [&](auto g, auto d) {
    return articulated_closed<decltype(g)::value, decltype(d)::value>(model, cm, bodies, work, Phiq_packed, gamma,
                                                                       v, tau, qdd_lem, lambda, pivots_lem,
                                                                       W_pivots, scratch, ratio);
  };
  using T = std::true_type;
  using F = std::false_type;
  if (gravity) return damping ? call(T(), T()) : call(T(), F());
  return damping ? call(F(), T()) : call(F(), F());
}

namespace {

// [x; mu] = K^-1 [x; mu] in place (x: nv, Lemma 2 order; mu: nc, Phi order),
// K = [[M, Phiq^T], [Phiq, 0]], with the factorizations articulated_closed()
// left: x <- M^-1 x, mu <- W^-1 (Phiq x - mu), x <- x - Y mu.
void closed_solve(const Model& model, const ConstraintModel& cm, const BodyState* bodies, ArticulatedState* work,
                  const double* Phiq_packed, const double* W_pivots, const double* scratch, double* x,
                  double* mu) {
  const std::int32_t nv = model.nv, nc = cm.nc;
  articulated_solve(model, bodies, work, x);
  for_each_kept_row(cm, Phiq_packed, [&](const CutModel& cut, std::int32_t r, const double* row) {
    double b = 0.0;
    for_each_row_entry(model, cut, [&](std::int32_t index, std::int32_t dof) { b += row[index] * x[dof]; });
    mu[r] = b - mu[r];
  });
  solve_w(scratch + static_cast<std::int64_t>(nc) * nv, nc, W_pivots, mu);
  for (std::int32_t s = 0; s < nc; ++s) {
    const double* y = scratch + static_cast<std::int64_t>(s) * nv;
    for (std::int32_t j = 0; j < nv; ++j) x[j] -= y[j] * mu[s];
  }
}

}  // namespace

double articulated_closed_error_estimate(const Model& model, const ConstraintModel& cm, BodyState* bodies,
                                         ArticulatedState* work, const double* Phiq_packed, const double* gamma,
                                         const double* v, const double* tau, const double* qdd_lem,
                                         const double* lambda, const double* W_pivots, const double* scratch,
                                         double* estimate_scratch, bool gravity, bool damping,
                                         const double* diagonal_bounds) {
  const std::int32_t nv = model.nv, nc = cm.nc, n = nv + nc;
  double* r = estimate_scratch;      // residual, then w
  double* d = estimate_scratch + n;  // the solves
  // r_1 = tau - (M qdd + h) - Phiq^T lambda, r_2 = gamma - Phiq qdd.
  inverse_dynamics(model, bodies, v, qdd_lem, r, gravity, damping);
  for (std::int32_t j = 0; j < nv; ++j) r[j] = tau[model.dof_user[j]] - r[j];
  for_each_kept_row(cm, Phiq_packed, [&](const CutModel& cut, std::int32_t k, const double* row) {
    double b = 0.0;
    for_each_row_entry(model, cut, [&](std::int32_t index, std::int32_t dof) {
      r[dof] -= row[index] * lambda[k];
      b += row[index] * qdd_lem[dof];
    });
    r[nv + k] = gamma[k] - b;
  });
  for (std::int32_t i = 0; i < n; ++i) d[i] = r[i];
  closed_solve(model, cm, bodies, work, Phiq_packed, W_pivots, scratch, d, d + nv);
  double d1 = 0.0, x = 0.0;
  for (std::int32_t j = 0; j < nv; ++j) {
    d1 = std::max(d1, std::abs(d[j]));
    x = std::max(x, std::abs(qdd_lem[j]));
  }
  // w: |r| plus each entry's rounding floor (mass_residual_floor, and the
  // rows' products with lambda and qdd).
  mass_residual_floor(model, bodies, qdd_lem, diagonal_bounds, r);
  for_each_kept_row(cm, Phiq_packed, [&](const CutModel& cut, std::int32_t k, const double* row) {
    double b = std::abs(gamma[k]);
    for_each_row_entry(model, cut, [&](std::int32_t index, std::int32_t dof) {
      const double e = std::abs(row[index]);
      r[dof] += kEps * e * std::abs(lambda[k]);
      b += e * std::abs(qdd_lem[dof]);
    });
    r[nv + k] = std::abs(r[nv + k]) + kEps * b;
  });
  // Hager's step: z = K^-1 w, d2 = K^-1 (sign(z) w).
  for (std::int32_t i = 0; i < n; ++i) d[i] = r[i];
  closed_solve(model, cm, bodies, work, Phiq_packed, W_pivots, scratch, d, d + nv);
  double e = d1;
  for (std::int32_t i = 0; i < n; ++i) {
    if (i < nv) e = std::max(e, std::abs(d[i]));
    d[i] = std::copysign(r[i], d[i]);
  }
  closed_solve(model, cm, bodies, work, Phiq_packed, W_pivots, scratch, d, d + nv);
  for (std::int32_t j = 0; j < nv; ++j) e = std::max(e, std::abs(d[j]));
  return x > 0.0 ? e / x : e;
}

}  // namespace jr
