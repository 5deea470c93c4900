// jrgen runtime: the articulated-body route to the forward dynamics of a tree
// (issue 20, item 2), O(n) whatever the depth: Featherstone, Rigid Body
// Dynamics Algorithms (2008), Table 7.1.  The paper's route (M by eq. 14/18,
// then the no-fill-in factorization of Lemma 2) costs O(n d^2) for depth d,
// O(n^3) on a chain; this one costs O(n) on every tree.
//
// Same conventions as jrgen/runtime.hpp: bodies in Lemma 2 order (parent >
// child, so a forward loop is leaves-first), spatial vectors angular first in
// body coordinates, gravity entered as the base's acceleration -g, joint
// damping as in jr::bias_forces (a force damping * v on each velocity
// coordinate, part of h).  Inputs handed in by users (v, tau) are in user
// order, computed per-dof quantities (qdd, pivots, tau of inverse_dynamics)
// in Lemma 2 order, like h_lem of jr::bias_forces: dof j of Lemma 2 order is
// user coordinate Model::dof_user[j].
//
// Pivots.  Eliminating a leaf's dofs from M (the leaves-first L D L^T of
// Step 1, Lemma 2 order) replaces the leaf's inertia by its articulated
// inertia, and the Schur complement left on the parent's block is
// S_p^T IA_p S_p (RBDA Sec. 6.5).  So the pivots of this algorithm, the
// L D L^T pivots of each joint's D_i = S_i^T IA_i S_i in the joint's own dof
// order, are the pivots of Step 1's factorization of M (in exact arithmetic),
// and the digits test of the generated solvers (jr::pivot_spread with
// inverse = false, power = 1) applies to them unchanged.
#pragma once

#include "jrgen/runtime.hpp"

