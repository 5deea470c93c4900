// The part of a cut joint's definition (docs/interface.md section 2) that its
// constraint rows cannot see.  Two rows for "the axis stays aligned" vanish
// for a reversed axis too, and three rows for "the orientation stays fixed"
// vanish at half turns (any smooth rows of that count must vanish somewhere
// else as well; tests/reference/reference_constraints_test,
// CutDefinitionResidual).  Assembly from far starts can converge there: an
// assembled configuration is accepted only where this check passes too.
#pragma once

#include <Eigen/Core>

#include "topology/topology.hpp"

namespace jrgen::analysis {

class RuntimeModel;

/// The first cut (index into tree.cuts) whose axis on l points against its
/// axis on k (revolute, prismatic, cylindrical) or whose two frames are
/// turned more than 90 degrees apart (prismatic, fixed) at q; -1 if none.
/// Needs only kinematics; residuals of the rows themselves are not looked at.
int cut_against_definition(const topology::Tree& tree, RuntimeModel& rt, const Eigen::VectorXd& q);

}  // namespace jrgen::analysis
