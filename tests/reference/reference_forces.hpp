// Independent reference for the force elements of docs/interface.md section 2b
// (docs/forces.md), for tests only (issue 29, item 1).
//
// Written from the definitions in docs/forces.md on top of the world-frame
// kinematics of reference_dynamics.hpp (link poses and point Jacobians, user
// order); it calls none of the runtime's or the generator's force code:
//
//   spring (points a on k, b on l; d = b - a, L = |d|):
//       F = stiffness (L - rest_length) + damping dL/dt,  dL/dt = d . (b' - a') / L,
//       force on b: -(F / L) d, on a: +(F / L) d,  h -= J_b^T f_b + J_a^T f_a;
//       rest_length, when the file gives none: L at the neutral configuration;
//   joint spring:  h += stiffness (q - rest) + damping v   (its joint's coordinate);
//   joint force:   h -= value.
//
// The generalized potential of the springs (1/2 stiffness (L - rest)^2 summed)
// is given too, for energy checks.
#pragma once

#include <Eigen/Core>

#include "ir/ir.hpp"

namespace jrgen::reference {

/// The force elements' part of h (size nv, user order): M qdd = tau - h_tree - h_forces.
Eigen::VectorXd force_element_bias(const ir::Robot& robot, const Eigen::VectorXd& q, const Eigen::VectorXd& v);

/// 1/2 stiffness (L - rest)^2 over the springs plus 1/2 stiffness (q - rest)^2
/// over the joint springs (joint forces do work that no potential holds).
double force_element_potential(const ir::Robot& robot, const Eigen::VectorXd& q);

}  // namespace jrgen::reference
