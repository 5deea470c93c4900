// Step 1 of Section 4.3, straight-line: M = L L^T (or L D L^T) in place on
// the packed L, column by column, eq. (25) and (26).
#include <fmt/format.h>

#include "emit/format.hpp"
#include "emit/kernel.hpp"
#include "emit/steps/pivots.hpp"
#include "emit/steps/step_text.hpp"
#include "emit/steps/steps.hpp"

namespace jrgen::emit {

namespace {

// Column j of Step 1: the sums run over the descendants of the column only
// (Lemma 2: every other L[j, i] is zero), and only the rows of ancestors are
// computed.
//
// `dense` names the source of M's entries: empty, M is already packed in L
// (forward_dynamics); else the user's dense column-major M, read straight
// into the statement that first needs each entry (solve_augmented: no
// separate gather pass).
struct Column {
  const topology::Tree& t;
  const std::string& dense;
  int j;
  std::vector<int> anc;        ///< ancestors of j, nearest first: the rows computed
  const std::vector<int>& dj;  ///< descendants of j: the columns summed over

  // The original value of packed entry (row, col): row an ancestor of col.
  std::string M(int row, int col) const {
    if (dense.empty()) return L(t, row, col);
    return fmt::format("{}[{}]", dense, t.dof_user[row] + static_cast<long long>(t.nv) * t.dof_user[col]);
  }
  // Two neighbouring ancestor rows r = anc[p], r' = anc[p + 1] of column j
  // are stored next to each other in column j and in every column i of
  // F(j) (column i holds i's ancestors, nearest first, and those of j are a
  // suffix of them): their two statements of eq. (26) become one on a pair
  // of doubles (Kernel::update_pair, jrgen/simd.hpp).
  bool pairable(int r, int r2) const {
    if (t.packed(r2, j) != t.packed(r, j) + 1) return false;
    for (int i : dj)
      if (t.packed(r2, i) != t.packed(r, i) + 1) return false;
    return true;
  }
  std::string pair(int row, int col) const { return fmt::format("jr::load2(L + {})", t.packed(row, col)); }
  std::string M_pair(int r, int r2) const {
    if (dense.empty()) return pair(r, j);
    return fmt::format("jr::set2({}, {})", M(r, j), M(r2, j));
  }
};

// The rows of eq. (26) below the diagonal: for anc[p] (and anc[p + 1] when
// they pair up), with the scalar factor of descendant number n given by
// factor[n], then `scale`.  An entry with nothing to subtract or scale
// stays as it is.
void column_rows(Kernel& k, Kernel::Unit& u, const Column& c, const std::vector<std::string>& factor,
                 const Scale& scale) {
  const topology::Tree& t = c.t;
  for (std::size_t p = 0; p < c.anc.size();) {
    const int r = c.anc[p];
    if (c.dj.empty() && scale.empty() && c.dense.empty()) {
      p += 1;
    } else if (p + 1 < c.anc.size() && c.pairable(r, c.anc[p + 1])) {
      std::vector<Term> terms;
      for (std::size_t n = 0; n < c.dj.size(); ++n) terms.push_back({factor[n], c.pair(r, c.dj[n])});
      k.update_pair(u, "  ", fmt::format("L + {}", t.packed(r, c.j)), c.M_pair(r, c.anc[p + 1]), terms, scale);
      p += 2;
    } else {
      std::vector<Term> terms;
      for (std::size_t n = 0; n < c.dj.size(); ++n) terms.push_back({factor[n], L(t, r, c.dj[n])});
      k.update(u, "  ", L(t, r, c.j), c.M(r, c.j), terms, scale);
      p += 1;
    }
  }
}

// L L^T: eq. (25), L[j,j]^2 = M[j,j] - sum_i L[j,i]^2, then eq. (26),
// L[k,j] = (M[k,j] - sum_i L[j,i] L[k,i]) / L[j,j].  With `divide` each entry
// is divided by its pivot, as eq. (26) is written, and Dinv is written only
// with `write_dinv` (for the runtime's table-driven Step 3, which reads it);
// otherwise Dinv[j] holds the pivot itself, for the digits test
// (check_digits_M).
void column_llt(Kernel& k, Kernel::Unit& u, const Column& c, bool divide, bool write_dinv) {
  const topology::Tree& t = c.t;
  const int j = c.j;
  const std::string in = "  ";
  std::vector<Term> sq;
  std::vector<std::string> factor;
  for (int i : c.dj) {
    sq.push_back({L(t, j, i), L(t, j, i)});
    factor.push_back(L(t, j, i));
  }
  k.update(u, in, "d", c.M(j, j), sq, "", "const double ", "sd");
  u.lines.push_back(in + pivot_test(c.M(j, j), fmt::format("not_positive_definite({}, d)", j), "kMassPivotTolerance"));
  // 1 / L[j,j] = sqrt(d) * (1 / d): the square root and the division run
  // side by side, not one after the other, on the chain from this pivot to
  // the next column (one more multiplication per column;
  // docs/benchmarks.md, run 8: tree_d4_30 10% faster, talos 4%).
  u.lines.push_back(in + "const double l = std::sqrt(d);");
  u.lines.push_back(in + L(t, j, j) + " = l;");
  u.statements += 3;
  k.ops.sqrt += 1;
  if (!divide || write_dinv) {
    u.lines.push_back(in + fmt::format("Dinv[{}] = l * (1.0 / d);", j));
    k.ops.div += 1;
    k.ops.mul += 1;
  } else {
    u.lines.push_back(in + fmt::format("Dinv[{}] = d;  // the pivot itself, for check_digits_M", j));
  }
  ++u.statements;
  column_rows(k, u, c, factor, divide ? Scale::divided_by("l") : Scale(fmt::format("Dinv[{}]", j)));
}

// L D L^T: w_i = L[j,i] D[i]; D[j] = M[j,j] - sum_i w_i L[j,i];
// L[k,j] = (M[k,j] - sum_i w_i L[k,i]) * Dinv[j].
//
// --divide keeps W = L D instead (eq. 26 without the division), ldlt_pivot():
//   l_i = W[j,i] / D[i];  D[j] = M[j,j] - sum_i W[j,i] l_i;
//   W[k,j] = M[k,j] - sum_i W[k,i] l_i  (k an ancestor of j).
// One division per entry of L and no products w_i (165 fewer on the HMMWV),
// and column j's entries do not wait for its pivot.  Measured
// (docs/benchmarks.md, run 9): with divisions, legged30 4.5% faster than the
// products w_i; with reciprocals 10% slower (each entry is stored twice), so
// the default keeps the products.
void column_ldlt(Kernel& k, Kernel::Unit& u, const Column& c, bool divide, bool write_dinv) {
  const topology::Tree& t = c.t;
  const int j = c.j;
  LdltPivot pivot;
  for (int i : c.dj) {
    pivot.entries.push_back(L(t, j, i));
    pivot.pivots.push_back(L(t, i, i));
  }
  pivot.base = c.M(j, j);
  pivot.diag = L(t, j, j);
  pivot.fail = fmt::format("not_positive_definite({}, d)", j);
  pivot.inverse = fmt::format("Dinv[{}]", j);
  pivot.reciprocal = write_dinv;
  pivot.check = "check_digits_M";
  pivot.tolerance = "kMassPivotTolerance";
  const std::vector<std::string> factor = ldlt_pivot(k, u, pivot, divide);
  column_rows(k, u, c, factor, divide ? Scale() : Scale(fmt::format("Dinv[{}]", j)));
}

// Step 1: M = L L^T (or L D L^T), column by column, eq. (25) and (26).
Kernel step1(const topology::Tree& t, const std::vector<std::vector<int>>& desc, Method method, bool divide,
             bool write_dinv, const std::string& dense = "") {
  Kernel k;
  for (int j = 0; j < t.nv; ++j) {
    Kernel::Unit& u = k.unit();
    const Column c{t, dense, j, t.ancestors(j), desc[j]};
    u.lines.push_back(fmt::format("// column {}: {}; {} descendant(s), {} ancestor row(s)", j, dof_label(t, j),
                                  c.dj.size(), c.anc.size()));
    u.lines.push_back("{");
    if (method == Method::kLLT) column_llt(k, u, c, divide, write_dinv);
    else column_ldlt(k, u, c, divide, write_dinv);
    u.lines.push_back("}");
  }
  return k;
}

}  // namespace

std::string factor_note(const Plan& plan) {
  return plan.method == Method::kLLT ? "M = L L^T" : "M = L D L^T, D on the diagonal of L";
}

std::string step1_unrolled(const topology::Tree& t, const Plan& plan, const std::vector<std::vector<int>>& desc,
                           OpCount& ops) {
  Kernel k1 = step1(t, desc, plan.method, plan.divide, plan.write_dinv);
  // Fences in Step 1 only: Steps 2 and 4 are short chains of dependent
  // rows, slower with each value read back (docs/benchmarks.md, run 8).
  k1.fence_every = kFenceProducts;
  ops = k1.ops;
  std::string out = k1.functions(
      "step1_factor", "double* L, double* Dinv", "L, Dinv", true,
      fmt::format("---- Step 1: factor {} in place (packed), eq. (25)-(26). ----\n"
                  "Lemma 2: no fill-in; column j reads only rows of its descendants\n"
                  "and writes only rows of its ancestors. {}\n{}",
                  factor_note(plan),
                  !plan.divide      ? "Dinv[j] = 1 / pivot j."
                  : plan.write_dinv ? "Entries are divided by their pivot L[j,j] (--divide);\n"
                                      "Dinv[j] = 1 / pivot j is kept for Step 3's loops."
                                    : "Entries are divided by their pivot L[j,j] (--divide).",
                  ops_text(k1.ops, true)));
  if (!plan.fused) return out;
  // Small models: the same statements reading the user's dense M.
  Kernel k1_dense = step1(t, desc, plan.method, plan.divide, plan.write_dinv, "M");
  k1_dense.fence_every = kFenceProducts;
  return out + "\n\n" +
         k1_dense.functions("step1_factor_dense", "const double* M, double* L, double* Dinv", "M, L, Dinv", true,
                            "---- Step 1 for solve_augmented: the same statements, each reading its entry of\n"
                            "the user's dense M (column-major, user order) where the packed variant reads\n"
                            "L: only the structurally non-zero entries of eq. (18) are read, and no\n"
                            "separate copy of M into L is made.");
}

std::string step1_gather_then_factor() {
  return "\n\n// Step 1 for solve_augmented: gather M's structurally non-zero entries, then factor.\n"
         "int step1_factor_dense(const double* M, double* L, double* Dinv) {\n"
         "  gather_M(M, L);\n"
         "  return step1_factor(L, Dinv);\n"
         "}";
}

}  // namespace jrgen::emit
