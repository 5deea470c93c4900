// Steps 1, 2 and 4, supernodal (Shape::kSupernodal: trees with a run of at
// least kMinDenseSupernode single-child dofs, method llt): the dense
// supernodes as a table, the runtime's blocked kernels on them, its scalar
// loops elsewhere.
#include <fmt/format.h>

#include "emit/format.hpp"
#include "emit/kernel.hpp"
#include "emit/steps/step_text.hpp"
#include "emit/steps/steps.hpp"

namespace jrgen::emit {

void supernodal_steps(const topology::Tree& t, const Plan& plan, Steps124& s) {
  const std::vector<topology::Supernode>& nodes = plan.supernodes;
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
  s.step1 = fmt::format(
      "// ---- Step 1: factor M = L L^T, eq. (25)-(26), supernodal. ----\n"
      "{}\n// {}\n"
      "constexpr jr::Supernode kSupernodes[{}] = {{\n{}\n}};\n"
      "thread_local double g_S[{}];  // the supernodes' columns of L, dense\n",
      as_comment(fmt::format(
          "Dense supernodes (runs of >= {} dofs of the dof tree each with a single child,\n"
          "so their columns of L share one dense structure): Eigen's blocked Cholesky on\n"
          "the diagonal block, a triangular solve for the panel of ancestor rows, and its\n"
          "rank-s update subtracted from the ancestors' packed columns.  Every other\n"
          "column: the runtime's scalar loops over the packed layout (Lemma 2).",
          kMinDenseSupernode)),
      ops_text(s.ops1, true), n, table, dense);
  s.step1 += call_function(
      "", "int step1_factor(double* L, double* Dinv)",
      {"double pivot = 0.0;", "const std::int32_t j =",
       fmt::format("    jr::factor_supernodal(kModel, kSupernodes, {}, L, g_S, Dinv, kMassPivotTolerance, &pivot);", n),
       "return j < 0 ? 0 : not_positive_definite(j, pivot);"});
  s.step2 = call_function(
      "---- Step 2: solve L z = Q (forward substitution), Remark 2, supernodal. ----\n" + ops_text(s.ops2, true),
      "void step2_forward(const double* L, const double* Dinv, double* z)",
      {fmt::format("jr::forward_supernodal(kModel, kSupernodes, {}, L, g_S, Dinv, z);", n)});
  s.step4 = call_function(
      "---- Step 4: solve L^T qdd = z (back substitution), Remark 2, supernodal. ----\n" + ops_text(s.ops4, true),
      "void step4_backward(const double* L, const double* Dinv, double* z)",
      {fmt::format("jr::backward_supernodal(kModel, kSupernodes, {}, L, g_S, Dinv, z);", n)});
}

}  // namespace jrgen::emit
