// Steps 1, 2 and 4, parallel (Shape::kParallel: Corollary 3, trees, with
// --threads N >= 2 or at least kMinParallelDofs dofs): subtrees below a
// separator as OpenMP work items (groups of consecutive subtrees of about
// equal work), the runtime's subtree and separator loops.
#include <fmt/format.h>

#include <algorithm>

#include "emit/format.hpp"
#include "emit/steps/step_text.hpp"
#include "emit/steps/steps.hpp"

namespace jrgen::emit {

void parallel_steps(const topology::Tree& t, const Plan& plan, Steps124& out) {
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
  const bool ldlt = plan.ldlt;
  const char* flag = ldlt ? "true" : "false";
  const std::string omp = plan.threads >= 2
                              ? fmt::format("#pragma omp parallel for schedule(dynamic, 1) num_threads({})", plan.threads)
                              : std::string("#pragma omp parallel for schedule(dynamic, 1)");
  const std::string pragma = "#if defined(_OPENMP)\n" + omp + "\n#endif\n";
  out.step1 = fmt::format(
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
      "// " + ops_text(out.ops1, true), n, table, tasks + 1, join_ints(task_start), tasks, buffer, pragma, flag, n, n, flag);
  out.step2 = fmt::format(
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
      "// " + ops_text(out.ops2, true), ldlt ? "" : "const double* Dinv, ", pragma, ldlt ? "nullptr" : "Dinv", flag, n, n,
      ldlt ? "nullptr" : "Dinv", flag);
  out.step4 = fmt::format(
      "// ---- Step 4: solve L^T qdd = z (back substitution), Remark 2, parallel. ----\n{}\n"
      "void step4_backward(const double* L, const double* Dinv, double* z) {{\n"
      "  jr::backward_separator(kModel, kSubtrees, {}, L, Dinv, {}, z);\n"
      "{}"
      "  for (std::int32_t w = 0; w < kNumTasks; ++w)\n"
      "    for (std::int32_t i = kTaskStart[w]; i < kTaskStart[w + 1]; ++i)\n"
      "      jr::backward_subtree(kModel, kSubtrees[i], L, Dinv, {}, z);\n"
      "}}",
      "// " + ops_text(out.ops4, true), n, flag, pragma, flag);
}

}  // namespace jrgen::emit
