// Steps 3.1-3.5 as calls of the runtime's table-driven loops
// (jrgen/constraint_solve.hpp) over emitted tables: closed loops whose
// straight-line Step 3 would hold more than step3_unroll_limit() products.
// Same arithmetic as the straight-line units, counted the same way.
#include <fmt/format.h>

#include <algorithm>

#include "emit/format.hpp"
#include "emit/steps/step3.hpp"
#include "emit/steps/step_text.hpp"

namespace jrgen::emit {

namespace {

// Lemma 3's dof lists per cut, each dof's parent on its list, and the
// number of its ancestors on the list (per kCutDofs entry, returned).
std::vector<int> cut_lists(const topology::Tree& t, Step3Tables& tab) {
  std::vector<int> ancestors_on_list;
  tab.cut_dof_start.push_back(0);
  for (const topology::Cut& cut : t.cuts) {
    const int first = static_cast<int>(tab.cut_dofs.size());
    for (int d : cut.dofs) {
      tab.cut_dofs.push_back(d);
      const int parent = t.dof_parent[d];
      tab.cut_parent_index.push_back(parent < 0 ? -1 : dof_index(cut, parent));
    }
    // Ancestors of each dof on the list: the length of its parent chain.
    for (std::size_t i = 0; i < cut.dofs.size(); ++i) {
      int n = 0;
      for (int a = tab.cut_parent_index[first + i]; a >= 0; a = tab.cut_parent_index[first + a]) ++n;
      ancestors_on_list.push_back(n);
    }
    tab.cut_dof_start.push_back(static_cast<int>(tab.cut_dofs.size()));
    tab.cut_num_distinct.push_back(cut.num_distinct);
  }
  return ancestors_on_list;
}

// The kept rows' cuts and T starts; Steps 3.1, 3.2 and 3.5 counted.
void row_lists(const topology::Tree& t, const std::vector<Row>& rows, const std::vector<int>& ancestors_on_list,
               Step3Tables& tab) {
  for (const Row& row : rows) {
    tab.row_cut.push_back(row.cut);
    tab.row_t_start.push_back(row.t_start);
    const int n = static_cast<int>(t.cuts[row.cut].dofs.size());
    for (int i = 0; i < n; ++i) {
      const long long a = ancestors_on_list[tab.cut_dof_start[row.cut] + i];
      tab.products += a;
      tab.ops31.add += a;
      tab.ops31.mul += a;
    }
    tab.products += 2LL * n;  // Steps 3.2 and 3.5
    tab.ops32.add += n;
    tab.ops32.mul += n;
    tab.ops35.add += n;
    tab.ops35.mul += n;
  }
}

// The dofs the cuts of kept rows a and b share.
long long common_dofs(const topology::Cut& a, const topology::Cut& b) {
  long long n = 0;
  for (std::size_t x = 0, y = 0; x < a.dofs.size() && y < b.dofs.size();) {
    if (a.dofs[x] < b.dofs[y]) ++x;
    else if (b.dofs[y] < a.dofs[x]) ++y;
    else ++n, ++x, ++y;
  }
  return n;
}

// T^T T's factor pattern by columns (elimination positions); Steps 3.3 and
// 3.4 counted.
void w_pattern(const topology::Tree& t, const std::vector<Row>& rows, const SchurPattern& sp, Step3Tables& tab) {
  for (int j = 0; j < sp.m; ++j) {
    tab.W_col_start.push_back(static_cast<int>(tab.W_row.size()));
    tab.W_row.push_back(j);
    tab.W_structural.push_back(1);
    auto common = [&](int r) { return common_dofs(t.cuts[rows[sp.order[r]].cut], t.cuts[rows[sp.order[j]].cut]); };
    const long long nd = common(j);
    tab.products += nd;
    tab.ops33.mul += nd;
    tab.ops33.add += nd - 1;
    for (std::size_t e = 0; e < sp.pattern[j].size(); ++e) {
      tab.W_row.push_back(sp.pattern[j][e]);
      tab.W_structural.push_back(sp.structural[j][e] ? 1 : 0);
      if (sp.structural[j][e]) {
        const long long n = common(sp.pattern[j][e]);
        tab.products += n;
        tab.ops33.mul += n;
        tab.ops33.add += n - 1;
      }
    }
    const long long c = static_cast<long long>(sp.pattern[j].size());
    tab.products += c * (c + 1) / 2 + 2 * c;  // outer product, forward and backward solves
    tab.ops34.add += c * (c + 1) / 2 + 2 * c;
    tab.ops34.mul += c * (c + 1) / 2 + 3 * c + 2;
    tab.ops34.div += 1;
  }
  tab.W_col_start.push_back(static_cast<int>(tab.W_row.size()));
}

}  // namespace

Step3Tables step3_tables(const topology::Tree& t, const std::vector<Row>& rows, const SchurPattern& sp) {
  Step3Tables tab;
  const std::vector<int> ancestors_on_list = cut_lists(t, tab);
  row_lists(t, rows, ancestors_on_list, tab);
  w_pattern(t, rows, sp, tab);
  return tab;
}

namespace {

// The tables of jr::ConstraintSolveModel.
std::string solve_model_tables(const topology::Tree& t, const SchurPattern& sp, const Step3Tables& tab) {
  std::string s;
  s += fmt::format(
      "\n\n// ---- Step 3 tables (jr::ConstraintSolveModel): Lemma 3 dof lists per cut, ----\n"
      "// kept rows, and T^T T's factor pattern in the elimination order ({}; {} entries).\n",
      sp.minimum_degree ? "minimum degree on the graph of cuts" : "natural cut-row order", tab.W_row.size());
  auto table = [&](const char* type, const char* name, const std::vector<int>& values) {
    s += fmt::format("constexpr {} {}[{}] = {{ {} }};\n", type, name, std::max<std::size_t>(values.size(), 1),
                     values.empty() ? "0" : join_ints(values));
  };
  table("std::int32_t", "kCutDofStart", tab.cut_dof_start);
  table("std::int32_t", "kCutDofs", tab.cut_dofs);
  table("std::int32_t", "kCutParentIndex", tab.cut_parent_index);
  table("std::int32_t", "kCutNumDistinct", tab.cut_num_distinct);
  table("std::int32_t", "kRowCut", tab.row_cut);
  table("std::int32_t", "kRowTStart", tab.row_t_start);
  table("std::int32_t", "kOrder", sp.order);
  table("std::int32_t", "kWColStart", tab.W_col_start);
  table("std::int32_t", "kWRow", tab.W_row);
  table("std::uint8_t", "kWStructural", tab.W_structural);
  s += fmt::format(
      "constexpr jr::ConstraintSolveModel kConstraintSolve = {{{}, {}, kCutDofStart, kCutDofs, kCutParentIndex,\n"
      "    kCutNumDistinct, kRowCut, kRowTStart, kOrder, kWColStart, kWRow, kWStructural}};",
      t.cuts.size(), sp.m);
  return s;
}

// The functions of Steps 3.1-3.5, each a call of the runtime's loop.
std::string step_functions(const SchurPattern& sp, const Step3Tables& tab, bool ldlt, const OpCount& o31,
                           const OpCount& o32, const OpCount& o34) {
  const char* flag = ldlt ? "true" : "false";
  const char* U = ldlt ? "U" : "T";
  const char* Dinv = ldlt ? "nullptr" : "Dinv";
  const std::string step31 = call_function(
      fmt::format("---- Step 3.1: solve L {} = Phiq^T in place (T holds the packed Phiq on entry). ----\n"
                  "Lemma 3: only the dofs on the paths of each cut's bodies.  {}",
                  U, ops_text(o31)),
      fmt::format("void step31_solve_T(const double* L, {}double* T)", ldlt ? "" : "const double* Dinv, "),
      {fmt::format("jr::constraint_solve_T(kModel, kConstraintSolve, L, {}, {}, T);", Dinv, flag)});
  const std::string step32 = call_function(
      fmt::format("---- Step 3.2: z_m = {} ----\n{}",
                  ldlt ? "U^T D^-1 y - gamma, with V = D^-1 U kept for Step 3.3." : "T^T z_n - gamma.", ops_text(o32)),
      fmt::format("void step32_rhs(const double* T, {}const double* z, const double* gamma, {}double* zm)",
                  ldlt ? "const double* Dinv, " : "", ldlt ? "double* V, " : ""),
      {fmt::format("jr::constraint_rhs(kConstraintSolve, T, {}, z, gamma, {}, {}, zm);", ldlt ? "Dinv" : "nullptr",
                   flag, ldlt ? "V" : "nullptr")});
  const std::string step33 = call_function(
      fmt::format("---- Step 3.3: W = {} (m = {}), packed by columns in the elimination order; ----\n"
                  "only entries whose rows' cuts share a dof; fill of Step 3.4 set to 0.\n{}",
                  ldlt ? "U^T D^-1 U = V^T U" : "T^T T", sp.m, ops_text(tab.ops33)),
      fmt::format("void step33_TtT(const double* T, {}double* W)", ldlt ? "const double* V, " : ""),
      {fmt::format("jr::constraint_schur(kConstraintSolve, {}, T, W);", ldlt ? "V" : "T")});
  const std::string step34 =
      call_function(fmt::format("---- Step 3.4: factor W = {} in place (fill included) and solve W lambda = z_m. ----\n"
                                "Ops (factor and solve):{}",
                                ldlt ? "L_W D_W L_W^T" : "L_W L_W^T", ops_text(o34, true).substr(4)),
                    "int step34_factor(double* W, double* Winv)",
                    {"double pivot = 0.0;",
                     fmt::format("const std::int32_t row = jr::constraint_factor(kConstraintSolve, W, Winv, {}, "
                                 "kPivotTolerance, &pivot);",
                                 flag),
                     "return row < 0 ? 0 : constraints_singular(row, pivot);"}) +
      "\n\n" +
      call_function("", "void step34_solve(const double* W, const double* Winv, double* zm)",
                    {fmt::format("jr::constraint_solve_lambda(kConstraintSolve, W, Winv, {}, zm);", flag)});
  const std::string step35 =
      call_function(fmt::format("---- Step 3.5: y_n = {} lambda, subtracted from z_n in place. ----\n{}", U,
                                ops_text(tab.ops35)),
                    "void step35_update(const double* T, const double* zm, double* z)",
                    {"jr::constraint_update(kConstraintSolve, T, zm, z);"});
  return row_failure_functions() +
         fmt::format("// Step 3 is table-driven: unrolled, it would hold {} products (more than {}),\n"
                     "// too large to compile quickly; the runtime's loops do the same arithmetic.\n\n",
                     tab.products, step3_unroll_limit()) +
         step31 + "\n\n" + step32 + "\n\n" + step33 + "\n\n" + step34 + "\n\n" +
         check_digits_W(true, ldlt ? 1 : 2, "kOrder") + "\n\n" + step35;
}

}  // namespace

// Steps 3.1-3.5 as calls of the runtime's loops (jrgen/constraint_solve.hpp)
// over tables, for models whose straight-line Step 3 would be too large.
void table_driven_step3(const topology::Tree& t, const SchurPattern& sp, const Step3Tables& tab, bool ldlt,
                        const std::string& name_space, LoopCode& out) {
  OpCount o31 = tab.ops31, o32 = tab.ops32, o34 = tab.ops34;
  if (!ldlt) {
    o31.mul += static_cast<long long>(tab.cut_dofs.size());  // lower bound: one Dinv per entry
    o34.sqrt += sp.m;
  } else {
    o32.mul += o32.mul;  // V = D^-1 U
  }
  // The runtime header is included at file scope: leave the solver's
  // namespaces for it (the template includes jrgen/runtime.hpp only).
  out.tables = include_at_file_scope(name_space, "#include <jrgen/constraint_solve.hpp>  // table-driven Step 3") +
               out.tables + solve_model_tables(t, sp, tab);
  out.step3 = step_functions(sp, tab, ldlt, o31, o32, o34);
  out.call_args["step31_args"] = ldlt ? "g_L, g_T" : "g_L, g_Dinv, g_T";
  out.call_args["step32_args"] = ldlt ? "g_T, g_Dinv, g_z, g_gamma, g_V, g_zm" : "g_T, g_z, g_gamma, g_zm";
  out.call_args["step33_args"] = ldlt ? "g_T, g_V, g_W" : "g_T, g_W";
  out.call_args["step35_args"] = "g_T, g_zm, g_z";
  out.ops = {{"3.1", o31}, {"3.2", o32}, {"3.3", tab.ops33}, {"3.4", o34}, {"3.5", tab.ops35}};
}

}  // namespace jrgen::emit
