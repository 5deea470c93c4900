// What emit_solver() writes for one model (internal to the emit stage): the
// method, the shape of Steps 1, 2 and 4, the variants asked for, the sizes
// that chose them.  Every unit of the emitter reads its decisions from here.
#pragma once

#include <vector>

#include "emit/emitter.hpp"
#include "topology/topology.hpp"

namespace jrgen::emit {

/// How Steps 1, 2 and 4 are written: straight-line code, the runtime's
/// table-driven loops over the packed layout, its supernodal kernels (trees
/// with a long single-child run, llt) or its parallel subtree loops
/// (Corollary 3, trees).  The same factor (Lemma 2) in every shape.
enum class Shape { kUnrolled, kTable, kSupernodal, kParallel };

/// The parallel shape's work items: a few per thread on small machines.
inline constexpr int kParallelParts = 32;

struct Plan {
  Method method = Method::kLLT;
  bool ldlt = false;      ///< method == kLDLT
  bool divide = false;    ///< --divide
  bool proximal = false;  ///< --singular proximal
  int threads = 0;        ///< --threads (Options::threads)
  /// Products of the unrolled Step 1 (sum over dofs of depth (depth + 1) / 2)
  /// and the number of (dof, ancestor) pairs (sum of depths): the sizes that
  /// choose the shape, and the op counts of the runtime's loops.
  long long products = 0, chain = 0;
  std::vector<topology::Supernode> supernodes;  ///< non-empty: kSupernodal
  /// Corollary 3's subtrees below a separator (partition_subtrees); non-empty: kParallel.
  std::vector<topology::Subtree> subtrees;
  /// --threads asked for the parallel shape, but partition_subtrees() left
  /// every dof in the separator (a short chain): serial (a note says so).
  bool parallel_declined = false;
  Shape shape = Shape::kUnrolled;
  bool unrolled = false;  ///< shape == kUnrolled
  /// Small unrolled models: a second Step 1 reading the user's dense M
  /// (solve_augmented) instead of a gather pass.
  bool fused = false;
  /// Step 1 writes Dinv = 1 / pivot (else, with --divide, the pivots):
  /// decided once Step 3's shape is known (set_step3_shape).
  bool write_dinv = true;
};

/// The plan of Steps 1, 2 and 4 (kMaxUnrolledProducts, kMinDenseSupernode,
/// kMinParallelDofs decide the shape).
Plan plan_solver(const topology::Tree& tree, const Options& options);

/// Step 1 writes the reciprocal pivots Dinv unless --divide leaves nothing
/// to read them; a table-driven Step 3 reads them.
void set_step3_shape(Plan& plan, bool step3_table_driven);

}  // namespace jrgen::emit
