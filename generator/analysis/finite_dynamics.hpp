// Generation-time check that the model's dynamics are representable in
// double precision (docs/interface.md section 1: exit 0 means the output works).
#pragma once

#include <Eigen/Core>

#include "ir/ir.hpp"
#include "topology/topology.hpp"

namespace jrgen::analysis {

/// Evaluates the composite-rigid-body M (eq. 14, 18) and the gravity forces
/// at the zero configuration through the runtime; throws jrgen::Error naming
/// the joint whose diagonal entry of M or whose generalized gravity force
/// overflows (every call of the generated solver would return a non-finite
/// result).  Per-body constants are checked by topology::build_tree.
void check_finite_dynamics(const ir::Robot& robot, const topology::Tree& tree, const Eigen::Vector3d& gravity);

}  // namespace jrgen::analysis
