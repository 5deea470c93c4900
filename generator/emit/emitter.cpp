#include "emit/emitter.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <string_view>

#include <jrgen/runtime.hpp>

#include "emit/code_writer.hpp"
#include "emit/format.hpp"
#include "emit/kernel.hpp"
#include "emit/loops.hpp"
#include "emit/template.hpp"
#include "topology/topology.hpp"
#include "ir/error.hpp"

namespace jrgen::emit {

namespace {

const char* joint_kind(ir::JointType type) {
  switch (type) {
    case ir::JointType::Revolute:
    case ir::JointType::Continuous: return "jr::JointKind::kRevolute";
    case ir::JointType::Prismatic: return "jr::JointKind::kPrismatic";
    case ir::JointType::Ball: return "jr::JointKind::kBall";
    case ir::JointType::Floating: return "jr::JointKind::kFloating";
    case ir::JointType::Planar: return "jr::JointKind::kPlanar";
    case ir::JointType::Fixed: break;
  }
  return "?";
}

// Step 1: M = L L^T (or L D L^T), column by column, eq. (25) and (26); the
// sums run over the descendants of the column only (Lemma 2: every other
// L[j, i] is zero), and only the rows of ancestors are computed.
//
// `dense` names the source of M's entries: empty, M is already packed in L
// (forward_dynamics); else the user's dense column-major M, read straight
// into the statement that first needs each entry (solve_augmented: no
// separate gather pass).  With `divide` (--divide) each entry is divided by
// its pivot, as eq. (26) is written, and Dinv is written only with
// `write_dinv` (for the runtime's table-driven Step 3, which reads it); otherwise Dinv[j]
// holds the pivot itself, for the digits test (check_digits_M).
Kernel step1(const topology::Tree& t, const std::vector<std::vector<int>>& desc, Method method, bool divide,
             bool write_dinv, const std::string& dense = "") {
  // The original value of packed entry (row, col): row an ancestor of col.
  auto M = [&](int row, int col) {
    if (dense.empty()) return L(t, row, col);
    return fmt::format("{}[{}]", dense, t.dof_user[row] + static_cast<long long>(t.nv) * t.dof_user[col]);
  };
  // Two neighbouring ancestor rows r = anc[p], r' = anc[p + 1] of column j
  // are stored next to each other in column j and in every column i of
  // F(j) (column i holds i's ancestors, nearest first, and those of j are a
  // suffix of them): their two statements of eq. (26) become one on a pair
  // of doubles (Kernel::update_pair, jrgen/simd.hpp).
  auto pairable = [&](int r, int r2, int j, const std::vector<int>& dj) {
    if (t.packed(r2, j) != t.packed(r, j) + 1) return false;
    for (int i : dj)
      if (t.packed(r2, i) != t.packed(r, i) + 1) return false;
    return true;
  };
  auto pair = [&](int row, int col) { return fmt::format("jr::load2(L + {})", t.packed(row, col)); };
  auto M_pair = [&](int r, int r2, int col) {
    if (dense.empty()) return pair(r, col);
    return fmt::format("jr::set2({}, {})", M(r, col), M(r2, col));
  };
  auto target = [&](int row, int col) { return fmt::format("L + {}", t.packed(row, col)); };
  Kernel k;
  for (int j = 0; j < t.nv; ++j) {
    Kernel::Unit& u = k.unit();
    const std::vector<int> anc = t.ancestors(j);
    const std::vector<int>& dj = desc[j];
    // Rows of eq. (26) for anc[p] (and anc[p + 1] when they pair up), with
    // the scalar factor of descendant number n given by `factor(n)`, then
    // `scale`.  An entry with nothing to subtract or scale stays as it is.
    auto rows = [&](const auto& factor, const Scale& scale) {
      for (std::size_t p = 0; p < anc.size();) {
        const int r = anc[p];
        if (dj.empty() && scale.empty() && dense.empty()) {
          p += 1;
        } else if (p + 1 < anc.size() && pairable(r, anc[p + 1], j, dj)) {
          std::vector<Term> terms;
          for (std::size_t n = 0; n < dj.size(); ++n) terms.push_back({factor(n), pair(r, dj[n])});
          k.update_pair(u, "  ", target(r, j), M_pair(r, anc[p + 1], j), terms, scale);
          p += 2;
        } else {
          std::vector<Term> terms;
          for (std::size_t n = 0; n < dj.size(); ++n) terms.push_back({factor(n), L(t, r, dj[n])});
          k.update(u, "  ", L(t, r, j), M(r, j), terms, scale);
          p += 1;
        }
      }
    };
    u.lines.push_back(fmt::format("// column {}: {}; {} descendant(s), {} ancestor row(s)", j,
                                  dof_label(t, j), dj.size(), anc.size()));
    u.lines.push_back("{");
    const std::string in = "  ";
    const std::string diag = L(t, j, j);
    if (method == Method::kLLT) {
      // eq. (25): L[j,j]^2 = M[j,j] - sum_i L[j,i]^2
      std::vector<Term> sq;
      for (int i : dj) sq.push_back({L(t, j, i), L(t, j, i)});
      k.update(u, in, "d", M(j, j), sq, "", "const double ", "sd");
      u.lines.push_back(in + fmt::format("if (!(d > kPivotTolerance * {})) return not_positive_definite({}, d);",
                                         M(j, j), j));
      // 1 / L[j,j] = sqrt(d) * (1 / d): the square root and the division
      // run side by side, not one after the other, on the chain from this
      // pivot to the next column (one more multiplication per column;
      // docs/benchmarks.md, run 8: tree_d4_30 10% faster, talos 4%).
      u.lines.push_back(in + "const double l = std::sqrt(d);");
      u.lines.push_back(in + diag + " = l;");
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
      // eq. (26): L[k,j] = (M[k,j] - sum_i L[j,i] L[k,i]) / L[j,j]
      rows([&](std::size_t n) { return L(t, j, dj[n]); },
           divide ? Scale::divided_by("l") : Scale(fmt::format("Dinv[{}]", j)));
    } else {
      // L D L^T: w_i = L[j,i] D[i]; D[j] = M[j,j] - sum_i w_i L[j,i];
      // L[k,j] = (M[k,j] - sum_i w_i L[k,i]) * Dinv[j].
      //
      // --divide keeps W = L D instead (eq. 26 without the division): an
      // entry of column i stays unscaled, W[k,i], until column k is
      // reached, which needs L[k,i] = W[k,i] / D[i] (D[i] is known by then)
      // as well as W[k,i] itself:
      //   l_i = W[j,i] / D[i];  D[j] = M[j,j] - sum_i W[j,i] l_i;
      //   W[k,j] = M[k,j] - sum_i W[k,i] l_i  (k an ancestor of j).
      // One division per entry of L and no products w_i (165 fewer on the
      // HMMWV), and column j's entries do not wait for its pivot.  Measured
      // (docs/benchmarks.md, run 9): with divisions, legged30 4.5% faster
      // than the products w_i; with reciprocals 10% slower (each entry is
      // stored twice), so the default keeps the products.
      const bool unscaled = divide;
      std::vector<Term> dterms;
      for (std::size_t n = 0; n < dj.size(); ++n) {
        const int i = dj[n];
        const std::string name = fmt::format("{}{}", unscaled ? "l" : "w", n);
        u.lines.push_back(in + fmt::format("const double {} = {} {} {};", name, L(t, j, i), unscaled ? "/" : "*",
                                           L(t, i, i)));
        ++u.statements;
        (unscaled ? k.ops.div : k.ops.mul) += 1;
        dterms.push_back(unscaled ? Term{L(t, j, i), name} : Term{name, L(t, j, i)});
      }
      k.update(u, in, "d", M(j, j), dterms, "", "const double ", "sd");
      u.lines.push_back(in + fmt::format("if (!(d > kPivotTolerance * {})) return not_positive_definite({}, d);",
                                         M(j, j), j));
      u.lines.push_back(in + diag + " = d;");
      u.statements += 2;
      if (write_dinv) {
        u.lines.push_back(in + fmt::format("Dinv[{}] = 1.0 / d;", j));
        k.ops.div += 1;
      } else {
        u.lines.push_back(in + fmt::format("Dinv[{}] = d;  // the pivot itself, for check_digits_M", j));
      }
      ++u.statements;
      if (unscaled)
        for (std::size_t n = 0; n < dj.size(); ++n) {
          u.lines.push_back(in + fmt::format("{} = l{};", L(t, j, dj[n]), n));
          ++u.statements;
        }
      rows([&](std::size_t n) { return fmt::format("{}{}", unscaled ? "l" : "w", n); },
           unscaled ? Scale() : Scale(fmt::format("Dinv[{}]", j)));
    }
    u.lines.push_back("}");
  }
  return k;
}

// Step 2: L z = Q by forward substitution; row j sums over the family F(j)
// only (Remark 2).  For L D L^T the unit-diagonal solve leaves the D scaling
// to Step 4.  With `divide`, L L^T divides by L[j,j] instead of scaling by Dinv[j].
Kernel step2(const topology::Tree& t, const std::vector<std::vector<int>>& desc, Method method, bool divide) {
  Kernel k;
  for (int j = 0; j < t.nv; ++j) {
    std::vector<Term> terms;
    for (int i : desc[j]) terms.push_back({L(t, j, i), fmt::format("z[{}]", i)});
    if (method == Method::kLDLT && terms.empty()) continue;
    Kernel::Unit& u = k.unit();
    u.lines.push_back(fmt::format("// row {}: {}", j, dof_label(t, j)));
    const std::string zj = fmt::format("z[{}]", j);
    const Scale scale = method == Method::kLDLT ? Scale()
                        : divide                ? Scale::divided_by(L(t, j, j))
                                                : Scale(fmt::format("Dinv[{}]", j));
    k.update(u, "", zj, zj, terms, scale);
  }
  return k;
}

// Step 4: L^T qdd = z - y by back substitution, ancestors first; row j sums
// over the ancestors of j only (Remark 2).  For L D L^T the D^-1 of the
// forward solve is applied here.  With `divide`, the pivot L[j,j] divides
// instead of Dinv[j] multiplying.
Kernel step4(const topology::Tree& t, Method method, bool divide) {
  Kernel k;
  for (int j = t.nv - 1; j >= 0; --j) {
    Kernel::Unit& u = k.unit();
    u.lines.push_back(fmt::format("// row {}: {}", j, dof_label(t, j)));
    // The root-most ancestors first: the parent, solved just before, enters
    // the sum last, so the serial chain from root to leaf is one product per
    // row rather than one whole sum.
    const std::vector<int> anc = t.ancestors(j);
    std::vector<Term> terms;
    for (auto r = anc.rbegin(); r != anc.rend(); ++r) terms.push_back({L(t, *r, j), fmt::format("z[{}]", *r)});
    const std::string zj = fmt::format("z[{}]", j);
    const Scale scale = divide ? Scale::divided_by(L(t, j, j)) : Scale(fmt::format("Dinv[{}]", j));
    if (method == Method::kLLT) {
      k.update(u, "", zj, zj, terms, scale);
    } else {
      (divide ? k.ops.div : k.ops.mul) += 1;
      k.update(u, "", zj, zj + scale.applied(), terms, "");
    }
  }
  return k;
}

// ASCII picture of the block pattern of L (rows: Lemma 2 order), for models
// small enough to read it.
std::string pattern_comment(const topology::Tree& t) {
  constexpr int kMaxPictured = 64;
  if (t.nv > kMaxPictured) return fmt::format("//\n// Pattern of L not drawn (nv = {} > {}).", t.nv, kMaxPictured);
  std::vector<std::string> rows(t.nv, std::string(t.nv, ' '));
  for (int c = 0; c < t.nv; ++c) {
    for (int r = c + 1; r < t.nv; ++r) rows[r][c] = '.';
    rows[c][c] = 'x';
    for (int r : t.ancestors(c)) rows[r][c] = 'x';
  }
  std::string out = "//\n// Pattern of L (x: computed, .: structurally zero, never touched):\n";
  for (int r = 0; r < t.nv; ++r) {
    std::string row = rows[r];
    row.erase(row.find_last_not_of(' ') + 1);
    out += fmt::format("//   {:>4} {}  {}\n", r, row, comment_text(t.bodies[t.dof_body[r]].joint_name));
  }
  out.pop_back();
  return out;
}

enum class Shape { kUnrolled, kTable, kSupernodal, kParallel };

std::string as_comment(const std::string& text) {
  std::string out;
  for (const std::string& line : split_lines(text)) out += (out.empty() ? "// " : "\n// ") + line;
  return out;
}

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

std::string ops_line(const OpCount& o) {
  return fmt::format("// Ops: {} add, {} mul, {} div, {} sqrt.", o.add, o.mul, o.div, o.sqrt);
}

// Supernodal Steps 1, 2, 4 (method llt, trees): the dense supernodes as a
// table, the runtime's blocked kernels on them, its scalar loops elsewhere.
void supernodal_steps(const topology::Tree& t, const std::vector<topology::Supernode>& nodes, const OpCount& o1,
                      const OpCount& o2, const OpCount& o4, TemplateValues& v) {
  long long dense = 0;
  std::string table;
  for (const topology::Supernode& sn : nodes) {
    const int last = sn.first + sn.size - 1;
    table += fmt::format("  // dofs {}..{}: {} .. {}; {} x {} block + {} ancestor row(s)\n", sn.first, last,
                         dof_label(t, sn.first), dof_label(t, last), sn.size, sn.size, sn.rows - sn.size);
    table += fmt::format("  {{{}, {}, {}, {}}},\n", sn.first, sn.size, sn.rows, sn.offset);
    dense = sn.offset + static_cast<long long>(sn.rows) * sn.size;
  }
  table.pop_back();
  const int n = static_cast<int>(nodes.size());
  v["step1"] = fmt::format(
      "// ---- Step 1: factor M = L L^T, eq. (25)-(26), supernodal. ----\n"
      "{}\n{}\n"
      "constexpr jr::Supernode kSupernodes[{}] = {{\n{}\n}};\n"
      "thread_local double g_S[{}];  // the supernodes' columns of L, dense\n"
      "int step1_factor(double* L, double* Dinv) {{\n"
      "  double pivot = 0.0;\n"
      "  const std::int32_t j =\n"
      "      jr::factor_supernodal(kModel, kSupernodes, {}, L, g_S, Dinv, kPivotTolerance, &pivot);\n"
      "  return j < 0 ? 0 : not_positive_definite(j, pivot);\n"
      "}}",
      as_comment(fmt::format(
          "Dense supernodes (runs of >= {} dofs of the dof tree each with a single child,\n"
          "so their columns of L share one dense structure): Eigen's blocked Cholesky on\n"
          "the diagonal block, a triangular solve for the panel of ancestor rows, and its\n"
          "rank-s update subtracted from the ancestors' packed columns.  Every other\n"
          "column: the runtime's scalar loops over the packed layout (Lemma 2).",
          kMinDenseSupernode)),
      ops_line(o1), n, table, dense, n);
  v["step2"] = fmt::format(
      "// ---- Step 2: solve L z = Q (forward substitution), Remark 2, supernodal. ----\n{}\n"
      "void step2_forward(const double* L, const double* Dinv, double* z) {{\n"
      "  jr::forward_supernodal(kModel, kSupernodes, {}, L, g_S, Dinv, z);\n"
      "}}",
      ops_line(o2), n);
  v["step4"] = fmt::format(
      "// ---- Step 4: solve L^T qdd = z (back substitution), Remark 2, supernodal. ----\n{}\n"
      "void step4_backward(const double* L, const double* Dinv, double* z) {{\n"
      "  jr::backward_supernodal(kModel, kSupernodes, {}, L, g_S, Dinv, z);\n"
      "}}",
      ops_line(o4), n);
}

// Parallel Steps 1, 2, 4 (Corollary 3, trees): subtrees below a separator as
// OpenMP work items (groups of consecutive subtrees of about equal work).
void parallel_steps(const topology::Tree& t, const Options& options, const OpCount& o1, const OpCount& o2,
                    const OpCount& o4, TemplateValues& v) {
  constexpr int kParts = 32;  // work items, a few per thread on small machines
  const std::vector<topology::Subtree> trees =
      topology::partition_subtrees(t, kParts, std::max(16, t.nv / 20));
  long long total = 0, buffer = 1, inside = 0;
  for (const topology::Subtree& s : trees) {
    total += s.work;
    buffer = std::max(buffer, s.buffer + static_cast<long long>(s.path) * s.path);
    inside += s.root - s.first + 1;
  }
  std::vector<long long> task_start{0};
  long long acc = 0;
  for (std::size_t i = 0; i < trees.size(); ++i) {
    acc += trees[i].work;
    if (acc * kParts >= total || i + 1 == trees.size()) {
      task_start.push_back(static_cast<long long>(i) + 1);
      acc = 0;
    }
  }
  std::string table;
  for (const topology::Subtree& s : trees)
    table += fmt::format("  {{{}, {}, {}, {}}},  // {}\n", s.first, s.root, s.path, s.buffer, dof_label(t, s.root));
  table.pop_back();
  const int n = static_cast<int>(trees.size());
  const int tasks = static_cast<int>(task_start.size()) - 1;
  const bool ldlt = options.method == Method::kLDLT;
  const char* flag = ldlt ? "true" : "false";
  const std::string omp = options.threads >= 2
                              ? fmt::format("#pragma omp parallel for schedule(dynamic, 1) num_threads({})", options.threads)
                              : std::string("#pragma omp parallel for schedule(dynamic, 1)");
  const std::string pragma = "#if defined(_OPENMP)\n" + omp + "\n#endif\n";
  v["step1"] = fmt::format(
      "// ---- Step 1: factor {} in place (packed), eq. (25)-(26), parallel. ----\n"
      "{}\n{}\n"
      "constexpr jr::Subtree kSubtrees[{}] = {{\n{}\n}};\n"
      "// Work item w runs subtrees kTaskStart[w] .. kTaskStart[w + 1] - 1.\n"
      "constexpr std::int32_t kTaskStart[{}] = {{ {} }};\n"
      "constexpr std::int32_t kNumTasks = {};\n"
      "thread_local double g_U[{}];  // per-subtree updates of its path rows\n"
      "int step1_factor(double* L, double* Dinv) {{\n"
      "  jr::save_diagonal(kModel, L, Dinv);\n"
      "  double* const U = g_U;  // this thread's buffer, shared with the workers\n"
      "  std::int32_t failed[kNumTasks];\n"
      "  double pivots[kNumTasks];\n"
      "{}"
      "  for (std::int32_t w = 0; w < kNumTasks; ++w) {{\n"
      "    failed[w] = -1;\n"
      "    for (std::int32_t i = kTaskStart[w]; i < kTaskStart[w + 1] && failed[w] < 0; ++i)\n"
      "      failed[w] = jr::factor_subtree(kModel, kSubtrees[i], L, Dinv, {}, kPivotTolerance, &pivots[w],\n"
      "                                     U + kSubtrees[i].buffer);\n"
      "  }}\n"
      "  for (std::int32_t w = 0; w < kNumTasks; ++w)\n"
      "    if (failed[w] >= 0) return not_positive_definite(failed[w], pivots[w]);\n"
      "  for (std::int32_t i = 0; i < {}; ++i) jr::apply_subtree_update(kModel, kSubtrees[i], U + kSubtrees[i].buffer, L);\n"
      "  double pivot = 0.0;\n"
      "  const std::int32_t j = jr::factor_separator(kModel, kSubtrees, {}, L, Dinv, {}, kPivotTolerance, &pivot);\n"
      "  return j < 0 ? 0 : not_positive_definite(j, pivot);\n"
      "}}",
      ldlt ? "M = L D L^T" : "M = L L^T",
      as_comment(fmt::format(
          "Corollary 3 (Section 5): columns of L in disjoint subtrees are independent.\n"
          "{} subtrees ({} dofs) below a separator of {} dofs, in {} work items run\n"
          "in parallel (OpenMP, when compiled with it); each subtree's updates of the\n"
          "separator rows go to its own buffer, added in serially before the separator\n"
          "columns are factored.  Step 2 likewise; Step 4 in reverse.",
          n, inside, t.nv - inside, tasks)),
      ops_line(o1), n, table, tasks + 1, join_ints(task_start), tasks, buffer, pragma, flag, n, n, flag);
  v["step2"] = fmt::format(
      "// ---- Step 2: solve L z = Q (forward substitution), Remark 2, parallel. ----\n{}\n"
      "void step2_forward(const double* L, {}double* z) {{\n"
      "  double* const U = g_U;\n"
      "{}"
      "  for (std::int32_t w = 0; w < kNumTasks; ++w)\n"
      "    for (std::int32_t i = kTaskStart[w]; i < kTaskStart[w + 1]; ++i)\n"
      "      jr::forward_subtree(kModel, kSubtrees[i], L, {}, {}, z, U + kSubtrees[i].buffer);\n"
      "  for (std::int32_t i = 0; i < {}; ++i) jr::apply_subtree_forward(kModel, kSubtrees[i], U + kSubtrees[i].buffer, z);\n"
      "  jr::forward_separator(kModel, kSubtrees, {}, L, {}, {}, z);\n"
      "}}",
      ops_line(o2), ldlt ? "" : "const double* Dinv, ", pragma, ldlt ? "nullptr" : "Dinv", flag, n, n,
      ldlt ? "nullptr" : "Dinv", flag);
  v["step4"] = fmt::format(
      "// ---- Step 4: solve L^T qdd = z (back substitution), Remark 2, parallel. ----\n{}\n"
      "void step4_backward(const double* L, const double* Dinv, double* z) {{\n"
      "  jr::backward_separator(kModel, kSubtrees, {}, L, Dinv, {}, z);\n"
      "{}"
      "  for (std::int32_t w = 0; w < kNumTasks; ++w)\n"
      "    for (std::int32_t i = kTaskStart[w]; i < kTaskStart[w + 1]; ++i)\n"
      "      jr::backward_subtree(kModel, kSubtrees[i], L, Dinv, {}, z);\n"
      "}}",
      ops_line(o4), n, flag, pragma, flag);
}

std::string body_tables(const topology::Tree& t) {
  std::string out;
  for (std::size_t b = 0; b < t.bodies.size(); ++b) {
    const topology::Body& body = t.bodies[b];
    const Eigen::Matrix3d& R = body.X_PJ.R;
    const Eigen::Matrix3d& I = body.inertial.I_com;
    out += fmt::format("// {}: joint '{}' ({}), parent {}\n", b, comment_text(body.joint_name),
                       ir::joint_type_name(body.type),
                       body.parent_lem >= 0 ? std::to_string(body.parent_lem) : "base");
    out += fmt::format(
        "{{{}, {}, {}, {}, {}, {}, {},\n"
        " {{{}, {}, {}, {}, {}, {}, {}, {}, {}}},\n"
        " {}, {}, {}, {},\n"
        " {}, {}, {{{}, {}, {}, {}, {}, {}}}, {}}},\n",
        c_string(body.joint_name), joint_kind(body.type), body.parent_lem, body.q_user, body.v_user, body.v_lem,
        body.nv, num(R(0, 0)), num(R(0, 1)), num(R(0, 2)), num(R(1, 0)), num(R(1, 1)), num(R(1, 2)),
        num(R(2, 0)), num(R(2, 1)), num(R(2, 2)), vec(body.X_PJ.p), vec(body.axis), vec(body.e1),
        vec(body.e2), num(body.inertial.mass), vec(body.inertial.com), num(I(0, 0)), num(I(1, 1)),
        num(I(2, 2)), num(I(0, 1)), num(I(0, 2)), num(I(1, 2)), num(body.damping));
  }
  out.pop_back();
  return out;
}

// --singular proximal: Step 3.4 for a singular or nearly singular T^T T,
// by the proximal-point iteration (iterated Tikhonov).  Runs only after the
// regular factor failed its tests; the regular path is unchanged.
std::string proximal_step34(const LoopCode& loops, int m) {
  return fmt::format(R"(
// ---- Step 3.4, regularized (--singular proximal; docs/singular.md) ----------
// Runs when T^T T is singular or nearly so (a pivot of its factor, or the
// pivots' spread, failed its test): lambda by the proximal-point iteration
// (iterated Tikhonov regularization) on W = T^T T,
//     (W + mu I) lambda_(k+1) = z_m + mu lambda_k,   lambda_0 = 0,
// mu = sqrt(eps) max_j W_jj, kProximalIterations steps.  Every iterate stays
// in range(W) (z_m = T^T z_n - gamma is there when the system is consistent,
// as at an assembled state with Phiq v = 0 along the singular rows), and an
// eigencomponent of W with eigenvalue s converges to its share of the
// minimum-norm lambda = W^+ z_m by the factor mu / (s + mu) per step: below
// 1.5e-4 for s >= 1e-4 max W_jj, so 5 steps leave (1.5e-4)^5 ~ 1e-19 of it.
// The null space of W is that of T and of Phiq^T: it adds nothing to
// Phiq^T lambda, so qdd (Steps 3.5, 4) is the unique solution of eq. (17).
// Rounding puts ~eps |z_m| into the null space each step, which leaves
// ~5 sqrt(eps) |z_m| / max W_jj (~1e-7 relative) of it in lambda and nothing
// measurable in Phiq^T lambda.  Components with 0 < s < mu (a state within
// ~1e-8 of the singular one, relative) are damped: their constraint
// direction is relaxed.  Cost: kProximalIterations times Steps 3.3 and 3.4
// (W is formed and factored afresh each step), on singular states only.
constexpr int kProximalIterations = 5;
constexpr double kProximalShift = 1.4901161193847656e-08;  // sqrt(eps)
// Position of each diagonal entry of W in g_W (elimination order).
constexpr std::int32_t kWDiag[{0}] = {{ {1} }};
thread_local double g_zm0[{0}];     // z_m of Step 3.2, kept for the iteration
thread_local double g_lambda[{0}];  // lambda_k

// lambda into g_zm (user row order); status 2 only if W + mu I fails too.
int proximal_lambda() {{
  for (std::int32_t r = 0; r < nc; ++r) {{
    g_zm0[r] = g_zm[r];
    g_lambda[r] = 0.0;
  }}
  double mu = 0.0;
  for (int k = 0; k < kProximalIterations; ++k) {{
    step33_TtT({2});  // W afresh: Step 3.4 factored it in place
    if (k == 0) {{
      for (std::int32_t j = 0; j < nc; ++j) mu = std::fmax(mu, g_W[kWDiag[j]]);
      mu *= kProximalShift;
    }}
    for (std::int32_t j = 0; j < nc; ++j) g_W[kWDiag[j]] += mu;
    for (std::int32_t r = 0; r < nc; ++r) g_zm[r] = g_zm0[r] + mu * g_lambda[r];
    if (const int status = step34_factor(g_W, g_Winv)) return status;
    step34_solve(g_W, g_Winv, g_zm);
    for (std::int32_t r = 0; r < nc; ++r) g_lambda[r] = g_zm[r];
  }}
  return kSuccess;
}}
)",
                     m, join_ints(loops.W_diag), loops.call_args.at("step33_args"));
}

}  // namespace

