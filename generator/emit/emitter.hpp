// Emit stage: topology::Tree -> the text of OUT.hpp and OUT.cpp.
//
// Steps 1, 2 and 4 of the algorithm of Section 4.3 are written out as
// straight-line code over the packed factor, touching only structurally
// non-zero entries (Lemma 2, Remark 2); the kinematics come from the runtime.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "ir/ir.hpp"
#include "topology/topology.hpp"

namespace jrgen::emit {

enum class Method { kLLT, kLDLT };

struct Options {
  std::string name_space;      ///< C++ namespace of the generated API
  Eigen::Vector3d gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  Method method = Method::kLLT;
  std::string source_name;     ///< URDF base name, for the banner
  std::string cuts_name;       ///< cuts file base name or empty
  std::string header_name;     ///< base name of OUT.hpp, as included by OUT.cpp
  /// Corollary 3 parallel variant (--threads): 0 auto (trees of at least
  /// kMinParallelDofs dofs), 1 never, N >= 2 always with N OpenMP threads.
  int threads = 0;
  /// --divide: the straight-line steps divide by each pivot where it is
  /// used (one rounding per entry, the operation mix of the paper's Tables
  /// 1-3) instead of multiplying by its reciprocal.  Steps that run the
  /// runtime's loops keep the reciprocals (Solver::notes says which).
  bool divide = false;
  /// --singular proximal: when T^T T is singular or nearly so (a pivot or
  /// the pivots' spread fails its test), Step 3.4 solves for lambda by the
  /// proximal-point iteration instead of returning status 2, and the API
  /// gains last_solve_regularized() (docs/singular.md).  Off: status 2.
  bool singular_proximal = false;
  /// The assembled configuration (nq, user order) written to q_assembled[]
  /// (analysis::ConstraintAnalysis::configurations[0]); empty: the zero
  /// configuration (identity quaternions), as for a tree.
  std::vector<double> q_assembled;
};

/// Floating-point operations of emitted code, counted as written.
struct OpCount {
  long long add = 0, mul = 0, div = 0, sqrt = 0;
  long long trig = 0;  ///< sines and cosines (straight-line kinematics)
  OpCount& operator+=(const OpCount& o) {
    trig += o.trig;
    add += o.add;
    mul += o.mul;
    div += o.div;
    sqrt += o.sqrt;
    return *this;
  }
};

struct StepOps {
  std::string step;  ///< "1", "2", "3.1", ..., "4"
  OpCount ops;
};

struct Solver {
  std::string header;
  std::string source;
  std::vector<StepOps> ops;  ///< per step of Section 4.3, in order
  std::vector<std::string> notes;  ///< one line each, for stderr (jrgen: note: ...)
  bool divide = false;             ///< emitted with Options::divide
  std::string route;               ///< how forward_dynamics computes its terms (banner, report)
  std::vector<std::pair<std::string, OpCount>> terms_ops;  ///< per block of the specialized terms
  std::vector<std::pair<std::string, OpCount>> terms_unfolded_ops;  ///< the same, nothing folded
  bool fd_runs_steps = true;  ///< forward_dynamics runs the generated Steps (false: articulated-body route)
};

/// Throws jrgen::Error for models the generated code cannot serve.
Solver emit_solver(const ir::Robot& robot, const topology::Tree& tree, const Options& options);

/// The namespace derived from a robot name (docs/interface.md section 1), one
/// documented rule (docs): every character that is not [A-Za-z0-9_] becomes
/// '_', runs of '_' become one, leading '_' are dropped (a global name that
/// starts with '_' is reserved), an empty or digit-led result gets the prefix
/// "robot_", and a keyword (or std, jr, posix) gets a '_' suffix.  The
/// result is always a valid_namespace().
std::string sanitize_identifier(std::string_view name);

/// Why `name` cannot be the namespace of a generated solver ("" when it can):
/// empty, not [A-Za-z_][A-Za-z0-9_]*, a keyword, or reserved ([lex.name]:
/// containing "__", or starting with '_' at global scope; std, posix).
std::string invalid_namespace(std::string_view name);

}  // namespace jrgen::emit
