// Straight-line kernels under construction (internal to the emit stage): a
// list of indivisible units (one per column or row of a step), each a few
// statements, with a count of the floating-point operations written.
#pragma once

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "emit/emitter.hpp"

namespace jrgen::emit {

// Functions longer than this many statements are split, so that the compiler
// never sees one giant basic block (compile time grows faster than linearly).
inline constexpr std::size_t kMaxStatementsPerFunction = 4000;
// Models whose unrolled Step 1 would hold more products than this get the
// runtime's table-driven loops for Steps 1, 2 and 4 instead: the unrolled
// code outgrows the instruction caches, and compile time grows with it.
// Chosen by measurement (docs/benchmarks.md, run 5: the generated Steps 1, 2,
// 4 against the runtime's loops on the same packed M, in one process, on a
// 32 KiB-L1i AMD machine): straight-line is 1.5-1.6x faster at 4 500-6 500
// products (random trees of 300 dofs) and 1.4x at 15 200 (the 1000-dof
// scene), the loops 1.06x faster at 16 600 (tree_d4_1000), 1.3x at 24 900
// and 2.4x at 44 300 (tree_1000).  The earlier limit, 50 000, was the
// break-even on another machine (2026-11-22), where tree_1000 ran both
// shapes at the same speed; on this one it lost 2.4x there.  Since Steps 1
// and 3.1 write pairs of doubles (jrgen/simd.hpp) the straight-line code
// also wins at 16 600 (1.10x), so the break-even now lies between 16 600 and
// 24 900 products; the limit has not been moved again.
inline constexpr long long kMaxUnrolledProducts = 16000;
// Closed loops whose straight-line Step 3 would hold more products than this
// get the runtime's table-driven Step 3 (docs/trains.md).  Not re-measured
// with the limit above: it keeps the value both shared until run 5.
inline constexpr long long kMaxUnrolledStep3Products = 50000;
// Models whose unrolled Step 1 holds at most this many products also get a
// second copy of it reading the user's dense M (solve_augmented), instead of
// a gather pass before the factorization: small models, where that pass is
// a tenth of the solve.
inline constexpr long long kMaxFusedGatherProducts = 20000;
// Trees whose dof tree holds a supernode (a run of single-child dofs, see
// topology::dense_supernodes) of at least this many dofs get the supernodal
// Steps 1, 2, 4 (Eigen's blocked dense kernels on those runs, with method
// llt; docs/benchmarks.md for the measurement that chose it).
inline constexpr int kMinDenseSupernode = 48;
// --threads auto: trees with at least this many dofs get the parallel
// variant (Corollary 3; docs/benchmarks.md).
inline constexpr int kMinParallelDofs = 10000;
// Above this many packed entries, solve_augmented's gather of M walks the dof
// tree instead of reading a table of source indices (source size).
inline constexpr long long kMaxGatherTable = 1 << 20;
// Closed-loop models with at least this many kept rows, all reaching some
// common dofs (T^T T dense), get the runtime's dense loops for that part of
// Steps 3.3 and 3.4 (docs/benchmarks.md, run 4).
inline constexpr int kMinDenseSchurRows = 8;
// Up to this many rows the dense Steps 3.3 and 3.4 keep W square and call
// the runtime's loops with the size as a template argument
// (jr::schur_square_gram_fixed, jr::schur_square_factor_forward_fixed,
// jr::schur_square_backward_fixed): whole pairs of rows, every trip count
// known to the compiler; larger dense parts keep W packed by columns and the
// loops with the sizes at run time (jr::schur_dense_*).
inline constexpr int kMaxFixedDenseSchur = 32;
// Solvers with at least this many additions and multiplications (all steps,
// as --report counts them) keep each step in its own function; below, the
// compiler may inline them into the solve (docs/benchmarks.md, run 7:
// measured between tree_30, 992, no difference, and anymal, 1281).
inline constexpr long long kMinOpsSeparateSteps = 1000;
// Sums of more products than this are split into partial sums.
inline constexpr std::size_t kMaxTermsPerStatement = 8;
// Kernels with fences (Steps 1 and 3.1-3.3, 3.5) get a jr::compiler_fence()
// between two units once the units since the last fence have written at
// least this many products (each " * " of their statements).  The steps of
// solvers below kMinOpsSeparateSteps get none.  Chosen by measurement
// (docs/benchmarks.md, run 8; each shape built at six code placements):
// a fence between every two units made the HMMWV 6% and talos 9% faster
// but tree_d4_30 5% slower, whose short columns gain from the values kept
// in registers; after every 128 products the HMMWV gained 0.5%.  After
// every 64, as landed: the HMMWV 5% faster, its L D L^T variant 11%,
// legged30 11%, tree_300 7%, talos, chain_30 and the Stewart platform
// 5-6%, tree_d4_30 and tree_d4_100 unchanged, tree_100 3.5% slower.
inline constexpr std::size_t kFenceProducts = 64;

/// A product a * b of two named scalars.
struct Term {
  std::string a, b;
};

/// The final scaling of an update: "* by" (a reciprocal pivot), or with
/// `divide` "/ by" (the pivot itself, --divide).  Empty `by`: none.
struct Scale {
  std::string by;
  bool divide = false;
  Scale() = default;
  Scale(std::string factor) : by(std::move(factor)) {}  // NOLINT: a product, as the plain strings before
  Scale(const char* factor) : by(factor) {}              // NOLINT
  static Scale divided_by(std::string pivot) {
    Scale s(std::move(pivot));
    s.divide = true;
    return s;
  }
  bool empty() const { return by.empty(); }
  /// " * by" or " / by".
  std::string applied() const { return (divide ? " / " : " * ") + by; }
};

struct Kernel {
  struct Unit {
    std::vector<std::string> lines;
    std::size_t statements = 0;
  };
  std::vector<Unit> units;
  OpCount ops;
  /// Non-zero: functions() writes "jr::compiler_fence();" before a unit once
  /// the units since the last fence (or the start of the function) hold at
  /// least this many products (kFenceProducts).
  std::size_t fence_every = 0;

