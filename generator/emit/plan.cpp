#include "emit/plan.hpp"

#include <algorithm>
#include <cstdlib>

#include "emit/kernel.hpp"
#include "emit/loops.hpp"

namespace jrgen::emit {

namespace {

// A non-negative integer from the environment variable `name`, else `fallback`.
long long limit_from_environment(const char* name, long long fallback) {
  if (const char* text = std::getenv(name)) {
    char* end = nullptr;
    const long long v = std::strtoll(text, &end, 10);
    if (*text && !*end && v >= 0) return v;
  }
  return fallback;
}

}  // namespace

long long step3_unroll_limit() { return limit_from_environment("JRGEN_STEP3_UNROLL_LIMIT", kMaxUnrolledStep3Products); }

long long unroll_limit() { return limit_from_environment("JRGEN_UNROLL_LIMIT", kMaxUnrolledProducts); }

// Shape of Steps 1, 2 and 4: straight-line code while it stays small enough
// to compile quickly; beyond that, the runtime's loops over the same packed
// layout (the same factor, no fill-in either way).  Trees (no Step 3 reading
// the packed L) may instead get the supernodal shape, when a long run of
// single-child dofs makes a dense block, or the parallel one (Corollary 3),
// for large trees.
Plan plan_solver(const topology::Tree& t, const Options& options) {
  Plan p;
  p.method = options.method;
  p.ldlt = options.method == Method::kLDLT;
  p.divide = options.divide;
  p.proximal = options.singular_proximal;
  p.threads = options.threads;
  for (int j = 0; j < t.nv; ++j) {
    const long long k = t.dof_depth[j];
    p.products += k * (k + 1) / 2;
    p.chain += k;
  }
  const bool tree_only = t.cuts.empty();
  if (tree_only && options.method == Method::kLLT) p.supernodes = topology::dense_supernodes(t, kMinDenseSupernode);
  const bool parallel = tree_only && (options.threads >= 2 || (options.threads == 0 && t.nv >= kMinParallelDofs));
  if (parallel) p.subtrees = topology::partition_subtrees(t, kParallelParts, std::max(16, t.nv / 20));
  // A tree whose dofs all fit in the separator (a short chain) leaves no
  // subtree to factor in parallel: the serial shapes then.
  p.parallel_declined = parallel && p.subtrees.empty();
  p.shape = !p.subtrees.empty()               ? Shape::kParallel
            : !p.supernodes.empty()           ? Shape::kSupernodal
            : p.products <= unroll_limit()    ? Shape::kUnrolled
                                              : Shape::kTable;
  p.unrolled = p.shape == Shape::kUnrolled;
  p.fused = p.unrolled && p.products <= kMaxFusedGatherProducts;
  return p;
}

// --divide: Dinv only for a table-driven Step 3, whose loops read it.
void set_step3_shape(Plan& plan, bool step3_table_driven) {
  plan.write_dinv = !plan.divide || (plan.unrolled && step3_table_driven);
}

}  // namespace jrgen::emit
