// Emit stage, closed loops: the constraint tables and the straight-line code
// of Step 3 (3.1-3.5) of the algorithm of Section 4.3, for trees with cut
// joints whose kept rows are known (analysis::analyze_constraints).
// Defined in steps/step3.cpp (emit_loops, one unit per sub-step beside it),
// steps/schur_pattern.cpp and plan.cpp (the limits); see docs/trains.md and docs/scale.md.
#pragma once

#include <string>
#include <vector>

#include "emit/emitter.hpp"
#include "emit/template.hpp"

namespace jrgen::emit {

/// The symbolic structure of T^T T (m x m) and of its Cholesky factor in the
/// elimination order of topology::constraint_row_order (Step 3.4): rows and
/// columns are elimination positions; position j is kept row order[j] (user
/// row order, cut by cut).  Column j holds the diagonal, then the rows of
/// pattern[j] (ascending positions, fill included).
struct SchurPattern {
  int m = 0;
  std::vector<int> order;                  ///< elimination position -> kept row (user order)
  bool minimum_degree = false;             ///< order from minimum degree (else the natural order)
  std::vector<std::vector<int>> pattern;   ///< rows below the diagonal, per column
  std::vector<std::vector<int>> row_list;  ///< columns left of the diagonal, per row
  std::vector<int> col_start;              ///< packed column starts (m + 1)
  std::vector<std::vector<bool>> structural;  ///< per column, per pattern entry: non-zero in T^T T (else fill)
  int position(int row, int col) const;    ///< packed index of (row >= col)
  int nnz() const { return col_start.empty() ? 0 : col_start.back(); }
};

/// Entry (r, s) of T^T T is structurally non-zero when the cuts of rows r and
/// s share a dof (Lemma 3); the factor's fill follows by symbolic elimination
/// in the fill-reducing order.
SchurPattern schur_pattern(const topology::Tree& tree);

struct LoopCode {
  std::string tables;     ///< constraint tables (namespace scope)
  std::string workspace;  ///< thread_local buffers
  std::string step3;      ///< the functions of Steps 3.1-3.5 and their helpers
  std::string gather;     ///< gather_Phiq: dense Phiq -> packed, non-zero entries only
  TemplateValues call_args;  ///< arguments of the Step 3 calls in api_loops.cpp.tmpl
  std::vector<StepOps> ops;  ///< "3.1" .. "3.5"
  /// Step 3 calls the runtime's table-driven loops (which read Dinv).
  bool table_driven = false;
  /// The parts of Step 3 that run the runtime's loops, which multiply by
  /// reciprocal pivots also under --divide (empty: none).
  std::string reciprocal_steps;
  /// Where the diagonal entry of each elimination position sits in g_W.
  std::vector<int> W_diag;
};

/// Step 3 as straight-line code, or, when that would hold more than
/// step3_unroll_limit() products, as calls of the runtime's table-driven
/// loops (jrgen/constraint_solve.hpp) over emitted tables.  `name_space` is
/// the solver's namespace (the table-driven code includes the runtime header
/// at file scope).  With `divide` the straight-line code divides by each
/// pivot where it is used (Options::divide), read from L's diagonal, where
/// every shape of Step 1 leaves them (L[j,j], or D[j] with L D L^T).
LoopCode emit_loops(const topology::Tree& tree, Method method, bool divide, bool unrolled_gathers,
                    const std::string& name_space);

/// kMaxUnrolledStep3Products, or (internal, for tests only: not part of the CLI)
/// the value of the environment variable JRGEN_STEP3_UNROLL_LIMIT when it is a
/// non-negative integer; 0 forces the table-driven Step 3 on every model.
long long step3_unroll_limit();

/// The same for Steps 1, 2 and 4: kMaxUnrolledProducts, or the value of the
/// internal, test-only environment variable JRGEN_UNROLL_LIMIT; 0 forces the
/// runtime's table-driven Steps 1, 2, 4 on every model.
long long unroll_limit();

}  // namespace jrgen::emit
