// Steps 1, 2 and 4 as calls of the runtime's table-driven loops over the
// packed layout (Shape::kTable: models whose straight-line Step 1 would hold
// more than unroll_limit() products), and the operation counts of the
// runtime's loops that every non-straight-line shape shares.
#include <fmt/format.h>

#include <algorithm>
#include <cstdint>

#include <jrgen/runtime.hpp>

#include "emit/format.hpp"
#include "emit/loops.hpp"
#include "emit/steps/step_text.hpp"
#include "emit/steps/steps.hpp"

namespace jrgen::emit {

namespace {

// The row tables of the packed L for the table-driven Steps 2 and 4
// (jr::PackedRows), as the runtime's fill_packed_rows() computes them from
// the dof tree and the column starts.
std::string packed_rows_tables(const topology::Tree& t) {
  const std::size_t nnz = static_cast<std::size_t>(t.M_col_start[t.nv]);
  const std::size_t off = nnz - static_cast<std::size_t>(t.nv);
  jr::Model model{};
  model.nv = t.nv;
  model.dof_parent = t.dof_parent.data();
  model.M_col_start = t.M_col_start.data();
  // One unused entry when L is diagonal (a C++ array has at least one).
  std::vector<std::int32_t> entry_row(nnz), row_start(t.nv + 1), row_entry(std::max<std::size_t>(off, 1)),
      row_col(std::max<std::size_t>(off, 1));
  jr::fill_packed_rows(model, entry_row.data(), row_start.data(), row_entry.data(), row_col.data());
  return fmt::format(
      "// Row access to the packed L for Steps 2 and 4 (jr::PackedRows): the row of\n"
      "// each stored entry, and each row's off-diagonal entries (positions in L and\n"
      "// columns, by column ascending).\n"
      "constexpr std::int32_t kEntryRow[{}] = {{ {} }};\n"
      "constexpr std::int32_t kRowStart[{}] = {{ {} }};\n"
      "constexpr std::int32_t kRowEntry[{}] = {{ {} }};\n"
      "constexpr std::int32_t kRowCol[{}] = {{ {} }};\n"
      "constexpr jr::PackedRows kRows = {{kEntryRow, kRowStart, kRowEntry, kRowCol}};",
      entry_row.size(), join_ints(entry_row), row_start.size(), join_ints(row_start), row_entry.size(),
      join_ints(row_entry), row_col.size(), join_ints(row_col));
}

}  // namespace

// The runtime's column loop (factor_packed, and the columns of the parallel
// shape), the same for both methods: one reciprocal pivot, a product w_a / d
// per ancestor row, the update products, and the scaling of the rows; L L^T
// adds l = sqrt(d) and its scale l / d (jr::detail::row_scale).  The
// supernodal shape's dense blocks run Eigen's kernels instead and are counted
// as if they ran this loop.
Steps124 runtime_loop_ops(const topology::Tree& t, const Plan& plan) {
  const bool l = plan.ldlt;
  const long long products = plan.products, chain = plan.chain;
  Steps124 s;
  s.ops1 = {products, products + 2 * chain + (l ? 0 : t.nv), t.nv, l ? 0 : t.nv};
  s.ops2 = {chain, chain + (l ? 0 : t.nv), 0, 0};
  s.ops4 = {chain, chain + t.nv, 0, 0};
  if (plan.shape == Shape::kTable) {
    // forward_packed and backward_packed keep two partial sums per row:
    // one more addition each (the other shapes' loops keep one).
    s.ops2.add += t.nv;
    s.ops4.add += t.nv;
  }
  return s;
}

void table_steps(const topology::Tree& t, const Plan& plan, Steps124& s) {
  const std::string why = fmt::format(
      "Unrolled, Step 1 alone would hold {} products (more than {}): code that\n"
      "large outgrows the instruction caches and runs slower than the runtime's\n"
      "loops over the same packed layout, which compute the same factor (Lemma 2:\n"
      "no fill-in; only ancestor rows are touched).",
      plan.products, unroll_limit());
  const char* flag = plan.ldlt ? "true" : "false";
  s.step1 = call_function(
      fmt::format("---- Step 1: factor {} in place (packed), eq. (25)-(26), table-driven. ----\n{}\n{}",
                  factor_note(plan), why, ops_text(s.ops1, true)),
      "int step1_factor(double* L, double* Dinv)",
      {"double pivot = 0.0;",
       fmt::format("const std::int32_t j = jr::factor_packed(kModel, L, Dinv, {}, kMassPivotTolerance, &pivot);", flag),
       "return j < 0 ? 0 : not_positive_definite(j, pivot);"});
  s.step2 = packed_rows_tables(t) + "\n\n" +
            call_function("---- Step 2: solve L z = Q (forward substitution), Remark 2, table-driven. ----\n"
                          "Row j sums over its descendants (kRowEntry).\n" +
                              ops_text(s.ops2),
                          fmt::format("void step2_forward(const double* L, {}double* z)",
                                      plan.ldlt ? "" : "const double* Dinv, "),
                          {fmt::format("jr::forward_packed(kModel, kRows, L, {}, {}, z);",
                                       plan.ldlt ? "nullptr" : "Dinv", flag)});
  s.step4 = call_function("---- Step 4: solve L^T qdd = z (back substitution), Remark 2, table-driven. ----\n"
                          "Column j sums over its ancestors (kEntryRow).\n" +
                              ops_text(s.ops4),
                          "void step4_backward(const double* L, const double* Dinv, double* z)",
                          {fmt::format("jr::backward_packed(kModel, kRows, L, Dinv, {}, z);", flag)});
}

}  // namespace jrgen::emit
