// Step 3.2 of Section 4.3, straight-line: z_m = T^T z_n - gamma (L D L^T:
// V = D^-1 U, z_m = V^T y - gamma), one statement per kept row.
#include <fmt/format.h>

#include "emit/format.hpp"
#include "emit/steps/step3.hpp"
#include "emit/steps/step_text.hpp"

namespace jrgen::emit {

namespace {

// L D L^T: V = D^-1 U, laid out as T; the left factor of Step 3.3.  It reads
// Dinv, or with --divide the pivots on L's diagonal.
void scaled_rows(const Step3Layout& lay, Kernel& k) {
  const topology::Tree& t = lay.t;
  for (int i = 0; i < t.nv; ++i) {
    if (lay.td.rows[i].empty()) continue;
    Kernel::Unit& u = k.unit();
    u.lines.push_back(fmt::format("// V, row {}: {}", i, dof_label(t, i)));
    for (int g : lay.td.rows[i]) {
      u.lines.push_back(lay.divide ? fmt::format("{} = {} / {};", lay.V(i, g), lay.T(i, g), L(t, i, i))
                                   : fmt::format("{} = {} * Dinv[{}];", lay.V(i, g), lay.T(i, g), i));
      ++u.statements;
      (lay.divide ? k.ops.div : k.ops.mul) += 1;
    }
  }
}

}  // namespace

StepCode step32(const Step3Layout& lay) {
  const topology::Tree& t = lay.t;
  const bool ldlt = lay.ldlt;
  Kernel k;
  k.fence_every = kFenceProducts;
  if (ldlt) scaled_rows(lay, k);
  for (int p = 0; p < lay.m; ++p) {
    const int g = lay.sp.order[p];
    const Row& row = lay.rows[g];
    Kernel::Unit& u = k.unit();
    u.lines.push_back(fmt::format("// row {}: {}", g, row_label(t, row)));
    std::vector<Term> terms;
    for (int i : t.cuts[row.cut].dofs) terms.push_back({ldlt ? lay.V(i, g) : lay.T(i, g), fmt::format("z[{}]", i)});
    k.assign_sum(u, "", fmt::format("zm[{}]", g), terms, fmt::format("gamma[{}]", g));
  }
  const std::string pivots = lay.divide ? "L" : "Dinv";
  const std::string call_args = ldlt ? "g_Tr, g_" + pivots + ", g_z, g_gamma, g_V, g_zm" : "g_Tr, g_z, g_gamma, g_zm";
  return {k.functions("step32_rhs",
                      ldlt ? "const double* T, const double* " + pivots +
                                 ", const double* z, const double* gamma, double* V, double* zm"
                           : "const double* T, const double* z, const double* gamma, double* zm",
                      ldlt ? "T, " + pivots + ", z, gamma, V, zm" : "T, z, gamma, zm", false,
                      fmt::format("---- Step 3.2: z_m = {} ----\n{}",
                                  ldlt ? "U^T D^-1 y - gamma, with V = D^-1 U kept for Step 3.3." : "T^T z_n - gamma.",
                                  ops_text(k.ops))),
          k.ops, call_args};
}

}  // namespace jrgen::emit
