// The constraint block of the specialized terms (issue 20, item 1): Phi, the
// packed Jacobian Phiq and gamma = -(d/dt Phiq) v of the kept cut-joint rows
// as straight-line Program values, with every constant of the model folded in
// (cut frame offsets and rotations, unit directions of the rows, zero axis
// entries).  Rows, their order, their scalar kinds and the packed layout are
// those of the runtime's jr::constraint_terms (runtime/include/jrgen/
// runtime.hpp, "Cut joints"; the CutModel tables of
// analysis::cut_models), so the generated Steps 2-4 consume the result
// unchanged.
//
// The runtime expresses every row in world coordinates.  Every row depends
// only on the relative placement of the two cut frames Fk and Fl (and every
// derivative on absolute velocities, which may be expressed in any
// coordinates), so this block expresses everything in Fk's own coordinates:
// Fk's origin is 0 and its axes are the unit vectors, a point row
// e . (p_l - p_k) is one coordinate of p_l, and only the bodies on the paths
// from k and l up to their lowest common ancestor are composed (the floating
// base of a vehicle never enters its suspension loops).
#pragma once

#include <vector>

#include "emit/kinematics.hpp"
#include "emit/program.hpp"
#include "topology/topology.hpp"

namespace jrgen::emit {

/// The kept rows of every cut, cuts in tree.cuts order (analysis::cut_models:
/// first_row, phiq_start, num_dofs).
struct ConstraintValues {
  std::vector<Value> phi;          ///< nc
  /// phiq_nnz: row r kept of cut c at phiq_start(c) + r * dofs(c).size() +
  /// index of the dof in cut.dofs; the common-ancestor entries
  /// (index >= num_distinct) are the constant 0 (the runtime leaves them untouched).
  std::vector<Value> phiq_packed;
  std::vector<Value> gamma;        ///< nc; empty when no motion was given
};

/// Phi, the packed Phiq and (when `motion` is not empty) gamma of the kept
/// rows of tree.cuts (tree.cuts[c].kept_rows as filled by
/// analysis::analyze_constraints), from the joint frames and body velocities
/// of emit/kinematics (Program inputs q and v, user order).
ConstraintValues constraint_terms(Program& program, const topology::Tree& tree, const std::vector<BodyFrame>& frames,
                                  const std::vector<BodyMotion6>& motion);

}  // namespace jrgen::emit
