// Generation-time analysis of the cut joints (INTERFACE.md section 2):
// default distances, assembly, and the choice of an independent subset of
// constraint rows, checked at several assembled configurations.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "ir/ir.hpp"
#include "topology/topology.hpp"

namespace jrgen::analysis {

class RuntimeModel;

/// Zeros and identity quaternions, user layout (nq).
Eigen::VectorXd neutral_configuration(const topology::Tree& tree);

/// q <- q "+" dv: one step along velocity coordinates dv (nv, user order),
/// quaternions updated by the exponential map (docs/conventions.md).
void integrate(const topology::Tree& tree, Eigen::VectorXd& q, const Eigen::VectorXd& dv);

/// Newton projection of q onto Phi(q) = 0 (every row of every cut) by
/// minimum-norm steps in the velocity coordinates, dv = -Phiq_S^T (Phiq_S
/// Phiq_S^T)^-1 phi_S over the rows S independent at the iterate, with a
/// sparse pivot-dropping Cholesky factorization of the Gram matrix on the
/// Lemma 3 pattern (time and memory follow its fill, not rows x nv).
/// Returns the final max-norm residual; `q` holds the last iterate.
double assemble(const topology::Tree& tree, RuntimeModel& rt, Eigen::VectorXd& q, double tolerance = 1e-12,
                int max_iterations = 60);

struct ConstraintAnalysis {
  std::vector<std::string> notes;          ///< one line each, for stderr
  std::vector<Eigen::VectorXd> configurations;  ///< the assembled configurations used
};

/// Fills default distances, assembles the mechanism and keeps, per cut, the
/// rows that are independent of all rows before them (in the elimination
/// order of topology::constraint_row_order) at some assembled configuration
/// (tree.cuts[c].kept_rows).  Throws jrgen::Error for a loop
/// that cannot be closed, a zero default distance, and (with strict) for any
/// redundant row.
ConstraintAnalysis analyze_constraints(const ir::Robot& robot, topology::Tree& tree, bool strict);

}  // namespace jrgen::analysis
