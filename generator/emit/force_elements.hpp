// The force elements' block of the specialized terms (docs/interface.md section
// 2b): springs between two bodies (or a body and the base), joint springs and
// joint forces, as straight-line Program values.  The formulas are those of
// the runtime's jr::force_elements (runtime/src/forces.cpp), in the same
// order of operations: the joint terms stiffness (q - rest) - force, then per
// spring, with d = b - a between its points and L = sqrt(d.d + guard)
// (jr::kSpringLengthGuard: zero force where the points coincide), the force
// f_b = -(k (L - L0) + c dL/dt) / L d on b and -f_b on a, entering h as
// -J^T f through every dof on the paths of the two bodies to the base.
#pragma once

#include <string>
#include <vector>

#include "emit/kinematics.hpp"
#include "topology/topology.hpp"

namespace jrgen::emit {

/// Adds the force elements' part of h to h (nv values, Lemma 2 order); q and
/// v are read as "<q>[i]", "<v>[i]".  Nothing (no node) for a model without
/// force elements.  Needs joint_frames and body_velocities of the same Program.
void add_force_elements(Program& program, const topology::Tree& tree, const std::vector<BodyFrame>& frames,
                        const std::vector<BodyMotion6>& motion, std::vector<Value>& h, const std::string& q = "q");

}  // namespace jrgen::emit
