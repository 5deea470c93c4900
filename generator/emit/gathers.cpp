// The gathers of solve_augmented (template value gather): its dense inputs
// in user order read into the solver's workspace in Lemma 2 order, only the
// structurally non-zero entries, and qdd scattered back.  Straight-line
// copies, or loops over index tables when the model is large
// (gather_function, emit/format.hpp).
#include <fmt/format.h>

#include <string>
#include <vector>

#include "emit/blocks.hpp"
#include "emit/format.hpp"
#include "emit/kernel.hpp"
#include "emit/steps/step3.hpp"

namespace jrgen::emit {

namespace {

// M (dense, user order) -> packed L, eq. (18): column c holds rows c,
// parent(c), ...  A table of source indices, or for a very large L
// (kMaxGatherTable) a walk through the dof tree.
std::string gather_M(const topology::Tree& t, bool unrolled) {
  if (!unrolled && t.nnz() > kMaxGatherTable)
    return "// M (dense, user order) -> packed L: the structurally non-zero entries, eq. (18);\n"
           "// column c holds rows c, parent(c), ... (walked through the dof tree: no table).\n"
           "void gather_M(const double* __restrict M, double* __restrict L) {\n"
           "  std::int64_t k = 0;\n"
           "  for (std::int32_t c = 0; c < nv; ++c) {\n"
           "    const double* col = M + static_cast<std::int64_t>(kDofUser[c]) * nv;\n"
           "    for (std::int32_t r = c; r >= 0; r = kDofParent[r]) L[k++] = col[kDofUser[r]];\n"
           "  }\n"
           "}";
  std::vector<long long> pack_to, pack_from;
  for (int c = 0; c < t.nv; ++c) {
    pack_to.push_back(static_cast<long long>(pack_to.size()));
    pack_from.push_back(static_cast<long long>(t.dof_user[c]) * (t.nv + 1));
    for (int r : t.ancestors(c)) {
      pack_to.push_back(static_cast<long long>(pack_to.size()));
      pack_from.push_back(t.dof_user[r] + static_cast<long long>(t.nv) * t.dof_user[c]);
    }
  }
  return gather_function("// M (dense, user order) -> packed L: the structurally non-zero entries, eq. (18).\n",
                         "gather_M", "M", "L", pack_to, pack_from, unrolled);
}

}  // namespace

std::string gathers(const topology::Tree& t, const Plan& plan) {
  // Q in, qdd out: user order <-> Lemma 2 order.
  std::vector<long long> lem, user;
  for (int j = 0; j < t.nv; ++j) {
    lem.push_back(j);
    user.push_back(t.dof_user[j]);
  }
  std::string out =
      gather_function("// Q (user order) -> z (Lemma 2 order).\n", "gather_Q", "Q", "z", lem, user, plan.unrolled) +
      "\n\n" +
      gather_function("// z (Lemma 2 order) -> qdd (user order).\n", "scatter_qdd", "z", "qdd", user, lem,
                      plan.unrolled);
  // A fused Step 1 reads M itself (steps/step1.cpp).
  if (!plan.fused) out += "\n\n" + gather_M(t, plan.unrolled);
  return out;
}

std::string gather_phiq(const topology::Tree& t, const std::vector<Row>& rows, bool unrolled) {
  std::vector<long long> from_dense, packed;
  const long long m = static_cast<long long>(rows.size());
  for (std::size_t g = 0; g < rows.size(); ++g) {
    const topology::Cut& cut = t.cuts[rows[g].cut];
    for (int idx = 0; idx < cut.num_distinct; ++idx) {
      packed.push_back(rows[g].t_start + idx);
      from_dense.push_back(static_cast<long long>(g) + m * t.dof_user[cut.dofs[idx]]);
    }
  }
  return gather_function(
      "// Phiq (dense, user order) -> packed: the structurally non-zero entries only\n"
      "// (the dofs of Lemma 3 less the common ancestors, where Phiq is zero).\n",
      "gather_Phiq", "Phiq", "T", packed, from_dense, unrolled);
}

}  // namespace jrgen::emit
