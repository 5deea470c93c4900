// The reference qdd of the full forward-dynamics tables (the solver report and
// tests/peers): the repository's independent world-frame dynamics
// (tests/reference/reference_dynamics.hpp: M, h) and loop-closure rows (tests/reference/reference_constraints.hpp:
// Phiq, gamma), evaluated in double, then eq. (17) solved in long double:
//
//   M qdd + Phiq^T lambda = tau - h,   Phiq qdd = gamma
//   qdd = M^-1 (Q - Phiq^T lambda),    (Phiq M^-1 Phiq^T) lambda = Phiq M^-1 Q - gamma
//
// with a rank-revealing (complete orthogonal) factorization of Phiq M^-1 Phiq^T,
// because the reference keeps every row of every cut where the generator
// drops the redundant ones (the range of Phiq^T, and so qdd, is the same).
// Its own error is that of M, h, Phiq and gamma in double: about
// eps cond(M) relative.
#pragma once

#include <Eigen/Core>

#include "ir/ir.hpp"

namespace jrgen::report {

Eigen::VectorXd reference_qdd(const ir::Robot& robot, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                              const Eigen::VectorXd& tau, const Eigen::Vector3d& gravity);

/// |x - ref|_2 / |ref|_2.
double relative_error(const Eigen::VectorXd& x, const Eigen::VectorXd& ref);

}  // namespace jrgen::report
