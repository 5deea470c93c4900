// The bias-forces block of the specialized terms (issue 20, item 1): h of
// M qdd = tau - h (Q = tau - h) by recursive Newton-Euler with qdd = 0, as
// straight-line Program values, with the bodies' inertias as constants,
// gravity folded in only when non-zero and damping only where a joint has it.
// The formulas are those of jr::bias_forces<kGravity, kDamping>
// (runtime/src/runtime.cpp): forward sweep (root end first) for the body
// accelerations, with gravity as the base's acceleration -g; per body
// f = I a + v x* I v; backward sweep (leaves first, Lemma 2 order) carrying f
// to the parent; h_j = S_j^T f (+ damping_j v_j); then the force elements
// (emit/force_elements.hpp), as jr::force_elements adds them.
#pragma once

#include <string>
#include <vector>

#include "emit/kinematics.hpp"
#include "topology/topology.hpp"

namespace jrgen::emit {

/// h at (q, v), nv values in Lemma 2 order ("<v>[user index]" read for the
/// damping terms).  Needs joint_frames and body_velocities of the same Program.
std::vector<Value> bias_forces(Program& program, const topology::Tree& tree, const std::vector<BodyFrame>& frames,
                               const std::vector<BodyMotion6>& motion, const Eigen::Vector3d& gravity,
                               const std::string& v = "v");

}  // namespace jrgen::emit
