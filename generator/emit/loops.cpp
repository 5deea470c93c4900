#include "emit/loops.hpp"

#include <algorithm>
#include <cstdlib>
#include <map>
#include <stdexcept>

#include "analysis/runtime_model.hpp"
#include "emit/format.hpp"
#include "emit/kernel.hpp"

namespace jrgen::emit {

namespace {

// One kept constraint row: its cut, its row of the cut type, and where its
// packed Jacobian (and T) entries start.
struct Row {
  int cut = 0;
  int type_row = 0;   ///< row of the cut type (runtime.hpp order)
  int t_start = 0;    ///< first packed entry of this row
};

const char* cut_kind(ir::CutType type) {
  switch (type) {
    case ir::CutType::Spherical: return "jr::CutKind::kSpherical";
    case ir::CutType::Revolute: return "jr::CutKind::kRevolute";
    case ir::CutType::Prismatic: return "jr::CutKind::kPrismatic";
    case ir::CutType::Cylindrical: return "jr::CutKind::kCylindrical";
    case ir::CutType::Universal: return "jr::CutKind::kUniversal";
    case ir::CutType::Fixed: return "jr::CutKind::kFixed";
    case ir::CutType::Distance: return "jr::CutKind::kDistance";
  }
  return "?";
}

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

// Index of dof in a cut's sorted dof list.
int dof_index(const topology::Cut& cut, int dof) {
  return static_cast<int>(std::lower_bound(cut.dofs.begin(), cut.dofs.end(), dof) - cut.dofs.begin());
}

// The chains of a cut: dofs on the path from k (and from l) to the base.
std::vector<int> chain(const topology::Tree& t, int body) {
  std::vector<int> out;
  for (int d = body >= 0 ? t.bodies[body].v_lem : -1; d >= 0; d = t.dof_parent[d]) out.push_back(d);
  return out;
}

// For each dof of the cut (same order as cut.dofs), the dofs of the cut that
// are its descendants: L[i, v] T[v] can be non-zero only for these (Lemma 3).
std::vector<std::vector<int>> cut_descendants(const topology::Tree& t, const topology::Cut& cut) {
  std::vector<std::vector<int>> out(cut.dofs.size());
  for (const std::vector<int>& ch : {chain(t, cut.body_k), chain(t, cut.body_l)})
    for (std::size_t a = 0; a < ch.size(); ++a)
      for (std::size_t b = 0; b < a; ++b) {
        std::vector<int>& list = out[dof_index(cut, ch[a])];
        if (std::find(list.begin(), list.end(), ch[b]) == list.end()) list.push_back(ch[b]);
      }
  for (std::vector<int>& list : out) std::sort(list.begin(), list.end());
  return out;
}

// T = L^-1 Phiq^T by its rows (the straight-line Step 3): for each dof, the
// kept rows whose cut reaches it, in elimination order, and where they start.
struct TByDofs {
  std::vector<std::vector<int>> rows;  ///< per dof: kept rows (user order), by elimination position
  std::vector<int> start;              ///< per dof: first entry (nv + 1)
  std::vector<int> position;           ///< kept row -> elimination position
  int at(int dof, int row) const {
    const std::vector<int>& r = rows[dof];
    const auto it = std::lower_bound(r.begin(), r.end(), row,
                                     [&](int a, int b) { return position[a] < position[b]; });
    return start[dof] + static_cast<int>(it - r.begin());
  }
};

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

// After Step 3.4 (a): T^T T singular to working precision although every
// pivot passed its own test (kSpreadLimit, jr::pivot_spread).  Winv holds
// the reciprocal pivots (inverse) or the pivots, of L_W D_W L_W^T (power 1)
// or L_W L_W^T (power 2); `order` maps elimination positions to kept rows.
std::string check_digits_W(bool inverse, int power, const char* order) {
  return fmt::format(
      "// After Step 3.4 (a): T^T T singular to working precision although every pivot\n"
      "// passed its own test (kSpreadLimit); names the loop joint and row of the\n"
      "// smallest pivot and gives d_min / d_max.\n"
      "int check_digits_W(const double* Winv) {{\n"
      "  double ratio = 0.0;\n"
      "  const std::int32_t j = jr::pivot_spread(Winv, nc, {}, {}, kSpreadLimit, &ratio);\n"
      "  if (j < 0) return kSuccess;\n"
      "  return fail_row(kConstraintsSingular,\n"
      "                  \"constraint rows singular to working precision (smallest pivot of T^T T below 1e-13 \"\n"
      "                  \"of the largest)\",\n"
      "                  {}[j], ratio);\n"
      "}}",
      inverse ? "true" : "false", power, order);
}

std::string row_label(const topology::Tree& t, const Row& row) {
  const topology::Cut& cut = t.cuts[row.cut];
  return fmt::format("loop joint '{}' row {}", comment_text(cut.name), row.type_row + 1);
}

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

// The tables of the table-driven Step 3 (jr::ConstraintSolveModel), and the
// number of products the straight-line Step 3 would hold.
struct Step3Tables {
  std::vector<int> cut_dof_start, cut_dofs, cut_parent_index, cut_num_distinct, row_cut, row_t_start;
  std::vector<int> W_col_start, W_row;
  std::vector<int> W_structural;
  long long products = 0;
  OpCount ops31, ops32, ops33, ops34, ops35;  ///< of the loops (as the straight-line code counts)
};

Step3Tables step3_tables(const topology::Tree& t, const std::vector<Row>& rows, const SchurPattern& sp) {
  Step3Tables tab;
  std::vector<int> ancestors_on_list;  // per cut_dofs entry
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
  for (int j = 0; j < sp.m; ++j) {
    tab.W_col_start.push_back(static_cast<int>(tab.W_row.size()));
    tab.W_row.push_back(j);
    tab.W_structural.push_back(1);
    auto common = [&](int r) {
      const topology::Cut& a = t.cuts[rows[sp.order[r]].cut];
      const topology::Cut& b = t.cuts[rows[sp.order[j]].cut];
      long long n = 0;
      for (std::size_t x = 0, y = 0; x < a.dofs.size() && y < b.dofs.size();) {
        if (a.dofs[x] < b.dofs[y]) ++x;
        else if (b.dofs[y] < a.dofs[x]) ++y;
        else ++n, ++x, ++y;
      }
      return n;
    };
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
  return tab;
}

// Steps 3.1-3.5 as calls of the runtime's loops (jrgen/constraint_solve.hpp)
// over tables, for models whose straight-line Step 3 would be too large.
void table_driven_step3(const topology::Tree& t, const SchurPattern& sp, const Step3Tables& tab, bool ldlt,
                        const std::string& name_space, LoopCode& out) {
  const int m = sp.m;
  OpCount o31 = tab.ops31, o32 = tab.ops32, o34 = tab.ops34;
  if (!ldlt) {
    o31.mul += static_cast<long long>(tab.cut_dofs.size());  // lower bound: one Dinv per entry
    o34.sqrt += m;
  } else {
    o32.mul += o32.mul;  // V = D^-1 U
  }
  // The runtime header is included at file scope: leave the solver's
  // namespaces for it (the template includes jrgen/runtime.hpp only).
  std::string s = fmt::format(
      "}}  // namespace\n}}  // namespace {0}\n"
      "#include <jrgen/constraint_solve.hpp>  // table-driven Step 3\n"
      "namespace {0} {{\nnamespace {{\n\n",
      name_space);
  s += out.tables;
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
      t.cuts.size(), m);
  out.tables = s;

  const char* flag = ldlt ? "true" : "false";
  std::string f;
  f += row_failure_functions();
  f += fmt::format(
      "// Step 3 is table-driven: unrolled, it would hold {} products (more than {}),\n"
      "// too large to compile quickly; the runtime's loops do the same arithmetic.\n\n",
      tab.products, step3_unroll_limit());
  const std::string U = ldlt ? "U" : "T";
  f += fmt::format(
      "// ---- Step 3.1: solve L {0} = Phiq^T in place (T holds the packed Phiq on entry). ----\n"
      "// Lemma 3: only the dofs on the paths of each cut's bodies.  Ops: {1} add, {2} mul, {3} div.\n"
      "void step31_solve_T(const double* L, {4}double* T) {{\n"
      "  jr::constraint_solve_T(kModel, kConstraintSolve, L, {5}, {6}, T);\n}}\n\n",
      U, o31.add, o31.mul, o31.div, ldlt ? "" : "const double* Dinv, ", ldlt ? "nullptr" : "Dinv", flag);
  f += fmt::format(
      "// ---- Step 3.2: z_m = {0} ----\n// Ops: {1} add, {2} mul, {3} div.\n"
      "void step32_rhs(const double* T, {4}const double* z, const double* gamma, {5}double* zm) {{\n"
      "  jr::constraint_rhs(kConstraintSolve, T, {6}, z, gamma, {7}, {8}, zm);\n}}\n\n",
      ldlt ? "U^T D^-1 y - gamma, with V = D^-1 U kept for Step 3.3." : "T^T z_n - gamma.", o32.add, o32.mul,
      o32.div, ldlt ? "const double* Dinv, " : "", ldlt ? "double* V, " : "", ldlt ? "Dinv" : "nullptr", flag,
      ldlt ? "V" : "nullptr");
  f += fmt::format(
      "// ---- Step 3.3: W = {0} (m = {1}), packed by columns in the elimination order; ----\n"
      "// only entries whose rows' cuts share a dof; fill of Step 3.4 set to 0.\n"
      "// Ops: {2} add, {3} mul, {4} div.\n"
      "void step33_TtT(const double* T, {5}double* W) {{\n"
      "  jr::constraint_schur(kConstraintSolve, {6}, T, W);\n}}\n\n",
      ldlt ? "U^T D^-1 U = V^T U" : "T^T T", m, tab.ops33.add, tab.ops33.mul, tab.ops33.div,
      ldlt ? "const double* V, " : "", ldlt ? "V" : "T");
  f += fmt::format(
      "// ---- Step 3.4: factor W = {0} in place (fill included) and solve W lambda = z_m. ----\n"
      "// Ops (factor and solve): {1} add, {2} mul, {3} div, {4} sqrt.\n"
      "int step34_factor(double* W, double* Winv) {{\n"
      "  double pivot = 0.0;\n"
      "  const std::int32_t row = jr::constraint_factor(kConstraintSolve, W, Winv, {5}, kPivotTolerance, &pivot);\n"
      "  return row < 0 ? 0 : constraints_singular(row, pivot);\n}}\n\n"
      "void step34_solve(const double* W, const double* Winv, double* zm) {{\n"
      "  jr::constraint_solve_lambda(kConstraintSolve, W, Winv, {5}, zm);\n}}\n\n",
      ldlt ? "L_W D_W L_W^T" : "L_W L_W^T", o34.add, o34.mul, o34.div, o34.sqrt, flag);
  f += check_digits_W(true, ldlt ? 1 : 2, "kOrder") + "\n\n";
  f += fmt::format(
      "// ---- Step 3.5: y_n = {0} lambda, subtracted from z_n in place. ----\n"
      "// Ops: {1} add, {2} mul, {3} div.\n"
      "void step35_update(const double* T, const double* zm, double* z) {{\n"
      "  jr::constraint_update(kConstraintSolve, T, zm, z);\n}}",
      U, tab.ops35.add, tab.ops35.mul, tab.ops35.div);
  out.step3 = f;
  out.call_args["step31_args"] = ldlt ? "g_L, g_T" : "g_L, g_Dinv, g_T";
  out.call_args["step32_args"] = ldlt ? "g_T, g_Dinv, g_z, g_gamma, g_V, g_zm" : "g_T, g_z, g_gamma, g_zm";
  out.call_args["step33_args"] = ldlt ? "g_T, g_V, g_W" : "g_T, g_W";
  out.call_args["step35_args"] = "g_T, g_zm, g_z";
  out.ops = {{"3.1", o31}, {"3.2", o32}, {"3.3", tab.ops33}, {"3.4", o34}, {"3.5", tab.ops35}};
}

}  // namespace

int SchurPattern::position(int row, int col) const {
  if (row == col) return col_start[col];
  const std::vector<int>& p = pattern[col];
  return col_start[col] + 1 + static_cast<int>(std::lower_bound(p.begin(), p.end(), row) - p.begin());
}

SchurPattern schur_pattern(const topology::Tree& t) {
  SchurPattern sp;
  std::vector<int> rows_per_cut;
  for (const topology::Cut& cut : t.cuts) rows_per_cut.push_back(static_cast<int>(cut.kept_rows.size()));
  const topology::RowOrder order = topology::constraint_row_order(t, rows_per_cut);
  sp.order = order.order;
  sp.minimum_degree = order.minimum_degree;
  sp.m = static_cast<int>(sp.order.size());
  // Structural entries below the diagonal (rows whose cuts share a dof), in
  // elimination positions, then the fill of the symbolic factorization.
  const std::vector<std::vector<int>> lower = topology::constraint_row_pattern(t, rows_per_cut, sp.order);
  sp.pattern = topology::symbolic_cholesky(lower, -1, nullptr);
  sp.row_list.assign(sp.m, {});
  sp.structural.assign(sp.m, {});
  sp.col_start.assign(sp.m + 1, 0);
  for (int j = 0; j < sp.m; ++j) {
    sp.col_start[j + 1] = sp.col_start[j] + 1 + static_cast<int>(sp.pattern[j].size());
    for (int r : sp.pattern[j]) {
      sp.row_list[r].push_back(j);
      sp.structural[j].push_back(std::binary_search(lower[j].begin(), lower[j].end(), r));
    }
  }
  return sp;
}

LoopCode emit_loops(const topology::Tree& t, Method method, bool divide, bool unrolled_gathers,
                    const std::string& name_space) {
  LoopCode out;
  const bool ldlt = method == Method::kLDLT;
  const std::vector<Row> rows = kept_rows(t);
  const int m = static_cast<int>(rows.size());
  const int nb = static_cast<int>(t.bodies.size());
  const std::vector<jr::CutModel> models = analysis::cut_models(t);
  const int phiq_nnz = rows.empty() ? 0 : rows.back().t_start + static_cast<int>(t.cuts[rows.back().cut].dofs.size());
  const SchurPattern sp = schur_pattern(t);
  const Step3Tables tab = step3_tables(t, rows, sp);
  // Straight-line Step 3 while it stays small enough to compile quickly;
  // beyond that, the runtime's loops over the same tables (same arithmetic).
  const bool unrolled = tab.products <= step3_unroll_limit();
  unrolled_gathers = unrolled_gathers && unrolled;

  // ---- tables ----
  {
    std::string s = "// ---- Cut joints (closed loops) -----------------------------------------------\n";
    s += "// Per cut: name, kind, body k, body l, frame on k (R row-major, p), frame on l,\n"
         "// axis, child axis, distance, kept-row mask, first row, packed Phiq start, dofs per row.\n";
    s += fmt::format("constexpr jr::CutModel kCuts[{}] = {{\n", t.cuts.size());
    for (std::size_t c = 0; c < t.cuts.size(); ++c) {
      const topology::Cut& cut = t.cuts[c];
      const jr::CutModel& cm = models[c];
      auto mat = [](const double* R) {
        return fmt::format("{{{}, {}, {}, {}, {}, {}, {}, {}, {}}}", num(R[0]), num(R[1]), num(R[2]), num(R[3]),
                           num(R[4]), num(R[5]), num(R[6]), num(R[7]), num(R[8]));
      };
      auto v3 = [](const double* p) { return fmt::format("{{{}, {}, {}}}", num(p[0]), num(p[1]), num(p[2])); };
      std::string kept;
      for (int r : cut.kept_rows) kept += fmt::format("{}{}", kept.empty() ? "" : ", ", r + 1);
      s += fmt::format("// {}: loop joint '{}' ({}), bodies {} and {}, rows kept: {}\n", c, comment_text(cut.name),
                       ir::cut_type_name(cut.type), cut.body_k, cut.body_l, kept.empty() ? "none" : kept);
      s += fmt::format("{{{}, {}, {}, {},\n {}, {},\n {}, {},\n {}, {}, {}, {}, {}, {}, {}}},\n", c_string(cut.name),
                       cut_kind(cut.type), cm.body_k, cm.body_l, mat(cm.R_k), v3(cm.p_k), mat(cm.R_l), v3(cm.p_l),
                       v3(cm.axis), v3(cm.child_axis), num(cm.distance), cm.row_mask, cm.first_row, cm.phiq_start,
                       cm.num_dofs);
    }
    s += "};\n";
    s += fmt::format("constexpr jr::ConstraintModel kConstraints = {{{}, {}, {}, kCuts}};\n", t.cuts.size(), m,
                     phiq_nnz);
    std::vector<long long> from_dense, packed;
    for (int g = 0; g < m; ++g) {
      const topology::Cut& cut = t.cuts[rows[g].cut];
      for (int idx = 0; idx < cut.num_distinct; ++idx) {
        packed.push_back(rows[g].t_start + idx);
        from_dense.push_back(g + static_cast<long long>(m) * t.dof_user[cut.dofs[idx]]);
      }
    }
    out.gather = gather_function(
        "// Phiq (dense, user order) -> packed: the structurally non-zero entries only\n"
        "// (the dofs of Lemma 3 less the common ancestors, where Phiq is zero).\n",
        "gather_Phiq", "Phiq", "T", packed, from_dense, unrolled_gathers);
    s += "// Kept constraint row -> the loop joint and row of its type (for diagnostics).\n";
    s += fmt::format("const char* const kRowLabel[{}] = {{\n", m);
    for (int g = 0; g < m; ++g) {
      const topology::Cut& cut = t.cuts[rows[g].cut];
      s += c_string(fmt::format("loop joint '{}' row {} of {} ({})", cut.name, rows[g].type_row + 1, cut.rows,
                                ir::cut_type_name(cut.type))) +
           ",\n";
    }
    s += "};";
    out.tables = s;
  }

  // ---- workspace ----
  // w_declaration: the line of g_W, which depends on the layout of W.
  auto set_workspace = [&](const std::string& w_declaration) {
    out.workspace = fmt::format(
        "thread_local jr::BodyMotion g_motion[{}];\n"
        "{}"
        "thread_local double g_gamma[{}];\n"
        "{}"
        "thread_local double g_Winv[{}];  // inverse pivots of T^T T\n"
        "thread_local double g_zm[{}];    // z_m (Step 3.2), then lambda (Step 3.4)",
        nb,
        (unrolled ? fmt::format("thread_local double g_T[{0}];     // packed Phiq, cut row by cut row\n"
                                "thread_local double g_Tr[{0}];    // T = L^-1 Phiq^T by dofs (Step 3.1)\n",
                                phiq_nnz)
                  : fmt::format("thread_local double g_T[{}];     // packed Phiq, overwritten by T (Step 3.1)\n",
                                phiq_nnz)) +
            (ldlt ? fmt::format("thread_local double g_V[{}];     // D^-1 U (Step 3.2)\n", phiq_nnz) : ""),
        m, w_declaration, m, m);
  };
  const std::string packed_W = fmt::format(
      "thread_local double g_W[{}];     // T^T T packed (fill included), factored in place\n", sp.nnz());

  if (!unrolled) {
    set_workspace(packed_W);
    table_driven_step3(t, sp, tab, ldlt, name_space, out);
    out.W_diag.assign(tab.W_col_start.begin(), tab.W_col_start.end() - 1);
    out.table_driven = true;
    out.reciprocal_steps = "3.1-3.5 (the runtime's table-driven loops)";
    return out;
  }

  // ---- T by dofs (rows of T = L^-1 Phiq^T, nv x m) ----
  // The straight-line Steps 3.1-3.5 keep T by its rows: for dof i, the entries
  // of the constraint rows R_i whose cut reaches i (Lemma 3), ordered by their
  // elimination position (Step 3.4); a descendant's R_v is a subset of R_i
  // (its cut's path to the base passes through i).  The dofs that every row
  // reaches then hold one contiguous k x m block in the order of W, which the
  // dense kernels below read as it is.  The packed Phiq stays as the runtime
  // writes it (P, cut row by cut row); Step 3.1 reads it and writes T.
  const TByDofs td = t_by_dofs(t, rows, sp);
  auto Tr = [&](int dof, int g) { return fmt::format("T[{}]", td.at(dof, g)); };
  // LDLT: V = D^-1 U (Step 3.2), laid out as T; the left factor of Step 3.3.
  auto Vr = [&](int dof, int g) { return fmt::format("V[{}]", td.at(dof, g)); };

  // ---- Dense part of T^T T ----
  // Dofs that every kept row reaches (a floating base under all the loops)
  // make every pair of rows share a dof: T^T T and its factor are dense.  If
  // those dofs are consecutive, their rows of T form one k x m row-major
  // block, and Steps 3.3 and 3.4 call the runtime's compact dense loops for
  // it (jrgen/constraint_solve.hpp) instead of unrolling the dense part.
  int dense_first = -1, dense_dofs = 0;
  if (m >= kMinDenseSchurRows) {
    std::vector<int> full;
    for (int i = 0; i < t.nv; ++i)
      if (static_cast<int>(td.rows[i].size()) == m) full.push_back(i);
    if (!full.empty() && full.back() - full.front() + 1 == static_cast<int>(full.size())) {
      dense_first = full.front();
      dense_dofs = static_cast<int>(full.size());
    }
  }
  const bool dense_schur = dense_dofs > 0;
  const int dense_last = dense_first + dense_dofs;  // one past
  if (dense_schur)
    for (int j = 0; j < m; ++j)  // every entry of the lower triangle (the dense kernels' layouts)
      if (sp.col_start[j] != j * m - j * (j - 1) / 2 || static_cast<int>(sp.pattern[j].size()) != m - 1 - j)
        throw std::logic_error("emit_loops: T^T T not dense although every row shares a dof");
  // Up to kMaxFixedDenseSchur rows the dense W is kept square (column j from
  // j * ld, ld = m rounded up to even: the runtime's schur_square_* loops
  // then run over aligned pairs of rows only); otherwise packed by columns.
  const bool square_W = dense_schur && m <= kMaxFixedDenseSchur;
  const int ld = m + (m & 1);
  auto W_at = [&](int row, int col) {
    return fmt::format("W[{}]", square_W ? row + ld * col : sp.position(row, col));
  };
  set_workspace(square_W ? fmt::format("thread_local double g_W[{}];     // T^T T, square ({} x {}, lower triangle), "
                                       "factored in place\n",
                                       ld * ld, ld, ld)
                         : packed_W);

  // ---- Step 3.1: L T = Phiq^T, only the rows of Lemma 3 ----
  Kernel k31;
  k31.fence_every = kFenceProducts;
  {
    std::vector<std::vector<std::vector<int>>> cdesc(t.cuts.size());
    for (std::size_t c = 0; c < t.cuts.size(); ++c) cdesc[c] = cut_descendants(t, t.cuts[c]);
    for (int i = 0; i < t.nv; ++i) {
      if (td.rows[i].empty()) continue;
      Kernel::Unit& u = k31.unit();
      u.lines.push_back(fmt::format("// row {} of T: {} ({} constraint rows)", i, dof_label(t, i), td.rows[i].size()));
      // Entry (i, g): the descendants v of i on the paths of g's cut, and
      // the packed Phiq entry (none at the common ancestors of k and l,
      // where Phiq is exactly zero).
      auto descendants = [&](int g) -> const std::vector<int>& {
        return cdesc[rows[g].cut][dof_index(t.cuts[rows[g].cut], i)];
      };
      auto base_index = [&](int g) {
        const topology::Cut& cut = t.cuts[rows[g].cut];
        const int idx = dof_index(cut, i);
        return idx < cut.num_distinct ? rows[g].t_start + idx : -1;
      };
      // Two neighbouring entries of row i of T whose sums run over the same
      // descendants, each holding both rows next to each other, become one
      // statement on a pair of doubles (Kernel::update_pair).
      auto pairable = [&](int g, int g2) {
        if (td.at(i, g2) != td.at(i, g) + 1 || (base_index(g) < 0) != (base_index(g2) < 0)) return false;
        if (descendants(g) != descendants(g2)) return false;
        for (int v : descendants(g))
          if (td.at(v, g2) != td.at(v, g) + 1) return false;
        return true;
      };
      // LDLT: unit diagonal.  --divide: by the pivot L[i,i] itself.
      const Scale scale = ldlt ? Scale() : divide ? Scale::divided_by(L(t, i, i)) : Scale(fmt::format("Dinv[{}]", i));
      const std::vector<int>& gs = td.rows[i];
      for (std::size_t p = 0; p < gs.size();) {
        const int g = gs[p];
        const int b = base_index(g);
        if (descendants(g).empty() && b < 0) {  // (cannot happen: a common dof has descendants on the paths)
          u.lines.push_back(Tr(i, g) + " = 0.0;");
          ++u.statements;
          p += 1;
        } else if (p + 1 < gs.size() && pairable(g, gs[p + 1])) {
          std::vector<Term> terms;
          for (int v : descendants(g)) terms.push_back({L(t, i, v), fmt::format("jr::load2(T + {})", td.at(v, g))});
          const std::string base = b < 0 ? "" : fmt::format("jr::set2(P[{}], P[{}])", b, base_index(gs[p + 1]));
          k31.update_pair(u, "", fmt::format("T + {}", td.at(i, g)), base, terms, scale);
          p += 2;
        } else {
          std::vector<Term> terms;
          for (int v : descendants(g)) terms.push_back({L(t, i, v), Tr(v, g)});
          k31.update(u, "", Tr(i, g), b < 0 ? "" : fmt::format("P[{}]", b), terms, scale);
          p += 1;
        }
      }
    }
  }

  // ---- Step 3.2: z_m = T^T z_n - gamma (LDLT: V = D^-1 U, z_m = V^T y - gamma) ----
  Kernel k32;
  k32.fence_every = kFenceProducts;
  if (ldlt) {
    for (int i = 0; i < t.nv; ++i) {
      if (td.rows[i].empty()) continue;
      Kernel::Unit& u = k32.unit();
      u.lines.push_back(fmt::format("// V, row {}: {}", i, dof_label(t, i)));
      for (int g : td.rows[i]) {
        u.lines.push_back(divide ? fmt::format("{} = {} / {};", Vr(i, g), Tr(i, g), L(t, i, i))
                                 : fmt::format("{} = {} * Dinv[{}];", Vr(i, g), Tr(i, g), i));
        ++u.statements;
        (divide ? k32.ops.div : k32.ops.mul) += 1;
      }
    }
  }
  for (int p = 0; p < m; ++p) {
    const int g = sp.order[p];
    const Row& row = rows[g];
    const topology::Cut& cut = t.cuts[row.cut];
    Kernel::Unit& u = k32.unit();
    u.lines.push_back(fmt::format("// row {}: {}", g, row_label(t, row)));
    std::vector<Term> terms;
    for (int i : cut.dofs) terms.push_back({ldlt ? Vr(i, g) : Tr(i, g), fmt::format("z[{}]", i)});
    k32.assign_sum(u, "", fmt::format("zm[{}]", g), terms, fmt::format("gamma[{}]", g));
  }

  // ---- Step 3.3: T^T T, only entries whose rows share a dof ----
  Kernel k33;
  k33.fence_every = kFenceProducts;
  // Positions of the elimination order (Step 3.4) -> kept rows (user order).
  auto row_at = [&](int position) -> const Row& { return rows[sp.order[position]]; };
  if (dense_schur) {
    Kernel::Unit& u = k33.unit();
    u.lines.push_back(fmt::format("// dense part: the {} dofs {} to {} reached by every row ({} .. {})", dense_dofs,
                                  dense_first, dense_first + dense_dofs - 1, dof_label(t, dense_first),
                                  dof_label(t, dense_first + dense_dofs - 1)));
    const std::string A = fmt::format("{} + {}", ldlt ? "V" : "T", td.start[dense_first]);
    const std::string B = fmt::format("T + {}", td.start[dense_first]);
    u.lines.push_back(square_W ? fmt::format("jr::schur_square_gram_fixed<{}, {}>({}, {}, W);", dense_dofs, m, A, B)
                               : fmt::format("jr::schur_dense_gram({}, {}, {}, {}, W);", A, B, dense_dofs, m));
    ++u.statements;
    const long long entries = static_cast<long long>(m) * (m + 1) / 2;
    k33.ops.mul += entries * dense_dofs;
    k33.ops.add += entries * (dense_dofs - 1);
  }
  for (int j = 0; j < m; ++j) {
    Kernel::Unit& u = k33.unit();
    u.lines.push_back(fmt::format("// column {}: {}{}", j, row_label(t, row_at(j)),
                                  dense_schur ? " (the other shared dofs)" : ""));
    const topology::Cut& cj = t.cuts[row_at(j).cut];
    auto entry = [&](int r) {
      const topology::Cut& cr = t.cuts[row_at(r).cut];
      std::vector<Term> terms;
      std::vector<int> common;
      std::set_intersection(cj.dofs.begin(), cj.dofs.end(), cr.dofs.begin(), cr.dofs.end(), std::back_inserter(common));
      for (int i : common) {
        if (i >= dense_first && i < dense_last) continue;
        terms.push_back({ldlt ? Vr(i, sp.order[r]) : Tr(i, sp.order[r]), Tr(i, sp.order[j])});
      }
      return terms;
    };
    if (dense_schur) {
      // The products outside the dense part, added to it.
      k33.add_sum(u, "", W_at(j, j), entry(j));
      for (int r : sp.pattern[j]) k33.add_sum(u, "", W_at(r, j), entry(r));
      if (u.statements == 0) k33.units.pop_back();  // nothing outside the dense part
      continue;
    }
    k33.assign_sum(u, "", W_at(j, j), entry(j), "");
    for (std::size_t e = 0; e < sp.pattern[j].size(); ++e) {
      const int r = sp.pattern[j][e];
      const std::string target = W_at(r, j);
      if (sp.structural[j][e]) {
        k33.assign_sum(u, "", target, entry(r), "");
      } else {
        u.lines.push_back(target + " = 0.0;  // fill of Step 3.4");
        ++u.statements;
      }
    }
  }

  // ---- Step 3.4: factor T^T T (packed, fill included) and solve for lambda ----
  Kernel k34f, k34s;
  // Column j's entries are scaled by Winv[j] = 1 / pivot, or with --divide
  // divided by the pivot W[j, j] itself.
  auto pivot_scale = [&](int j) {
    return divide ? Scale::divided_by(W_at(j, j)) : Scale(fmt::format("Winv[{}]", j));
  };
  if (dense_schur) {
    out.reciprocal_steps = "3.4 (the runtime's dense kernels)";
    // The runtime's right-looking loops factor in the order of L D L^T
    // (jrgen/constraint_solve.hpp): m (m^2 - 1) / 6 products and
    // subtractions, one product f = w / d per pair of columns, one division
    // per pivot; L L^T then scales each column by 1 / sqrt(d) = sqrt(d) / d
    // (a square root and a product per pivot, a product per entry).  The
    // forward substitution rides along: g = u / d per pivot with rows below
    // (m - 1), a product and a subtraction per entry, and with L L^T the
    // scaling y = u / sqrt(d) (m).  The backward substitution is that of the
    // unrolled solve: a product and a subtraction per entry, m scalings.
    const long long mm = m, updates = mm * (mm * mm - 1) / 6, below = mm * (mm - 1) / 2;
    k34f.ops.add = updates + below;
    k34f.ops.mul = updates + below + (mm - 1) + below + (ldlt ? 0 : below + 2 * mm);
    k34f.ops.div = mm;
    k34f.ops.sqrt = ldlt ? 0 : mm;
    k34s.ops.add = below;
    k34s.ops.mul = below + mm;
  } else {
    for (int j = 0; j < m; ++j) {
      Kernel::Unit& u = k34f.unit();
      u.lines.push_back(fmt::format("// column {}: {}", j, row_label(t, row_at(j))));
      u.lines.push_back("{");
      const std::string in = "  ";
      const std::string diag = W_at(j, j);
      const std::vector<int>& left = sp.row_list[j];
      auto common_left = [&](int r) {
        std::vector<int> c;
        std::set_intersection(left.begin(), left.end(), sp.row_list[r].begin(), sp.row_list[r].end(), std::back_inserter(c));
        return c;
      };
      if (!ldlt) {
        std::vector<Term> sq;
        for (int i : left) sq.push_back({W_at(j, i), W_at(j, i)});
        k34f.update(u, in, "d", diag, sq, "", "const double ", "sd");
        u.lines.push_back(in + fmt::format("if (!(d > kPivotTolerance * {})) return constraints_singular({}, d);", diag, sp.order[j]));
        u.lines.push_back(in + diag + " = std::sqrt(d);");
        u.statements += 2;
        k34f.ops.sqrt += 1;
        if (!divide) {
          u.lines.push_back(in + fmt::format("Winv[{}] = 1.0 / {};", j, diag));
          k34f.ops.div += 1;
        } else {
          u.lines.push_back(in + fmt::format("Winv[{}] = d;  // the pivot itself, for check_digits_W", j));
        }
        ++u.statements;
        for (int r : sp.pattern[j]) {
          std::vector<Term> terms;
          for (int i : common_left(r)) terms.push_back({W_at(j, i), W_at(r, i)});
          k34f.update(u, in, W_at(r, j), W_at(r, j), terms, pivot_scale(j));
        }
      } else {
        // L D L^T as Step 1's: products w_i = W[j,i] D[i], or with --divide
        // an entry W[r,i] kept unscaled (L_W D_W) until column r, which
        // divides it by its pivot and needs both forms.
        const bool unscaled = divide;
        std::vector<Term> dterms;
        std::map<int, std::string> w;
        for (int i : left) {
          const std::string name = fmt::format("{}{}", unscaled ? "l" : "w", w.size());
          u.lines.push_back(
              in + fmt::format("const double {} = {} {} {};", name, W_at(j, i), unscaled ? "/" : "*", W_at(i, i)));
          ++u.statements;
          (unscaled ? k34f.ops.div : k34f.ops.mul) += 1;
          w[i] = name;
          dterms.push_back(unscaled ? Term{W_at(j, i), name} : Term{name, W_at(j, i)});
        }
        k34f.update(u, in, "d", diag, dterms, "", "const double ", "sd");
        u.lines.push_back(in + fmt::format("if (!(d > kPivotTolerance * {})) return constraints_singular({}, d);", diag, sp.order[j]));
        u.lines.push_back(in + diag + " = d;");
        u.statements += 2;
        if (!divide) {
          u.lines.push_back(in + fmt::format("Winv[{}] = 1.0 / d;", j));
          k34f.ops.div += 1;
        } else {
          u.lines.push_back(in + fmt::format("Winv[{}] = d;  // the pivot itself, for check_digits_W", j));
        }
        ++u.statements;
        if (unscaled)
          for (const auto& [i, name] : w) {
            u.lines.push_back(in + fmt::format("{} = {};", W_at(j, i), name));
            ++u.statements;
          }
        for (int r : sp.pattern[j]) {
          std::vector<Term> terms;
          for (int i : common_left(r)) terms.push_back(unscaled ? Term{W_at(r, i), w[i]} : Term{w[i], W_at(r, i)});
          if (unscaled && terms.empty()) continue;  // stays unscaled until column r
          k34f.update(u, in, W_at(r, j), W_at(r, j), terms, unscaled ? Scale() : pivot_scale(j));
        }
      }
      u.lines.push_back("}");
    }
    for (int j = 0; j < m; ++j) {  // forward
      std::vector<Term> terms;
      for (int i : sp.row_list[j])
        terms.push_back({W_at(j, i), fmt::format("zm[{}]", sp.order[i])});
      if (ldlt && terms.empty()) continue;
      Kernel::Unit& u = k34s.unit();
      u.lines.push_back(fmt::format("// forward, row {}", j));
      const std::string z = fmt::format("zm[{}]", sp.order[j]);
      k34s.update(u, "", z, z, terms, ldlt ? Scale() : pivot_scale(j));
    }
    for (int j = m - 1; j >= 0; --j) {  // backward
      std::vector<Term> terms;
      // Farthest rows first: the position solved just before enters last, so
      // the serial chain of the back substitution is one product per row.
      for (auto r = sp.pattern[j].rbegin(); r != sp.pattern[j].rend(); ++r)
        terms.push_back({W_at(*r, j), fmt::format("zm[{}]", sp.order[*r])});
      Kernel::Unit& u = k34s.unit();
      u.lines.push_back(fmt::format("// backward, row {}", j));
      const std::string z = fmt::format("zm[{}]", sp.order[j]);
      if (ldlt) {
        (divide ? k34s.ops.div : k34s.ops.mul) += 1;
        k34s.update(u, "", z, z + pivot_scale(j).applied(), terms, "");
      } else {
        k34s.update(u, "", z, z, terms, pivot_scale(j));
      }
    }
  }

  // ---- Step 3.5: y_n = T lambda, subtracted from z_n in place ----
  Kernel k35;
  k35.fence_every = kFenceProducts;
  {
    for (int i = 0; i < t.nv; ++i) {
      if (td.rows[i].empty()) continue;
      std::vector<Term> terms;  // in storage order
      for (int g : td.rows[i]) terms.push_back({Tr(i, g), fmt::format("zm[{}]", g)});
      Kernel::Unit& u = k35.unit();
      u.lines.push_back(fmt::format("// row {}: {}", i, dof_label(t, i)));
      const std::string z = fmt::format("z[{}]", i);
      k35.update(u, "", z, z, terms, "");
    }
  }

  // ---- functions ----
  const std::string U = ldlt ? "U" : "T";
  std::string s;
  s += row_failure_functions();
  s += k31.functions(
      "step31_solve_T",
      ldlt ? "const double* L, const double* P, double* T" : "const double* L, const double* Dinv, const double* P, double* T",
      ldlt ? "L, P, T" : "L, Dinv, P, T", false,
      fmt::format("---- Step 3.1: solve L {0} = Phiq^T (P: the packed Phiq, cut row by cut row). ----\n"
                  "Lemma 3: the column of row r of cut j is non-zero only at dofs of\n"
                  "d[k] U d[l]; only those are stored and computed.  {0} is stored by\n"
                  "its rows (dofs, descendants first), each row's constraint rows in\n"
                  "elimination order, so neighbouring statements touch neighbouring entries.{1}\n"
                  "Ops: {2} add, {3} mul, {4} div.",
                  U, ldlt ? " L has a unit diagonal: U = L^-1 Phiq^T." : "", k31.ops.add, k31.ops.mul, k31.ops.div));
  s += "\n\n";
  // L D L^T: V = D^-1 U reads Dinv, or with --divide the pivots on L's diagonal.
  const std::string pivots = divide ? "L" : "Dinv";
  s += k32.functions(
      "step32_rhs",
      ldlt ? "const double* T, const double* " + pivots + ", const double* z, const double* gamma, double* V, double* zm"
           : "const double* T, const double* z, const double* gamma, double* zm",
      ldlt ? "T, " + pivots + ", z, gamma, V, zm" : "T, z, gamma, zm", false,
      fmt::format("---- Step 3.2: z_m = {} ----\nOps: {} add, {} mul, {} div.",
                  ldlt ? "U^T D^-1 y - gamma, with V = D^-1 U kept for Step 3.3." : "T^T z_n - gamma.", k32.ops.add,
                  k32.ops.mul, k32.ops.div));
  s += "\n\n";
  s += k33.functions(
      "step33_TtT", ldlt ? "const double* T, const double* V, double* W" : "const double* T, double* W",
      ldlt ? "T, V, W" : "T, W", false,
      fmt::format("---- Step 3.3: W = {} (m = {}), {}. ----\n"
                  "Entry (r, s) is computed only when the cuts of rows r and s share a dof;\n"
                  "entries that are zero here but filled by Step 3.4 are set to 0.\n"
                  "Ops: {} add, {} mul, {} div.",
                  ldlt ? "U^T D^-1 U = V^T U" : "T^T T", m,
                  square_W ? fmt::format("square: entry (r, s) at W[r + {} s]", ld) : "packed by columns", k33.ops.add,
                  k33.ops.mul, k33.ops.div));
  s += "\n\n";
  OpCount k34 = k34f.ops;
  k34 += k34s.ops;
  if (dense_schur) {
    // Up to kMaxFixedDenseSchur rows the square layout with m a compile-time
    // constant (the schur_square_*_fixed loops: every trip count known),
    // beyond the packed layout and runtime loops.
    auto call = [&](const char* kernel) {
      return square_W ? fmt::format("jr::schur_square_{}_fixed<{}>(W, Winv, ", kernel, m)
                      : fmt::format("jr::schur_dense_{}(W, Winv, {}, ", kernel, m);
    };
    s += fmt::format(
        "// ---- Step 3.4 (a): factor W = {0} in place (dense, m = {1}: the runtime's loops), ----\n"
        "// with the forward substitution of z_m (into g_zw, elimination order) in the same passes.\n"
        "// Ops: {2} add, {3} mul, {4} div, {5} sqrt.\n"
        "int step34_factor(double* __restrict W, double* __restrict Winv) {{\n"
        "  double pivot = 0.0;\n"
        "  const std::int32_t position = {10}kSchurOrder, {6}, kPivotTolerance, &pivot, g_zw, g_zm);\n"
        "  return position < 0 ? 0 : constraints_singular(kSchurOrder[position], pivot);\n"
        "}}\n\n"
        "// ---- Step 3.4 (b): backward substitution, lambda into z_m. ----\n"
        "// Ops: {7} add, {8} mul, {9} div.\n"
        "void step34_solve(const double* __restrict W, const double* __restrict Winv, double* __restrict zm) {{\n"
        "  {11}kSchurOrder, {6}, g_zw, zm);\n"
        "}}",
        ldlt ? "L_W D_W L_W^T" : "L_W L_W^T", m, k34f.ops.add, k34f.ops.mul, k34f.ops.div, k34f.ops.sqrt,
        ldlt ? "true" : "false", k34s.ops.add, k34s.ops.mul, k34s.ops.div, call("factor_forward"),
        call("backward"));
  } else {
    s += k34f.functions(
        "step34_factor", "double* W, double* Winv", "W, Winv", true,
        fmt::format("---- Step 3.4 (a): factor W = {} in place, unrolled, fill included. ----\n"
                    "Ops: {} add, {} mul, {} div, {} sqrt.",
                    ldlt ? "L_W D_W L_W^T" : "L_W L_W^T", k34f.ops.add, k34f.ops.mul, k34f.ops.div, k34f.ops.sqrt));
    s += "\n\n";
    s += k34s.functions("step34_solve", "const double* W, const double* Winv, double* zm", "W, Winv, zm", false,
                        fmt::format("---- Step 3.4 (b): solve W lambda = z_m in place. ----\n"
                                    "Ops: {} add, {} mul, {} div.",
                                    k34s.ops.add, k34s.ops.mul, k34s.ops.div));
  }
  s += "\n\n";
  // The dense kernels leave 1 / d (L D L^T) or 1 / l (L L^T) in Winv, as the
  // straight-line factor does without --divide; with it, the pivots d.
  s += check_digits_W(dense_schur || !divide, dense_schur || !divide ? (ldlt ? 1 : 2) : 1, "kSchurOrder");
  s += "\n\n";
  s += k35.functions("step35_update", "const double* T, const double* zm, double* z", "T, zm, z", false,
                     fmt::format("---- Step 3.5: y_n = {} lambda, subtracted from z_n in place (Step 4 then ----\n"
                                 "solves with z_n - y_n). Only rows of dofs some cut reaches.\n"
                                 "Ops: {} add, {} mul, {} div.",
                                 U, k35.ops.add, k35.ops.mul, k35.ops.div));
  if (dense_schur) {
    // The dense kernels live in the runtime header: included at file scope.
    out.tables = fmt::format(
                     "}}  // namespace\n}}  // namespace {0}\n"
                     "#include <jrgen/constraint_solve.hpp>  // dense Steps 3.3-3.4\n"
                     "namespace {0} {{\nnamespace {{\n\n",
                     name_space) +
                 out.tables;
    out.workspace += fmt::format("\nthread_local double g_zw[{}];    // forward solution, then lambda, elimination order (Step 3.4)", square_W ? ld : m);
  }
  for (int j = 0; j < m; ++j) out.W_diag.push_back(square_W ? j * (ld + 1) : sp.position(j, j));
  out.tables += fmt::format("\n// Elimination position of Step 3.4 -> kept row (user order).\n"
                            "constexpr std::int32_t kSchurOrder[{}] = {{ {} }};",
                            m, join_ints(sp.order));
  out.step3 = s;
  out.call_args["step31_args"] = ldlt ? "g_L, g_T, g_Tr" : "g_L, g_Dinv, g_T, g_Tr";
  out.call_args["step32_args"] = ldlt ? "g_Tr, g_" + pivots + ", g_z, g_gamma, g_V, g_zm" : "g_Tr, g_z, g_gamma, g_zm";
  out.call_args["step33_args"] = ldlt ? "g_Tr, g_V, g_W" : "g_Tr, g_W";
  out.call_args["step35_args"] = "g_Tr, g_zm, g_z";
  out.ops = {{"3.1", k31.ops}, {"3.2", k32.ops}, {"3.3", k33.ops}, {"3.4", k34}, {"3.5", k35.ops}};
  return out;
}

}  // namespace jrgen::emit
