// Step 3 of Section 4.3 (closed loops): the driver.  emit_loops() lays out
// the kept rows, T and T^T T (Step3Layout), chooses the shape (straight-line
// while it stays under step3_unroll_limit() products, else the runtime's
// table-driven loops over the same tables, the same arithmetic), and joins
// the sub-steps 3.1-3.5 (steps/step31.cpp .. step35.cpp).
#include <fmt/format.h>

#include <algorithm>
#include <stdexcept>

#include "emit/format.hpp"
#include "emit/steps/step3.hpp"
#include "emit/steps/step_text.hpp"

namespace jrgen::emit {

std::vector<Row> kept_rows(const topology::Tree& t) {
  std::vector<Row> rows;
  int start = 0;
  for (int c = 0; c < static_cast<int>(t.cuts.size()); ++c) {
    const topology::Cut& cut = t.cuts[c];
    for (int r : cut.kept_rows) {
      rows.push_back({c, r, start});
      start += static_cast<int>(cut.dofs.size());
    }
  }
  return rows;
}

int dof_index(const topology::Cut& cut, int dof) {
  return static_cast<int>(std::lower_bound(cut.dofs.begin(), cut.dofs.end(), dof) - cut.dofs.begin());
}

std::string row_label(const topology::Tree& t, const Row& row) {
  const topology::Cut& cut = t.cuts[row.cut];
  if (cut.type == ir::CutType::Mimic) return fmt::format("mimic joint '{}'", comment_text(cut.name));
  return fmt::format("loop joint '{}' row {}", comment_text(cut.name), row.type_row + 1);
}

int TByDofs::at(int dof, int row) const {
  const std::vector<int>& r = rows[dof];
  const auto it = std::lower_bound(r.begin(), r.end(), row, [&](int a, int b) { return position[a] < position[b]; });
  return start[dof] + static_cast<int>(it - r.begin());
}

std::string Step3Layout::W(int row, int col) const {
  return fmt::format("W[{}]", square_W ? row + ld * col : sp.position(row, col));
}

Scale Step3Layout::pivot_scale(int j) const {
  return divide ? Scale::divided_by(W(j, j)) : Scale(fmt::format("Winv[{}]", j));
}

// The failure reports that name a kept row (kRowLabel: its loop joint and
// row), shared by both shapes of Step 3.  Labels print with at most 220
// characters: with the rest they fit g_error whatever the names.
std::string row_failure_functions() {
  return "// Constraint rows whose T^T T pivot fails: the loop joint is named.\n"
         "int constraints_singular(std::int32_t row, double pivot) {\n"
         "  std::snprintf(g_error, sizeof g_error,\n"
         "                \"constraint rows singular (T^T T not positive definite) at %.220s; pivot %.17g\",\n"
         "                kRowLabel[row], pivot);\n"
         "  return kConstraintsSingular;\n"
         "}\n\n"
         "int fail_row(int status, const char* what, std::int32_t row, double value) {\n"
         "  std::snprintf(g_error, sizeof g_error, \"%.100s at %.220s, value %.17g\", what, kRowLabel[row], value);\n"
         "  return status;\n"
         "}\n\n";
}

namespace {

// The straight-line Steps 3.1-3.5 keep T by its rows: for dof i, the entries
// of the constraint rows R_i whose cut reaches i (Lemma 3), ordered by their
// elimination position (Step 3.4); a descendant's R_v is a subset of R_i (its
// cut's path to the base passes through i).  The dofs that every row reaches
// then hold one contiguous k x m block in the order of W, which the dense
// kernels read as it is.  The packed Phiq stays as the runtime writes it (P,
// cut row by cut row); Step 3.1 reads it and writes T.
TByDofs t_by_dofs(const topology::Tree& t, const std::vector<Row>& rows, const SchurPattern& sp) {
  TByDofs td;
  td.rows.assign(t.nv, {});
  td.position.assign(rows.size(), 0);
  for (int p = 0; p < sp.m; ++p) td.position[sp.order[p]] = p;
  for (int p = 0; p < sp.m; ++p)
    for (int dof : t.cuts[rows[sp.order[p]].cut].dofs) td.rows[dof].push_back(sp.order[p]);
  td.start.assign(t.nv + 1, 0);
  for (int i = 0; i < t.nv; ++i) td.start[i + 1] = td.start[i] + static_cast<int>(td.rows[i].size());
  return td;
}

// The thread_local buffers of Step 3; `w_declaration` is the line of g_W,
// which depends on the layout of W.
std::string workspace(const topology::Tree& t, int m, int phiq_nnz, bool unrolled, bool ldlt,
                      const std::string& w_declaration) {
  return fmt::format(
      "[[maybe_unused]] thread_local jr::BodyMotion g_motion[{}];  // the runtime's constraint terms (fallback)\n"
      "{}"
      "thread_local double g_gamma[{}];\n"
      "{}"
      "thread_local double g_Winv[{}];  // inverse pivots of T^T T\n"
      "thread_local double g_zm[{}];    // z_m (Step 3.2), then lambda (Step 3.4)",
      t.bodies.size(),
      (unrolled ? fmt::format("thread_local double g_T[{0}];     // packed Phiq, cut row by cut row\n"
                              "thread_local double g_Tr[{0}];    // T = L^-1 Phiq^T by dofs (Step 3.1)\n",
                              phiq_nnz)
                : fmt::format("thread_local double g_T[{}];     // packed Phiq, overwritten by T (Step 3.1)\n",
                              phiq_nnz)) +
          (ldlt ? fmt::format("thread_local double g_V[{}];     // D^-1 U (Step 3.2)\n", phiq_nnz) : ""),
      m, w_declaration, m, m);
}

std::string packed_W_declaration(const SchurPattern& sp) {
  return fmt::format("thread_local double g_W[{}];     // T^T T packed (fill included), factored in place\n",
                     sp.nnz());
}

}  // namespace

// Dofs that every kept row reaches (a floating base under all the loops)
// make every pair of rows share a dof: T^T T and its factor are dense.  If
// those dofs are consecutive, their rows of T form one k x m row-major block,
// and Steps 3.3 and 3.4 call the runtime's compact dense loops for it
// (jrgen/constraint_solve.hpp) instead of unrolling the dense part.
Step3Layout step3_layout(const topology::Tree& t, const std::vector<Row>& rows, const SchurPattern& sp, bool ldlt,
                         bool divide) {
  Step3Layout lay(t, rows, sp);
  lay.ldlt = ldlt;
  lay.divide = divide;
  lay.m = static_cast<int>(rows.size());
  lay.td = t_by_dofs(t, rows, sp);
  const int m = lay.m;
  if (m >= kMinDenseSchurRows) {
    std::vector<int> full;
    for (int i = 0; i < t.nv; ++i)
      if (static_cast<int>(lay.td.rows[i].size()) == m) full.push_back(i);
    if (!full.empty() && full.back() - full.front() + 1 == static_cast<int>(full.size())) {
      lay.dense_first = full.front();
      lay.dense_dofs = static_cast<int>(full.size());
    }
  }
  if (lay.dense_schur())
    for (int j = 0; j < m; ++j)  // every entry of the lower triangle (the dense kernels' layouts)
      if (sp.col_start[j] != j * m - j * (j - 1) / 2 || static_cast<int>(sp.pattern[j].size()) != m - 1 - j)
        throw std::logic_error("emit_loops: T^T T not dense although every row shares a dof");
  // Up to kMaxFixedDenseSchur rows the dense W is kept square (column j from
  // j * ld, ld = m rounded up to even: the runtime's schur_square_* loops
  // then run over aligned pairs of rows only); otherwise packed by columns.
  lay.square_W = lay.dense_schur() && m <= kMaxFixedDenseSchur;
  lay.ld = m + (m & 1);
  return lay;
}

LoopCode emit_loops(const topology::Tree& t, Method method, bool divide, bool unrolled_gathers,
                    const std::string& name_space) {
  LoopCode out;
  const bool ldlt = method == Method::kLDLT;
  const std::vector<Row> rows = kept_rows(t);
  const int m = static_cast<int>(rows.size());
  const int phiq_nnz = rows.empty() ? 0 : rows.back().t_start + static_cast<int>(t.cuts[rows.back().cut].dofs.size());
  const SchurPattern sp = schur_pattern(t);
  const Step3Tables tab = step3_tables(t, rows, sp);
  // Straight-line Step 3 while it stays small enough to compile quickly;
  // beyond that, the runtime's loops over the same tables (same arithmetic).
  const bool unrolled = tab.products <= step3_unroll_limit();
  out.tables = constraint_tables(t, rows);
  out.gather = gather_phiq(t, rows, unrolled_gathers && unrolled);
  if (!unrolled) {
    out.workspace = workspace(t, m, phiq_nnz, unrolled, ldlt, packed_W_declaration(sp));
    table_driven_step3(t, sp, tab, ldlt, name_space, out);
    out.W_diag.assign(tab.W_col_start.begin(), tab.W_col_start.end() - 1);
    out.table_driven = true;
    out.reciprocal_steps = "3.1-3.5 (the runtime's table-driven loops)";
    return out;
  }

  const Step3Layout lay = step3_layout(t, rows, sp, ldlt, divide);
  out.workspace = workspace(t, m, phiq_nnz, unrolled, ldlt,
                            lay.square_W ? fmt::format("thread_local double g_W[{}];     // T^T T, square ({} x {}, "
                                                       "lower triangle), factored in place\n",
                                                       lay.ld * lay.ld, lay.ld, lay.ld)
                                         : packed_W_declaration(sp));
  const StepCode s31 = step31(lay), s32 = step32(lay), s33 = step33(lay), s34 = step34(lay), s35 = step35(lay);
  out.step3 = row_failure_functions() + s31.text + "\n\n" + s32.text + "\n\n" + s33.text + "\n\n" + s34.text +
              "\n\n" + s35.text;
  if (lay.dense_schur()) {
    // The dense kernels live in the runtime header: included at file scope.
    out.tables = include_at_file_scope(name_space, "#include <jrgen/constraint_solve.hpp>  // dense Steps 3.3-3.4") +
                 out.tables;
    out.workspace += fmt::format(
        "\nthread_local double g_zw[{}];    // forward solution, then lambda, elimination order (Step 3.4)",
        lay.square_W ? lay.ld : m);
    out.reciprocal_steps = "3.4 (the runtime's dense kernels)";
  }
  for (int j = 0; j < m; ++j) out.W_diag.push_back(lay.square_W ? j * (lay.ld + 1) : sp.position(j, j));
  out.tables += fmt::format("\n// Elimination position of Step 3.4 -> kept row (user order).\n"
                            "constexpr std::int32_t kSchurOrder[{}] = {{ {} }};",
                            m, join_ints(sp.order));
  out.call_args["step31_args"] = s31.call_args;
  out.call_args["step32_args"] = s32.call_args;
  out.call_args["step33_args"] = s33.call_args;
  out.call_args["step35_args"] = s35.call_args;
  out.ops = {{"3.1", s31.ops}, {"3.2", s32.ops}, {"3.3", s33.ops}, {"3.4", s34.ops}, {"3.5", s35.ops}};
  return out;
}

}  // namespace jrgen::emit