namespace jr {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

/// Per-body scratch of the articulated-body algorithm (Lemma 2 order), owned
/// by the caller: an array of Model::nb of them.  Nothing allocates.  After
/// articulated_dynamics() succeeded, W and Dinv describe the factorization of
/// M at this configuration and articulated_solve() reuses them; pA, u and a
/// are overwritten by every call of either function.
struct ArticulatedState {
  Matrix6d IA;  ///< articulated inertia IA_i, body coordinates (complete once pass 2 reaches i)
  Vector6d pA;  ///< articulated bias force pA_i
  Vector6d c;   ///< velocity-product acceleration c_i = c_J + v_i x v_J
  Vector6d u;   ///< first nv entries: u_i = tau_i - damping qd_i - S_i^T pA_i
  Vector6d a;   ///< acceleration of the body, body coordinates (pass 3); with gravity, that of a
                ///< base accelerating at -g (Featherstone's trick): the true one minus g
  Matrix6d W;   ///< first nv columns: W_i = U_i D_i^-1, U_i = IA_i S_i
  Matrix6d Dinv;  ///< top-left nv x nv block: D_i^-1, D_i = S_i^T IA_i S_i
};

/// The smallest local ratio of the pivots (issue 29, item 3): for dof k of
/// joint i, its L D L^T pivot d over the same diagonal entry before the
/// children's projections, S_k^T (IA_i + sum_c X_c U_c D_c^-1 U_c^T X_c^T) S_k
/// (the part of the children's inertia that their own dofs removed added
/// back, plus the joint's own elimination).  A small ratio is cancellation in
/// forming the pivot: two joint axes aligning with nothing inertial between
/// them (fixed-base icub at its zero state: ratio 1e-11).  Unlike d / M_jj it
/// stays of order 1e-2 on long chains, whose M_jj grow with the length while
/// the articulated inertias do not.
struct LocalPivotRatio {
  double min = 1.0;        ///< min over the dofs of d / (diagonal before projection), in (0, 1]
  std::int32_t dof = -1;   ///< its Lemma 2 dof
};

/// qdd = M^-1 (tau - h) by the articulated-body algorithm: pass 1 (root
/// first) body velocities v_i (written to bodies[i].v), c_i and the rigid
/// inertias; pass 2 (leaves first) articulated inertias IA_i and bias forces
/// pA_i, with an L D L^T of each joint's D_i; pass 3 (root first)
/// accelerations (work[i].a) and qdd.
///
/// bodies: after jr::kinematics() at q (R, p and S are read; v is written).
/// v, tau: (nv) user order.  qdd_lem, pivots_lem: (nv) Lemma 2 order; dof
/// v_lem + k of a joint is the k-th dof of its D_i, pivoted in that order.
/// Returns -1 on success (as jr::factor_packed; 0 is dof 0, a failure), else
/// the Lemma 2 dof whose pivot was not positive (or NaN), with that pivot in
/// pivots_lem[dof]; qdd_lem is then not written and the pivots of the dofs
/// after it are undefined.  No relative tolerance (Step 1's kPivotTolerance
/// compares with M[j, j], not formed here): a tiny positive pivot is left to
/// the digits test.  ratio: when not null, the smallest local pivot ratio
/// (LocalPivotRatio; one more 6-vector transform per body and parent dof).
/// Instantiated for the four combinations, as jr::bias_forces.
template <bool kGravity, bool kDamping>
std::int32_t articulated_dynamics(const Model& model, BodyState* bodies, ArticulatedState* work, const double* v,
                                  const double* tau, double* qdd_lem, double* pivots_lem,
                                  LocalPivotRatio* ratio = nullptr);

/// Runtime switch over the four instantiations.
std::int32_t articulated_dynamics(const Model& model, BodyState* bodies, ArticulatedState* work, const double* v,
                                  const double* tau, double* qdd_lem, double* pivots_lem, bool gravity,
                                  bool damping, LocalPivotRatio* ratio = nullptr);

/// Estimated relative error max_j |qdd_j - qdd*_j| / max_j |qdd*_j| of qdd
/// from a successful articulated_dynamics() at the same state (bodies and
/// work as it left them; their v, a, f and work's pA, u, a are overwritten),
/// qdd* the exact solution of M qdd = tau - h (issue 29, item 3).  One step
/// of iterative refinement's error estimate, O(n): the residual r = tau -
/// ID(q, v, qdd) by the recursive Newton-Euler algorithm (inverse_dynamics),
/// d1 = M^-1 r with the same factorization (articulated_solve); then, since r
/// computed in double carries rounding of the order of the error it is to
/// reveal, with w = |r| + eps |S_j^T| |f_j| (f_j the subtree force of the
/// residual's pass: each entry's rounding floor), z = M^-1 w and d2 =
/// M^-1 (sign(z) w), signed so that M^-1 cannot cancel it (one step of
/// Hager's estimator of || |M^-1| w ||).  Four O(n) passes in all.  Returns
/// max(|d1|, |z|, |d2|) / max |qdd|.  diagonal_bounds (nv, Lemma 2 order;
/// optional, 0 for none): upper bounds B_j of M_jj, which add eps sqrt(B_j)
/// sum_k sqrt(B_k) |qdd_k| >= eps (|M| |qdd|)_j to w: where qdd lies along a
/// nearly singular direction, M qdd (and f_j) is small while |M| |qdd| is not
/// (a gimbal at its singular state).  tau as given to articulated_dynamics();
/// scratch: 2 nv doubles.
double articulated_error_estimate(const Model& model, BodyState* bodies, ArticulatedState* work, const double* v,
                                  const double* tau, const double* qdd_lem, double* scratch, bool gravity,
                                  bool damping, const double* diagonal_bounds = nullptr);

/// x = M^-1 f, in place on x_lem ((nv), Lemma 2 order both ways), with the
/// factorization left in work by a successful articulated_dynamics() at the
/// same configuration (bodies unchanged since): passes 2 and 3 only, at zero
/// velocity and gravity, O(n) per right-hand side.  For the columns of
/// M^-1 Phiq^T that closed loops need.
void articulated_solve(const Model& model, const BodyState* bodies, ArticulatedState* work, double* x_lem);

/// tau = M qdd + h (h as jr::bias_forces: with gravity when kGravity, damping
/// when kDamping) by the recursive Newton-Euler algorithm with qdd: O(n), no
/// M formed.  For the residual of a forward-dynamics solve.  bodies: after
/// jr::kinematics(); v, a, f are overwritten.  v: (nv) user order;
/// qdd_lem, tau_lem: (nv) Lemma 2 order.
template <bool kGravity, bool kDamping>
void inverse_dynamics(const Model& model, BodyState* bodies, const double* v, const double* qdd_lem,
                      double* tau_lem);

/// Runtime switch over the four instantiations.
void inverse_dynamics(const Model& model, BodyState* bodies, const double* v, const double* qdd_lem,
                      double* tau_lem, bool gravity, bool damping);

/// Closed loops in O(n nc + nc^2 d + nc^3), d the longest path of a cut to
/// the base (issue 20, item 2: loops over long chains, where forming and
/// factoring M is O(n^3)).  The Lagrange multiplier form of eq. 17,
/// M qdd + Phiq^T lambda = tau - h, Phiq qdd = gamma, solved with the
/// articulated-body factorization of M, never forming M:
///   a0 = M^-1 (tau - h)                        articulated_dynamics()
///   Y  = M^-1 Phiq^T                           one articulated_solve() per kept row
///   W  = Phiq Y = Phiq M^-1 Phiq^T (nc x nc)   L D L^T, pivots in W_pivots
///   W lambda = Phiq a0 - gamma,  qdd = a0 - Y lambda.
/// W is Step 3.3's T^T T (T = L^-1 Phiq^T, M = L L^T) in exact arithmetic,
/// symmetric positive definite when the kept rows are independent, and
/// lambda that of Step 3.4.
///
/// cm, Phiq_packed (cm.phiq_nnz, as jr::constraint_terms leaves it: the
/// common-ancestor entries are never read), gamma (cm.nc): the kept rows at
/// the configuration of bodies.  bodies: after jr::kinematics() (v is
/// written).  v, tau: (nv) user order.  qdd_lem, pivots_lem: (nv) Lemma 2
/// order, as articulated_dynamics().  lambda, W_pivots: (nc), rows in Phi
/// order.  scratch: closed_scratch_size(nv, nc) doubles, caller-owned: Y (nc
/// columns of nv, Lemma 2 order) then W (nc x nc, column-major: its diagonal,
/// L_W below it, undefined above).  work: as articulated_dynamics() leaves
/// it, except pA, u and a (overwritten by the solves).  Nothing allocates.
///
/// Returns -1 on success.  0 <= k < nv: M's pivot of Lemma 2 dof k failed, as
/// articulated_dynamics() (nothing else written).  nv + r: W's pivot of row r
/// (Phi order) was not above 1e-9 * W[r, r] (Step 3's kPivotTolerance, so
/// also when <= 0 or NaN): the rows are dependent to working precision; the
/// pivot is in W_pivots[r], qdd_lem holds a0 and lambda is not the solution.
/// On success the digits test of Step 3.4 applies to W's pivots as to those
/// of T^T T: jr::pivot_spread(W_pivots, nc, false, 1, ...); and to M's as in
/// articulated_dynamics().  nc = 0 is articulated_dynamics().  ratio: when
/// not null, M's smallest local pivot ratio, as articulated_dynamics().
template <bool kGravity, bool kDamping>
std::int32_t articulated_closed(const Model& model, const ConstraintModel& cm, BodyState* bodies,
                                ArticulatedState* work, const double* Phiq_packed, const double* gamma,
                                const double* v, const double* tau, double* qdd_lem, double* lambda,
                                double* pivots_lem, double* W_pivots, double* scratch,
                                LocalPivotRatio* ratio = nullptr);

/// Runtime switch over the four instantiations.
std::int32_t articulated_closed(const Model& model, const ConstraintModel& cm, BodyState* bodies,
                                ArticulatedState* work, const double* Phiq_packed, const double* gamma,
                                const double* v, const double* tau, double* qdd_lem, double* lambda,
                                double* pivots_lem, double* W_pivots, double* scratch, bool gravity, bool damping,
                                LocalPivotRatio* ratio = nullptr);

/// Estimated relative error max_j |qdd_j - qdd*_j| / max_j |qdd*_j| of qdd
/// from a successful articulated_closed() at the same state (issue 29, item
/// 3), (qdd*, lambda*) the exact solution of the augmented system
///   K [qdd; lambda] = [tau - h; gamma],  K = [[M, Phiq^T], [Phiq, 0]].
/// As articulated_error_estimate(), for K: the residual r = (tau -
/// ID(q, v, qdd) - Phiq^T lambda, gamma - Phiq qdd) (Newton-Euler and the
/// packed rows), d1 = K^-1 r with the same factorizations (M's articulated
/// solve, Y and W's L D L^T left in scratch: a0 = M^-1 r_1, mu = W^-1 (Phiq
/// a0 - r_2), d = a0 - Y mu); then w = |r| plus each entry's rounding floor
/// (eps |S_j^T| |f_j| + eps (|Phiq|^T |lambda|)_j for the dofs, with
/// diagonal_bounds also eps sqrt(B_j) sum_k sqrt(B_k) |qdd_k|; eps (|gamma_r|
/// + (|Phiq| |qdd|)_r) for the rows) and one step of Hager's estimator, z =
/// K^-1 w, d2 = K^-1 (sign(z) w).  Returns max over the dofs of |d1|, |z|,
/// |d2| over max |qdd|: one Newton-Euler pass and three solves, each an
/// articulated solve plus O(nnz(Phiq) + nc nv + nc^2).
///
/// Arguments as given to and left by articulated_closed() (scratch: Y and the
/// factor of W; lambda, W_pivots its outputs; bodies' v, a, f and work's pA,
/// u, a are overwritten).  estimate_scratch: 2 (nv + nc) doubles.
double articulated_closed_error_estimate(const Model& model, const ConstraintModel& cm, BodyState* bodies,
                                         ArticulatedState* work, const double* Phiq_packed, const double* gamma,
                                         const double* v, const double* tau, const double* qdd_lem,
                                         const double* lambda, const double* W_pivots, const double* scratch,
                                         double* estimate_scratch, bool gravity, bool damping,
                                         const double* diagonal_bounds = nullptr);

/// Doubles of scratch that articulated_closed() needs: nc * (nv + nc).
inline std::int64_t closed_scratch_size(std::int32_t nv, std::int32_t nc) {
  return static_cast<std::int64_t>(nc) * (static_cast<std::int64_t>(nv) + nc);
}

}  // namespace jr
