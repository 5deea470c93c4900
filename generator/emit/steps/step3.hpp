// Step 3 of the algorithm of Section 4.3 (closed loops; internal to the emit
// stage).  emit_loops() (emit/loops.hpp, defined in steps/step3.cpp) writes
// Steps 3.1-3.5 as straight-line code, one unit per sub-step
// (steps/step31.cpp .. step35.cpp) over the Step3Layout below, or as calls of
// the runtime's table-driven loops (steps/step3_table.cpp).
#pragma once

#include <fmt/format.h>

#include <string>
#include <vector>

#include "emit/kernel.hpp"
#include "emit/loops.hpp"
#include "emit/template.hpp"
#include "topology/topology.hpp"

namespace jrgen::emit {

// ---- Kept constraint rows ---------------------------------------------------

/// One kept constraint row: its cut, its row of the cut type, and where its
/// packed Jacobian (and T) entries start.
struct Row {
  int cut = 0;
  int type_row = 0;   ///< row of the cut type (runtime.hpp order)
  int t_start = 0;    ///< first packed entry of this row
};

/// The kept rows, cut by cut (user row order).
std::vector<Row> kept_rows(const topology::Tree& t);
/// Index of `dof` in a cut's sorted dof list.
int dof_index(const topology::Cut& cut, int dof);
/// "loop joint 'name' row r", for comments.
std::string row_label(const topology::Tree& t, const Row& row);

// ---- The straight-line layout -----------------------------------------------

/// T = L^-1 Phiq^T by its rows (the straight-line Step 3): for each dof, the
/// kept rows whose cut reaches it, in elimination order, and where they start.
struct TByDofs {
  std::vector<std::vector<int>> rows;  ///< per dof: kept rows (user order), by elimination position
  std::vector<int> start;              ///< per dof: first entry (nv + 1)
  std::vector<int> position;           ///< kept row -> elimination position
  int at(int dof, int row) const;      ///< index of entry (dof, row) in T
};

/// What the straight-line Steps 3.1-3.5 share: the kept rows, the pattern
/// of T^T T and its factor (Step 3.4), T by dofs, and the dense part of T^T T
/// when every row reaches some common dofs (a floating base under all the
/// loops), with the layout of W.
struct Step3Layout {
  Step3Layout(const topology::Tree& tree, const std::vector<Row>& kept, const SchurPattern& pattern)
      : t(tree), rows(kept), sp(pattern) {}
  const topology::Tree& t;
  const std::vector<Row>& rows;
  const SchurPattern& sp;
  bool ldlt = false;    ///< method L D L^T
  bool divide = false;  ///< --divide
  int m = 0;            ///< kept rows
  TByDofs td;
  /// The dofs every row reaches, when consecutive (at least
  /// kMinDenseSchurRows rows): dense_first .. dense_first + dense_dofs - 1.
  int dense_first = -1, dense_dofs = 0;
  /// Dense W kept square (m <= kMaxFixedDenseSchur), leading dimension ld.
  bool square_W = false;
  int ld = 0;

  bool dense_schur() const { return dense_dofs > 0; }
  int dense_last() const { return dense_first + dense_dofs; }  ///< one past
  /// Entry (dof, kept row g) of T, of V = D^-1 U (L D L^T), of W.
  std::string T(int dof, int g) const { return fmt::format("T[{}]", td.at(dof, g)); }
  std::string V(int dof, int g) const { return fmt::format("V[{}]", td.at(dof, g)); }
  std::string W(int row, int col) const;
  /// The kept row at an elimination position of Step 3.4.
  const Row& row_at(int position) const { return rows[sp.order[position]]; }
  /// Column j of W's factor is scaled by Winv[j] = 1 / pivot, or with
  /// --divide divided by the pivot W[j, j] itself.
  Scale pivot_scale(int j) const;
};

Step3Layout step3_layout(const topology::Tree& t, const std::vector<Row>& rows, const SchurPattern& sp, bool ldlt,
                         bool divide);  // steps/step3.cpp

/// One sub-step's functions, their operations, and the arguments of their
/// call in api_loops.cpp.tmpl (empty for Step 3.4, called by its block).
struct StepCode {
  std::string text;
  OpCount ops;
  std::string call_args;
};

StepCode step31(const Step3Layout& lay);  // steps/step31.cpp: L T = Phiq^T
StepCode step32(const Step3Layout& lay);  // steps/step32.cpp: z_m = T^T z_n - gamma
StepCode step33(const Step3Layout& lay);  // steps/step33.cpp: W = T^T T
StepCode step34(const Step3Layout& lay);  // steps/step34.cpp: W = L_W L_W^T, W lambda = z_m
StepCode step35(const Step3Layout& lay);  // steps/step35.cpp: z_n -= T lambda

// ---- Shared by both shapes --------------------------------------------------

/// The failure reports that name a kept row (constraints_singular, fail_row;
/// steps/step3.cpp).
std::string row_failure_functions();
/// check_digits_W(): T^T T singular to working precision although every pivot
/// passed its own test (steps/step34.cpp).  Winv holds the reciprocal pivots
/// (`inverse`) or the pivots, of L_W D_W L_W^T (`power` 1) or L_W L_W^T
/// (`power` 2); `order` maps elimination positions to kept rows.
std::string check_digits_W(bool inverse, int power, const char* order);

// ---- Table-driven shape (steps/step3_table.cpp) -----------------------------

/// The tables of the table-driven Step 3 (jr::ConstraintSolveModel), and the
/// number of products the straight-line Step 3 would hold.
struct Step3Tables {
  std::vector<int> cut_dof_start, cut_dofs, cut_parent_index, cut_num_distinct, row_cut, row_t_start;
  std::vector<int> W_col_start, W_row;
  std::vector<int> W_structural;
  long long products = 0;
  OpCount ops31, ops32, ops33, ops34, ops35;  ///< of the loops (as the straight-line code counts)
};

Step3Tables step3_tables(const topology::Tree& t, const std::vector<Row>& rows, const SchurPattern& sp);

/// Steps 3.1-3.5 as calls of the runtime's loops over `tab`: appends the
/// tables to out.tables, sets out.step3, out.call_args and out.ops.
void table_driven_step3(const topology::Tree& t, const SchurPattern& sp, const Step3Tables& tab, bool ldlt,
                        const std::string& name_space, LoopCode& out);

// ---- Blocks around Step 3 ---------------------------------------------------

/// The cut joints' tables (kCuts, kConstraints) and the row labels
/// (kRowLabel) (emit/model_tables.cpp).
std::string constraint_tables(const topology::Tree& t, const std::vector<Row>& rows);
/// gather_Phiq: the dense Phiq -> packed, non-zero entries only (emit/gathers.cpp).
std::string gather_phiq(const topology::Tree& t, const std::vector<Row>& rows, bool unrolled);

// ---- --singular proximal (steps/proximal.cpp) -------------------------------

/// The declaration of last_solve_regularized() for OUT.hpp ("" without).
std::string singular_api(bool proximal);
/// Template values singular_workspace and singular_definition of OUT.cpp.
void singular_values(bool proximal, TemplateValues& v);
/// Values proximal and step34_block of api_loops.cpp.tmpl: Step 3.4 of the
/// solve, regularized when T^T T fails its tests with `proximal`.
void step34_api(bool proximal, const LoopCode& loops, int m, TemplateValues& api);

}  // namespace jrgen::emit
