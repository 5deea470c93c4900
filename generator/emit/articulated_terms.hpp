// The articulated-body block of the specialized terms (issue 20, item 2):
// qdd of a tree by Featherstone's articulated-body algorithm, as straight-line
// Program values, O(n) operations where the paper's route (M by eq. 14/18,
// then the Lemma 2 factorization) costs O(n d^2) (d the depth).  For long
// chains; the emitter chooses between the two by the counted operations of
// both programs.
//
// The pivots D_i = S_i^T IA_i S_i of the algorithm are the pivots of the
// leaves-first L D L^T of M, the factorization of Step 1 (eliminating a leaf
// dof replaces the leaf's inertia by its articulated inertia, and the Schur
// complement is the parent's articulated inertia: Featherstone, Rigid Body
// Dynamics Algorithms, 2008, Sec. 6.5), so the digits test of Step 1
// (jr::pivot_spread) applies to them unchanged.
#pragma once

#include <vector>

#include "emit/kinematics.hpp"
#include "topology/topology.hpp"

namespace jrgen::emit {

struct ArticulatedResult {
  std::vector<Value> qdd;     ///< (nv) Lemma 2 order
  std::vector<Value> pivots;  ///< (nv) Lemma 2 order: the pivots of the joints' D blocks
};

/// qdd = M^-1 (tau - h) at (q, v, tau): tau read as "<tau>[user index]",
/// gravity (world = base frame) folded in when non-zero, damping where a
/// joint has it.  Needs joint_frames and body_velocities of the same Program.
ArticulatedResult articulated_body(Program& program, const topology::Tree& tree, const std::vector<BodyFrame>& frames,
                                   const std::vector<BodyMotion6>& motion, const Eigen::Vector3d& gravity,
                                   const std::string& v = "v", const std::string& tau = "tau");

}  // namespace jrgen::emit