namespace {

// "JRGEN_STEP " before each definition of a step function: the lines of
// `code` that start (column 0) with "int step" or "void step".
std::string mark_step_definitions(const std::string& code) {
  std::string out;
  std::size_t pos = 0;
  while (pos < code.size()) {
    std::size_t end = code.find('\n', pos);
    if (end == std::string::npos) end = code.size();
    const std::string_view line(code.data() + pos, end - pos);
    if (line.rfind("int step", 0) == 0 || line.rfind("void step", 0) == 0) out += "JRGEN_STEP ";
    out.append(line);
    if (end < code.size()) out += '\n';
    pos = end + 1;
  }
  return out;
}

}  // namespace

Solver emit_solver(const ir::Robot& robot, const topology::Tree& t, const Options& options) {
  if (t.nv == 0)
    throw Error(ir::SourceLocation{robot.source_file, 0}, "robot", robot.name,
                "has no moving joints: there are no equations of motion to solve");
  const int nb = static_cast<int>(t.bodies.size());

  // Shape of Steps 1, 2 and 4: straight-line code while it stays small
  // enough to compile quickly; beyond that, the runtime's loops over the same
  // packed layout (the same factor, no fill-in either way).  Trees (no Step 3
  // reading the packed L) may instead get the supernodal shape, when a long
  // run of single-child dofs makes a dense block, or the parallel one
  // (Corollary 3), for large trees.
  long long products = 0, chain = 0;
  for (int j = 0; j < t.nv; ++j) {
    const long long k = t.dof_depth[j];
    products += k * (k + 1) / 2;
    chain += k;
  }
  const bool tree_only = t.cuts.empty();
  std::vector<topology::Supernode> supernodes;
  if (tree_only && options.method == Method::kLLT) supernodes = topology::dense_supernodes(t, kMinDenseSupernode);
  const bool parallel =
      tree_only && (options.threads >= 2 || (options.threads == 0 && t.nv >= kMinParallelDofs));
  const Shape shape = parallel                ? Shape::kParallel
                      : !supernodes.empty()   ? Shape::kSupernodal
                      : products <= unroll_limit() ? Shape::kUnrolled
                                                          : Shape::kTable;
  const bool unrolled = shape == Shape::kUnrolled;
  // Small models also get Step 1 reading the user's dense M directly
  // (solve_augmented), which saves the separate pass copying M into L.
  const bool fused = unrolled && products <= kMaxFusedGatherProducts;
  Kernel k1, k1_dense, k2, k4;
  // Step 3 first: whether it is table-driven decides what Step 1 writes.
  LoopCode loops;
  if (t.nc() > 0) loops = emit_loops(t, options.method, options.divide, unrolled, options.name_space);
  // --divide: Dinv only for a table-driven Step 3, whose loops read it.
  const bool write_dinv = !options.divide || (unrolled && loops.table_driven);
  if (unrolled) {
    const std::vector<std::vector<int>> desc = t.descendants();
    k1 = step1(t, desc, options.method, options.divide, write_dinv);
    if (fused) k1_dense = step1(t, desc, options.method, options.divide, write_dinv, "M");
    k2 = step2(t, desc, options.method, options.divide);
    k4 = step4(t, options.method, options.divide);
    // Fences in Step 1 only: Steps 2 and 4 are short chains of dependent
    // rows, slower with each value read back (docs/benchmarks.md, run 8).
    k1.fence_every = k1_dense.fence_every = kFenceProducts;
  } else {
    // The runtime's column loop (factor_packed, and the columns of the
    // parallel shape), the same for both methods: one reciprocal pivot, a
    // product w_a / d per ancestor row, the update products, and the scaling
    // of the rows; L L^T adds l = sqrt(d) and its scale l / d
    // (jr::detail::row_scale).  The supernodal shape's dense blocks run
    // Eigen's kernels instead and are counted as if they ran this loop.
    const bool l = options.method == Method::kLDLT;
    k1.ops = {products, products + 2 * chain + (l ? 0 : t.nv), t.nv, l ? 0 : t.nv};
    k2.ops = {chain, chain + (l ? 0 : t.nv), 0, 0};
    k4.ops = {chain, chain + t.nv, 0, 0};
    if (shape == Shape::kTable) {
      // forward_packed and backward_packed keep two partial sums per row:
      // one more addition each (the other shapes' loops keep one).
      k2.ops.add += t.nv;
      k4.ops.add += t.nv;
    }
  }

  const bool gravity = !options.gravity.isZero(0.0);
  bool damping = false;
  for (const topology::Body& b : t.bodies) damping = damping || b.damping != 0.0;

  TemplateValues v;
  v["version"] = JRGEN_VERSION;
  // Names from the user's files appear in // comments only, made safe there.
  v["source"] = comment_text(options.source_name + (options.cuts_name.empty() ? "" : " + " + options.cuts_name));
  v["robot"] = comment_text(robot.name);
  v["ns"] = options.name_space;
  v["nq"] = std::to_string(t.nq);
  v["nv"] = std::to_string(t.nv);
  const int nc = t.nc();
  v["nc"] = std::to_string(nc);
  v["njoints"] = std::to_string(nb);

  Solver solver;
  solver.divide = options.divide;
  if (options.divide && !unrolled)
    solver.notes.push_back("--divide: Steps 1, 2 and 4 run the runtime's loops (a model this large) and multiply by "
                           "reciprocal pivots");
  const bool proximal = options.singular_proximal;
  v["singular_api"] =
      proximal ? "// Generated with --singular proximal (docs/singular.md): after a solve that\n"
                 "// returned kSuccess in this thread, true when T^T T was singular or nearly so\n"
                 "// and lambda came from the regularized Step 3.4 (the minimum-norm lambda of a\n"
                 "// consistent system; qdd and Phiq^T lambda are then still unique), false when\n"
                 "// the regular solve ran.  Always false for a tree (no constraints).\n"
                 "bool last_solve_regularized();\n\n"
               : "";
  solver.header = render_template("solver.hpp.tmpl", template_text("solver.hpp.tmpl"), v);
  v.erase("singular_api");
  v["singular_workspace"] =
      proximal ? "\nthread_local bool g_regularized = false;  // --singular proximal: last_solve_regularized()" : "";
  v["singular_definition"] = proximal ? "\nbool last_solve_regularized() { return g_regularized; }\n" : "";

  v.erase("nq");
  v.erase("nc");
  v.erase("njoints");
  v["nb"] = std::to_string(nb);
  v["nnz"] = std::to_string(t.nnz());
  v["nv_plus_1"] = std::to_string(t.nv + 1);
  v["header"] = options.header_name;
  v["method"] = options.method == Method::kLLT ? "L L^T (Cholesky)" : "L D L^T (no square roots)";
  if (nc == 0) {
    v["summary"] = fmt::format("tree, nq = {}, nv = {}, no constraints.", t.nq, t.nv);
  } else {
    int dropped = 0;
    for (const topology::Cut& c : t.cuts) dropped += c.rows - static_cast<int>(c.kept_rows.size());
    v["summary"] = fmt::format("closed loops, nq = {}, nv = {}, {} cut joint(s), nc = {} rows kept{}.", t.nq, t.nv,
                               t.cuts.size(), nc, dropped ? fmt::format(" ({} redundant dropped)", dropped) : "");
  }
  v["pattern"] = pattern_comment(t);
  v["runtime_header"] = shape == Shape::kSupernodal || shape == Shape::kParallel ? "jrgen/factor.hpp" : "jrgen/runtime.hpp";

  std::string names, q_index, v_index;
  std::vector<int> dof_joint(t.nv, 0);
  for (int ju = 0; ju < nb; ++ju) {
    const topology::Body& b = t.bodies[t.body_of_user_joint[ju]];
    names += c_string(b.joint_name) + ",\n";
    q_index += (ju ? ", " : "") + std::to_string(b.q_user);
    v_index += (ju ? ", " : "") + std::to_string(b.v_user);
    for (int k = 0; k < b.nv; ++k) dof_joint[b.v_user + k] = ju;
  }
  names.pop_back();
  v["joint_names"] = names;
  v["joint_q_index"] = q_index;
  v["joint_v_index"] = v_index;
  v["bodies"] = body_tables(t);
  v["dof_parent"] = join_ints(t.dof_parent);
  v["dof_user"] = join_ints(t.dof_user);
  v["col_start"] = join_ints(t.M_col_start);
  v["dof_joint"] = join_ints(dof_joint);
  std::vector<long long> pack_to, pack_from;
  for (int c = 0; c < t.nv && (unrolled || t.nnz() <= kMaxGatherTable); ++c) {
    pack_to.push_back(static_cast<long long>(pack_to.size()));
    pack_from.push_back(static_cast<long long>(t.dof_user[c]) * (t.nv + 1));
    for (int r : t.ancestors(c)) {
      pack_to.push_back(static_cast<long long>(pack_to.size()));
      pack_from.push_back(t.dof_user[r] + static_cast<long long>(t.nv) * t.dof_user[c]);
    }
  }
  v["model_init"] = fmt::format("{}, {}, {}, kBodies, kDofParent, kDofUser, kMColStart, {{{}, {}, {}}}", nb,
                                t.nq, t.nv, num(options.gravity[0]), num(options.gravity[1]),
                                num(options.gravity[2]));
  v["gravity_flag"] = gravity ? "true" : "false";
  v["damping_flag"] = damping ? "true" : "false";
  std::string bias = "Coriolis and centrifugal terms";
  if (gravity) bias += ", gravity";
  if (damping) bias += ", joint damping";
  v["bias_terms"] = bias;

  const std::string method_note =
      options.method == Method::kLLT ? "M = L L^T" : "M = L D L^T, D on the diagonal of L";
  // With L D L^T the forward solve has a unit diagonal and needs no Dinv.
  const bool ldlt = options.method == Method::kLDLT;
  v["step2_args"] = ldlt ? "g_L, g_z" : "g_L, g_Dinv, g_z";
  // What Step 1 leaves in Dinv for check_digits_M (jr::pivot_spread): the
  // reciprocal pivots 1 / d (L D L^T) or 1 / l (L L^T), or with --divide in
  // straight-line code, where nothing else reads Dinv, the pivots d.
  v["m_pivots"] = unrolled && !write_dinv ? "false, 1" : ldlt ? "true, 1" : "true, 2";
  if (shape == Shape::kSupernodal) {
    supernodal_steps(t, supernodes, k1.ops, k2.ops, k4.ops, v);
  } else if (shape == Shape::kParallel) {
    parallel_steps(t, options, k1.ops, k2.ops, k4.ops, v);
  } else if (!unrolled) {
    const std::string why = fmt::format(
        "Unrolled, Step 1 alone would hold {} products (more than {}): code that\n"
        "large outgrows the instruction caches and runs slower than the runtime's\n"
        "loops over the same packed layout, which compute the same factor (Lemma 2:\n"
        "no fill-in; only ancestor rows are touched).",
        products, unroll_limit());
    const char* flag = ldlt ? "true" : "false";
    v["step1"] = fmt::format(
        "// ---- Step 1: factor {} in place (packed), eq. (25)-(26), table-driven. ----\n{}\n"
        "// Ops: {} add, {} mul, {} div, {} sqrt.\n"
        "int step1_factor(double* L, double* Dinv) {{\n"
        "  double pivot = 0.0;\n"
        "  const std::int32_t j = jr::factor_packed(kModel, L, Dinv, {}, kPivotTolerance, &pivot);\n"
        "  return j < 0 ? 0 : not_positive_definite(j, pivot);\n"
        "}}",
        method_note, as_comment(why),
        k1.ops.add, k1.ops.mul, k1.ops.div, k1.ops.sqrt, flag);
    v["step2"] = packed_rows_tables(t) + fmt::format(
        "\n\n// ---- Step 2: solve L z = Q (forward substitution), Remark 2, table-driven. ----\n"
        "// Row j sums over its descendants (kRowEntry).\n"
        "// Ops: {} add, {} mul, {} div.\n"
        "void step2_forward(const double* L, {}double* z) {{\n"
        "  jr::forward_packed(kModel, kRows, L, {}, {}, z);\n"
        "}}",
        k2.ops.add, k2.ops.mul, k2.ops.div, ldlt ? "" : "const double* Dinv, ", ldlt ? "nullptr" : "Dinv", flag);
    v["step4"] = fmt::format(
        "// ---- Step 4: solve L^T qdd = z (back substitution), Remark 2, table-driven. ----\n"
        "// Column j sums over its ancestors (kEntryRow).\n"
        "// Ops: {} add, {} mul, {} div.\n"
        "void step4_backward(const double* L, const double* Dinv, double* z) {{\n"
        "  jr::backward_packed(kModel, kRows, L, Dinv, {}, z);\n"
        "}}",
        k4.ops.add, k4.ops.mul, k4.ops.div, flag);
  } else {
    v["step1"] = k1.functions(
        "step1_factor", "double* L, double* Dinv", "L, Dinv", true,
        fmt::format("---- Step 1: factor {} in place (packed), eq. (25)-(26). ----\n"
                    "Lemma 2: no fill-in; column j reads only rows of its descendants\n"
                    "and writes only rows of its ancestors. {}\n"
                    "Ops: {} add, {} mul, {} div, {} sqrt.",
                    method_note,
                    !options.divide ? "Dinv[j] = 1 / pivot j."
                    : write_dinv    ? "Entries are divided by their pivot L[j,j] (--divide);\n"
                                      "Dinv[j] = 1 / pivot j is kept for Step 3's loops."
                                    : "Entries are divided by their pivot L[j,j] (--divide).",
                    k1.ops.add, k1.ops.mul, k1.ops.div, k1.ops.sqrt));
    if (fused)
      v["step1"] += "\n\n" + k1_dense.functions(
          "step1_factor_dense", "const double* M, double* L, double* Dinv", "M, L, Dinv", true,
          "---- Step 1 for solve_augmented: the same statements, each reading its entry of\n"
          "the user's dense M (column-major, user order) where the packed variant reads\n"
          "L: only the structurally non-zero entries of eq. (18) are read, and no\n"
          "separate copy of M into L is made.");
    v["step2"] = k2.functions(
        "step2_forward", ldlt ? "const double* L, double* z" : "const double* L, const double* Dinv, double* z",
        ldlt ? "L, z" : "L, Dinv, z", false,
        fmt::format("---- Step 2: solve L z = Q (forward substitution), Remark 2: ----\n"
                    "row j sums over the family F(j) only.{}\n"
                    "Ops: {} add, {} mul, {} div.",
                    options.method == Method::kLDLT ? " Unit diagonal; D^-1 is applied in Step 4." : "",
                    k2.ops.add, k2.ops.mul, k2.ops.div));
    v["step4"] = k4.functions(
        "step4_backward", "const double* L, const double* Dinv, double* z", "L, Dinv, z", false,
        fmt::format("---- Step 4: solve L^T qdd = z (back substitution), Remark 2: ----\n"
                    "row j sums over the ancestors of j only.\n"
                    "Ops: {} add, {} mul, {} div.",
                    k4.ops.add, k4.ops.mul, k4.ops.div));
  }

  // The API: a tree gets no constraint code at all.
  TemplateValues api;
  for (const char* key : {"step2_args", "bias_terms", "gravity_flag", "damping_flag"}) api[key] = v[key];
  v.erase("step2_args");
  v.erase("bias_terms");
  solver.ops = {{"1", k1.ops}, {"2", k2.ops}};
  // solve_augmented reads the structurally non-zero entries of the dense
  // inputs only (straight-line copies unless the model is large).
  // Q in, qdd out: user order <-> Lemma 2 order.
  std::vector<long long> lem, user;
  for (int j = 0; j < t.nv; ++j) {
    lem.push_back(j);
    user.push_back(t.dof_user[j]);
  }
  v["gather"] = gather_function("// Q (user order) -> z (Lemma 2 order).\n", "gather_Q", "Q", "z", lem, user, unrolled) +
                "\n\n" +
                gather_function("// z (Lemma 2 order) -> qdd (user order).\n", "scatter_qdd", "z", "qdd", user, lem,
                                unrolled);
  if (!fused) {
    v["gather"] += "\n\n";
    if (unrolled || t.nnz() <= kMaxGatherTable) {
      v["gather"] += gather_function(
          "// M (dense, user order) -> packed L: the structurally non-zero entries, eq. (18).\n", "gather_M", "M",
          "L", pack_to, pack_from, unrolled);
    } else {
      v["gather"] +=
          "// M (dense, user order) -> packed L: the structurally non-zero entries, eq. (18);\n"
          "// column c holds rows c, parent(c), ... (walked through the dof tree: no table).\n"
          "void gather_M(const double* __restrict M, double* __restrict L) {\n"
          "  std::int64_t k = 0;\n"
          "  for (std::int32_t c = 0; c < nv; ++c) {\n"
          "    const double* col = M + static_cast<std::int64_t>(kDofUser[c]) * nv;\n"
          "    for (std::int32_t r = c; r >= 0; r = kDofParent[r]) L[k++] = col[kDofUser[r]];\n"
          "  }\n"
          "}";
    }
    v["step1"] +=
        "\n\n// Step 1 for solve_augmented: gather M's structurally non-zero entries, then factor.\n"
        "int step1_factor_dense(const double* M, double* L, double* Dinv) {\n"
        "  gather_M(M, L);\n"
        "  return step1_factor(L, Dinv);\n"
        "}";
  }
  if (nc == 0) {
    v["constraint_tables"] = "";
    v["constraint_workspace"] = "";
    v["step3"] = "";
    v["api"] = render_template("api_tree.cpp.tmpl", template_text("api_tree.cpp.tmpl"), api);
  } else {
    if (options.divide && !loops.reciprocal_steps.empty())
      solver.notes.push_back("--divide: Step " + loops.reciprocal_steps + " multiplies by reciprocal pivots");
    v["constraint_tables"] = loops.tables;
    v["constraint_workspace"] = loops.workspace;
    v["step3"] = loops.step3;
    v["gather"] += "\n\n" + loops.gather;
    for (const auto& [key, value] : loops.call_args) api[key] = value;
    api["proximal"] = proximal ? proximal_step34(loops, nc) : "";
    api["step34_block"] =
        proximal ? "  // Step 3.4: factor, or (T^T T singular or nearly so) the regularized solve.\n"
                   "  g_regularized = step34_factor(g_W, g_Winv) != kSuccess || check_digits_W(g_Winv) != kSuccess;\n"
                   "  if (!g_regularized) {\n"
                   "    step34_solve(g_W, g_Winv, g_zm);\n"
                   "  } else if (const int status = proximal_lambda()) {\n"
                   "    return status;\n"
                   "  }"
                 : "  if (const int status = step34_factor(g_W, g_Winv)) return status;\n"
                   "  if (const int status = check_digits_W(g_Winv)) return status;\n"
                   "  step34_solve(g_W, g_Winv, g_zm);";
    v["api"] = render_template("api_loops.cpp.tmpl", template_text("api_loops.cpp.tmpl"), api);
    solver.ops.insert(solver.ops.end(), loops.ops.begin(), loops.ops.end());
  }
  solver.ops.push_back({"4", k4.ops});
  // Steps as separate functions: inlined into one solve, the steps of a
  // large model make one huge function that runs slower, most of all built
  // position-independent as add_jr_solver() does (the HMMWV 4-14% slower
  // inlined, with about the same number of instructions executed: how GCC
  // schedules and lays out one huge function, not more work).  Small models
  // keep the steps inlined, where the calls would cost more than they save
  // (docs/benchmarks.md, run 7).  The same solvers keep the fences that
  // Kernel::functions() wrote (kFenceProducts); the others lose them.
  long long operations = 0;
  for (const StepOps& s : solver.ops) operations += s.ops.add + s.ops.mul;
  v["step_attribute"] = "";
  if (operations >= kMinOpsSeparateSteps) {
    v["step_attribute"] =
        "// Each step below stays its own function (" + std::to_string(operations) +
        " additions and multiplications in all:\n"
        "// one function that large compiles to slower code), and the long steps\n"
        "// pass values from block to block through memory (jr::compiler_fence).\n"
        "// noclone: GCC would clone each step with the thread-local workspace\n"
        "// propagated into it, and then recompute the arrays' addresses after\n"
        "// fences, saving registers around each; as arguments they are plain pointers.\n"
        "#if defined(__GNUC__) && !defined(__clang__)\n"
        "#define JRGEN_STEP __attribute__((noinline, noclone))\n"
        "#elif defined(__clang__)\n"
        "#define JRGEN_STEP __attribute__((noinline))\n"
        "#elif defined(_MSC_VER)\n"
        "#define JRGEN_STEP __declspec(noinline)\n"
        "#else\n"
        "#define JRGEN_STEP\n"
        "#endif\n\n";
    for (const char* key : {"step1", "step2", "step3", "step4"}) v[key] = mark_step_definitions(v[key]);
  } else {
    // Small solvers keep their values in registers: no fences.
    for (const char* key : {"step1", "step2", "step3", "step4"}) v[key] = strip_fences(v[key]);
  }
  solver.source = render_template("solver.cpp.tmpl", template_text("solver.cpp.tmpl"), v);
  return solver;
}

}  // namespace jrgen::emit
