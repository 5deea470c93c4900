// Generation-time analysis of the cut joints (docs/interface.md section 2):
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

/// Length scale L of the model: the largest offset between neighbouring frames
/// (tree joint origins, cut frames, given distances); 1 when all coincide.
/// Assembly and rank tolerances on length rows are relative to it
/// (docs/assembly.md, "Tolerances").
double model_length_scale(const topology::Tree& tree);

/// Levenberg-Marquardt projection of q onto Phi(q) = 0 (every row of every
/// cut): steps dv = -Phiq^T (Phiq Phiq^T + mu I)^-1 phi in the velocity
/// coordinates, mu = m |phi| with m from a trust-region ratio test, rows
/// dependent at the iterate left out (a sparse pivot-dropping Cholesky
/// factorization of the Gram matrix on the Lemma 3 pattern: time and memory
/// follow its fill, not rows x nv).  Lengths are measured in units of
/// model_length_scale().  Returns max |phi| at the end in those units (1e-12
/// or less on success); `q` holds the last accepted iterate.
double assemble(const topology::Tree& tree, RuntimeModel& rt, Eigen::VectorXd& q);

/// The start of --assemble-from: nq numbers in user order, separated by
/// white space or commas ('#' starts a comment to the end of the line);
/// quaternions are normalized.  Throws jrgen::Error naming the file (and the
/// line) and what is wrong.
Eigen::VectorXd read_start_configuration(const std::string& path, const topology::Tree& tree);

/// Names of the nq position coordinates, user order: the joint's name for a
/// one-coordinate joint, name[k] otherwise.
std::vector<std::string> coordinate_names(const topology::Tree& tree);

struct ConstraintAnalysis {
  std::vector<std::string> notes;          ///< one line each, for stderr
  std::vector<Eigen::VectorXd> configurations;  ///< the assembled configurations used, the first the assembly
  /// Markdown "## Assembly" section for the --report file when the first
  /// configuration is not the zero configuration (else empty).
  std::string report_section;
};

/// Fills default distances, assembles the mechanism (docs/assembly.md: from
/// the start in `start_file` if given, the zero configuration, then seeded
/// starts) and keeps, per cut, the rows that are independent of all rows
/// before them (in the elimination order of topology::constraint_row_order)
/// at some assembled configuration (tree.cuts[c].kept_rows).  Throws
/// jrgen::Error for a loop that cannot be closed from any start, a zero
/// default distance, a bad start file and (with strict) for any redundant row.
ConstraintAnalysis analyze_constraints(const ir::Robot& robot, topology::Tree& tree, bool strict,
                                       const std::string& start_file = "");

}  // namespace jrgen::analysis
