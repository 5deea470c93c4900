// Step 2 of Section 4.3, straight-line: L z = Q by forward substitution.
#include <fmt/format.h>

#include "emit/format.hpp"
#include "emit/kernel.hpp"
#include "emit/steps/step_text.hpp"
#include "emit/steps/steps.hpp"

namespace jrgen::emit {

namespace {

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

}  // namespace

std::string step2_unrolled(const topology::Tree& t, const Plan& plan, const std::vector<std::vector<int>>& desc,
                           OpCount& ops) {
  const Kernel k2 = step2(t, desc, plan.method, plan.divide);
  ops = k2.ops;
  return k2.functions(
      "step2_forward", plan.ldlt ? "const double* L, double* z" : "const double* L, const double* Dinv, double* z",
      plan.ldlt ? "L, z" : "L, Dinv, z", false,
      fmt::format("---- Step 2: solve L z = Q (forward substitution), Remark 2: ----\n"
                  "row j sums over the family F(j) only.{}\n{}",
                  plan.ldlt ? " Unit diagonal; D^-1 is applied in Step 4." : "", ops_text(k2.ops)));
}

}  // namespace jrgen::emit
