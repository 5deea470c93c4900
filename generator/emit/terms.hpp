// The terms of forward_dynamics, mass_matrix and bias_forces (issue 20):
// which route computes them from (q, v, tau), and the specialized code.
//
// Routes of a tree's forward_dynamics, chosen per model at generation time by
// counted operations (additions, multiplications, divisions, square roots,
// sines and cosines of the emitted code):
//   - kCompositeRigidBody: the paper's route, specialized: kinematics, M by
//     eq. (14)/(18) into the packed factor and Q = tau - h by Newton-Euler as
//     one straight-line Program (emit/kinematics, mass_matrix, bias_forces),
//     then the generated Steps 1, 2, 4.  O(n d) + the factorization's cost.
//   - kArticulated: kinematics and Featherstone's articulated-body algorithm
//     as one straight-line Program (emit/articulated_terms): O(n).  Its pivots
//     are those of Step 1's leaves-first L D L^T of M, so Step 1's digits
//     test (pivot spread) applies to them unchanged.
//   - kRuntime / kRuntimeArticulated: for models whose specialized programs
//     would outgrow the statement limit, the runtime's generic kinematics, M
//     and h, then Steps 1, 2, 4; or the runtime's articulated-body algorithm
//     (jr::articulated_dynamics, O(n): long chains), again by counted
//     operations.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "emit/emitter.hpp"
#include "topology/topology.hpp"

namespace jrgen::emit {

enum class TermsRoute { kRuntime, kRuntimeArticulated, kCompositeRigidBody, kArticulated };

struct TermsBlock {
  TermsRoute route = TermsRoute::kRuntime;
  std::string include;      ///< an extra runtime header, or empty
  std::string definitions;  ///< generated functions and workspace (empty for kRuntime)
  std::string fd_body;      ///< forward_dynamics' statements after the q test, ending with `status`
  std::string summary;      ///< one line: the route and why (banner, report)
  std::vector<std::pair<std::string, OpCount>> ops;  ///< per block of the chosen program
  /// The same program without folding (Program::fold_identities false): what
  /// specialization removed, for --report.
  std::vector<std::pair<std::string, OpCount>> unfolded_ops;
  long long statements = 0;
};

/// Above this many statements a specialized program is not emitted (compile
/// time grows about linearly, near 1 ms per statement at -O3, and code far
/// beyond the instruction caches loses what folding saved).
/// JRGEN_TERMS_LIMIT overrides (0: always the runtime's terms), and
/// JRGEN_TERMS_ROUTE=articulated|composite forces a tree's specialized route
/// (with JRGEN_TERMS_LIMIT=0: the runtime's articulated route, for trees and
/// for closed loops): both internal, for tests and measurements.
inline constexpr long long kMaxTermStatements = 40000;
long long terms_limit();

/// The forward_dynamics terms of a tree (nc == 0).  `solve_flops`: the
/// operations of the emitted Steps 1, 2 and 4, which only the
/// composite-rigid-body route runs.
TermsBlock tree_terms(const topology::Tree& tree, const Options& options, long long solve_flops);

/// The forward_dynamics terms of a closed-loop model: kinematics, M (packed),
/// Q = tau - h, the packed Phiq and gamma as one specialized program (the
/// kinematics shared by all), then the generated Steps 1-4.  Above the
/// statement limit, the runtime's terms, then by counted operations either
/// Steps 1-4 (`solve_flops`: their operations) or the runtime's
/// articulated-body route with the columns of M^-1 Phiq^T
/// (jr::articulated_closed: O(n nc), loops over long chains; not with
/// --singular proximal, whose regularized Step 3.4 it does not have).
TermsBlock loop_terms(const topology::Tree& tree, const Options& options, long long solve_flops);

/// The bodies of constraints(), constraint_jacobian() and constraint_gamma()
/// of a closed-loop model, with their specialized programs' definitions.
struct ConstraintPieces {
  std::string definitions;
  std::string constraints_body, jacobian_body, gamma_body;
};
ConstraintPieces constraint_pieces(const topology::Tree& tree);

/// The bodies of mass_matrix() and bias_forces() (the API's pieces), with
/// their specialized programs' definitions.
struct PieceTerms {
  std::string definitions;
  std::string mass_matrix_body, bias_forces_body;
};
PieceTerms piece_terms(const topology::Tree& tree, const Options& options);

/// Additions, multiplications, divisions, square roots, sines and cosines.
long long flops(const OpCount& c);

}  // namespace jrgen::emit