  Unit& unit() { return units.emplace_back(); }

  /// Appends "decl target = (base - sum terms) * scale;" (scale may be empty;
  /// "target *= scale;" when there are no terms; base may be empty: "-sum";
  /// "/" for a dividing Scale).  Counts len(terms) multiplications and
  /// additions (one fewer with no base), plus one multiplication (division)
  /// for the scale.
  /// Sums of more than kMaxTermsPerStatement products go through a partial
  /// sum named `acc`, inside a block when `scoped`.
  void update(Unit& u, const std::string& indent, const std::string& target, const std::string& base,
              const std::vector<Term>& terms, const Scale& scale, const std::string& decl = "",
              const std::string& acc = "s");

  /// Two update()s of neighbouring targets as one statement on jr::v2d:
  /// "jr::store2(target, (base - sum terms) * scale);" (scale may be empty;
  /// "/" for a dividing Scale),
  /// with `target` a pointer expression, `base` a jr::v2d expression, and in
  /// each term a scalar times a jr::v2d expression (jrgen/simd.hpp).  Each
  /// lane computes exactly what update() would for its target, in the same
  /// order, and counts as two update()s (base may be empty: "-sum").
  void update_pair(Unit& u, const std::string& indent, const std::string& target, const std::string& base,
                   const std::vector<Term>& terms, const Scale& scale);

  /// Appends "target = sum terms - tail;" (tail may be empty).  Counts
  /// len(terms) multiplications, len(terms) - 1 additions, plus one for the tail.
  void assign_sum(Unit& u, const std::string& indent, const std::string& target, const std::vector<Term>& terms,
                  const std::string& tail);

  /// Appends "target += sum terms;" (in statements of at most
  /// kMaxTermsPerStatement products; nothing when terms is empty).  Counts
  /// len(terms) multiplications and additions.
  void add_sum(Unit& u, const std::string& indent, const std::string& target, const std::vector<Term>& terms);

  /// Functions of at most kMaxStatementsPerFunction statements, and a driver
  /// `name(params)` calling them in order with `args`.  With `checked`, the
  /// parts return int (non-zero: stop) and the driver forwards it.  `doc` is
  /// written as a comment above.  A parameter a function body never indexes
  /// is cast to void, so tiny models compile under -Wunused-parameter.
  std::string functions(const std::string& name, const std::string& params, const std::string& args,
                        bool checked, const std::string& doc) const;
};

std::vector<std::string> split_lines(const std::string& text);

/// The statement Kernel::functions() writes as a fence, and `code` without
/// the lines that hold only it (solvers too small to gain from them).
inline constexpr const char* kFenceStatement = "jr::compiler_fence();";
std::string strip_fences(const std::string& code);

}  // namespace jrgen::emit
