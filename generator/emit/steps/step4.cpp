// Step 4 of Section 4.3, straight-line: L^T qdd = z - y by back substitution.
#include <fmt/format.h>

#include "emit/format.hpp"
#include "emit/kernel.hpp"
#include "emit/steps/step_text.hpp"
#include "emit/steps/steps.hpp"

namespace jrgen::emit {

namespace {

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

}  // namespace

std::string step4_unrolled(const topology::Tree& t, const Plan& plan, OpCount& ops) {
  const Kernel k4 = step4(t, plan.method, plan.divide);
  ops = k4.ops;
  return k4.functions("step4_backward", "const double* L, const double* Dinv, double* z", "L, Dinv, z", false,
                      fmt::format("---- Step 4: solve L^T qdd = z (back substitution), Remark 2: ----\n"
                                  "row j sums over the ancestors of j only.\n{}",
                                  ops_text(k4.ops)));
}

}  // namespace jrgen::emit
