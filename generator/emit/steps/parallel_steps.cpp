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

namespace {

// What the three steps' texts share: the work items and the OpenMP pragma.
struct Parallel {
  int n = 0;           ///< subtrees
  int tasks = 0;       ///< work items
  bool ldlt = false;
  const char* flag = "false";  ///< the runtime loops' ldlt argument
  std::string pragma;  ///< "#pragma omp parallel for", inside #if defined(_OPENMP)
};

Parallel parallel_of(const Plan& plan, const std::vector<long long>& task_start) {
  Parallel p;
  p.n = static_cast<int>(plan.subtrees.size());
  p.tasks = static_cast<int>(task_start.size()) - 1;
  p.ldlt = plan.ldlt;
  p.flag = plan.ldlt ? "true" : "false";
  const std::string omp =
      plan.threads >= 2 ? fmt::format("#pragma omp parallel for schedule(dynamic, 1) num_threads({})", plan.threads)
                        : std::string("#pragma omp parallel for schedule(dynamic, 1)");
  p.pragma = "#if defined(_OPENMP)\n" + omp + "\n#endif\n";
  return p;
}

// Work items: groups of consecutive subtrees of about total / kParallelParts
// work each; item w runs subtrees task_start[w] .. task_start[w + 1] - 1.
std::vector<long long> task_starts(const std::vector<topology::Subtree>& trees) {
  long long total = 0;
  for (const topology::Subtree& s : trees) total += s.work;
  std::vector<long long> task_start{0};
  long long acc = 0;
  for (std::size_t i = 0; i < trees.size(); ++i) {
    acc += trees[i].work;
    if (acc * kParallelParts >= total || i + 1 == trees.size()) {
      task_start.push_back(static_cast<long long>(i) + 1);
      acc = 0;
    }
  }
  return task_start;
}

std::string step1_text(const topology::Tree& t, const Plan& plan, const Parallel& par,
                       const std::vector<long long>& task_start, const OpCount& ops) {
  const std::vector<topology::Subtree>& trees = plan.subtrees;
  long long buffer = 1, inside = 0;
  std::string table;
  for (const topology::Subtree& s : trees) {
    buffer = std::max(buffer, s.buffer + static_cast<long long>(s.path) * s.path);
    inside += s.root - s.first + 1;
    table += fmt::format("  {{{}, {}, {}, {}}},  // {}\n", s.first, s.root, s.path, s.buffer, dof_label(t, s.root));
  }
  table.pop_back();
  const int n = par.n, tasks = par.tasks;
  const char* flag = par.flag;
  return fmt::format(
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
      "      failed[w] = jr::factor_subtree(kModel, kSubtrees[i], L, Dinv, {}, kMassPivotTolerance, &pivots[w],\n"
      "                                     U + kSubtrees[i].buffer);\n"
      "  }}\n"
      "  for (std::int32_t w = 0; w < kNumTasks; ++w)\n"
      "    if (failed[w] >= 0) return not_positive_definite(failed[w], pivots[w]);\n"
      "  for (std::int32_t i = 0; i < {}; ++i) jr::apply_subtree_update(kModel, kSubtrees[i], U + kSubtrees[i].buffer, L);\n"
      "  double pivot = 0.0;\n"
      "  const std::int32_t j = jr::factor_separator(kModel, kSubtrees, {}, L, Dinv, {}, kMassPivotTolerance, &pivot);\n"
      "  return j < 0 ? 0 : not_positive_definite(j, pivot);\n"
      "}}",
      par.ldlt ? "M = L D L^T" : "M = L L^T",
      as_comment(fmt::format(
          "Corollary 3 (Section 5): columns of L in disjoint subtrees are independent.\n"
          "{} subtrees ({} dofs) below a separator of {} dofs, in {} work items run\n"
          "in parallel (OpenMP, when compiled with it); each subtree's updates of the\n"
          "separator rows go to its own buffer, added in serially before the separator\n"
          "columns are factored.  Step 2 likewise; Step 4 in reverse.",
          n, inside, t.nv - inside, tasks)),
      "// " + ops_text(ops, true), n, table, tasks + 1, join_ints(task_start), tasks, buffer, par.pragma, flag, n, n, flag);
}

std::string step2_text(const Parallel& par, const OpCount& ops) {
  const bool ldlt = par.ldlt;
  return fmt::format(
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
      "// " + ops_text(ops, true), ldlt ? "" : "const double* Dinv, ", par.pragma, ldlt ? "nullptr" : "Dinv", par.flag,
      par.n, par.n, ldlt ? "nullptr" : "Dinv", par.flag);
}

std::string step4_text(const Parallel& par, const OpCount& ops) {
  return fmt::format(
      "// ---- Step 4: solve L^T qdd = z (back substitution), Remark 2, parallel. ----\n{}\n"
      "void step4_backward(const double* L, const double* Dinv, double* z) {{\n"
      "  jr::backward_separator(kModel, kSubtrees, {}, L, Dinv, {}, z);\n"
      "{}"
      "  for (std::int32_t w = 0; w < kNumTasks; ++w)\n"
      "    for (std::int32_t i = kTaskStart[w]; i < kTaskStart[w + 1]; ++i)\n"
      "      jr::backward_subtree(kModel, kSubtrees[i], L, Dinv, {}, z);\n"
      "}}",
      "// " + ops_text(ops, true), par.n, par.flag, par.pragma, par.flag);
}

}  // namespace

void parallel_steps(const topology::Tree& t, const Plan& plan, Steps124& out) {
  const std::vector<long long> task_start = task_starts(plan.subtrees);
  const Parallel par = parallel_of(plan, task_start);
  out.step1 = step1_text(t, plan, par, task_start, out.ops1);
  out.step2 = step2_text(par, out.ops2);
  out.step4 = step4_text(par, out.ops4);
}

}  // namespace jrgen::emit
