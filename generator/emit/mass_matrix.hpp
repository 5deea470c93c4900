// The mass-matrix block of the specialized terms (issue 20, item 1): M of
// eq. (18) by the composite-rigid-body recursion of eq. (14), as straight-line
// Program values.  The bodies' spatial inertias are constants of the model
// (folded), composite inertias are accumulated leaves-first (Lemma 2 order:
// descendants before ancestors), then for each dof j the force F = Ic_j S_j is
// carried up to the root and M(i, j) = S_i^T F for every ancestor dof i.  The
// formulas are those of jr::mass_matrix_packed (runtime/src/runtime.cpp,
// formulas (b)-(d)); the output is its packed layout (Tree::M_col_start: column
// j holds rows j, parent(j), ... up to the root), which the generated Step 1
// factors in place.
#pragma once

#include <vector>

#include "emit/kinematics.hpp"
#include "topology/topology.hpp"

namespace jrgen::emit {

/// A rigid or composite body's spatial inertia about its frame origin, in its
/// own coordinates, in the runtime's form: mass m, first moment h = m c and
/// rotational inertia I about the origin (symmetric; the nine entries kept,
/// the mirrored ones the same Values).  m is always a constant.
struct RigidInertia {
  Value m;
  Vec3 h;
  Mat3 I;
};

/// The body's own inertia from mass, centre of mass and I_com (parallel axis
/// theorem at generation time): constants only.
RigidInertia rigid_body_inertia(const ir::Inertial& in);

/// (c): [n; f] = [I w + h x v; m v - h x w].
Motion6 inertia_times(const RigidInertia& I, const Motion6& m);

/// (d): I_P + (I_C moved into the parent's coordinates through X_PC of `b`).
RigidInertia add_to_parent(const BodyFrame& b, const RigidInertia& I_C, const RigidInertia& I_P);

/// The lower triangle of M at q in the packed layout (tree.nnz() values,
/// entry (row, col) at tree.packed(row, col), Lemma 2 dofs).  Needs the
/// joint_frames of the same Program.
std::vector<Value> mass_matrix_packed(Program& program, const topology::Tree& tree,
                                      const std::vector<BodyFrame>& frames);

}  // namespace jrgen::emit
