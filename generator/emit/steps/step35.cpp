// Step 3.5 of Section 4.3, straight-line: y_n = T lambda, subtracted from
// z_n in place (Step 4 then solves with z_n - y_n); only the rows of dofs
// some cut reaches.
#include <fmt/format.h>

#include "emit/format.hpp"
#include "emit/steps/step3.hpp"
#include "emit/steps/step_text.hpp"

namespace jrgen::emit {

StepCode step35(const Step3Layout& lay) {
  const topology::Tree& t = lay.t;
  Kernel k;
  k.fence_every = kFenceProducts;
  for (int i = 0; i < t.nv; ++i) {
    if (lay.td.rows[i].empty()) continue;
    std::vector<Term> terms;  // in storage order
    for (int g : lay.td.rows[i]) terms.push_back({lay.T(i, g), fmt::format("zm[{}]", g)});
    Kernel::Unit& u = k.unit();
    u.lines.push_back(fmt::format("// row {}: {}", i, dof_label(t, i)));
    const std::string z = fmt::format("z[{}]", i);
    k.update(u, "", z, z, terms, "");
  }
  const std::string call_args = "g_Tr, g_zm, g_z";
  return {k.functions("step35_update", "const double* T, const double* zm, double* z", "T, zm, z", false,
                      fmt::format("---- Step 3.5: y_n = {} lambda, subtracted from z_n in place (Step 4 then ----\n"
                                  "solves with z_n - y_n). Only rows of dofs some cut reaches.\n{}",
                                  lay.ldlt ? "U" : "T", ops_text(k.ops))),
          k.ops, call_args};
}

}  // namespace jrgen::emit
