// Step 3.3 of Section 4.3, straight-line: W = T^T T (L D L^T: V^T U), only
// the entries whose rows' cuts share a dof (Lemma 3); the fill of Step 3.4
// set to 0.  A dense part (every row reaching some common dofs) goes to the
// runtime's dense Gram kernel.
#include <fmt/format.h>

#include <algorithm>
#include <iterator>

#include "emit/format.hpp"
#include "emit/steps/step3.hpp"
#include "emit/steps/step_text.hpp"

namespace jrgen::emit {

namespace {

// The dense part: the dofs reached by every row, one k x m block of T.
void dense_gram(const Step3Layout& lay, Kernel& k) {
  const int m = lay.m, first = lay.dense_first, dofs = lay.dense_dofs;
  Kernel::Unit& u = k.unit();
  u.lines.push_back(fmt::format("// dense part: the {} dofs {} to {} reached by every row ({} .. {})", dofs, first,
                                first + dofs - 1, dof_label(lay.t, first), dof_label(lay.t, first + dofs - 1)));
  const std::string A = fmt::format("{} + {}", lay.ldlt ? "V" : "T", lay.td.start[first]);
  const std::string B = fmt::format("T + {}", lay.td.start[first]);
  u.lines.push_back(lay.square_W ? fmt::format("jr::schur_square_gram_fixed<{}, {}>({}, {}, W);", dofs, m, A, B)
                                 : fmt::format("jr::schur_dense_gram({}, {}, {}, {}, W);", A, B, dofs, m));
  ++u.statements;
  const long long entries = static_cast<long long>(m) * (m + 1) / 2;
  k.ops.mul += entries * dofs;
  k.ops.add += entries * (dofs - 1);
}

// Column j of W (elimination positions).
void column(const Step3Layout& lay, int j, Kernel& k) {
  const topology::Tree& t = lay.t;
  const SchurPattern& sp = lay.sp;
  Kernel::Unit& u = k.unit();
  u.lines.push_back(fmt::format("// column {}: {}{}", j, row_label(t, lay.row_at(j)),
                                lay.dense_schur() ? " (the other shared dofs)" : ""));
  const topology::Cut& cj = t.cuts[lay.row_at(j).cut];
  // The products of entry (r, j): the dofs both cuts reach, outside the dense part.
  auto entry = [&](int r) {
    const topology::Cut& cr = t.cuts[lay.row_at(r).cut];
    std::vector<Term> terms;
    std::vector<int> common;
    std::set_intersection(cj.dofs.begin(), cj.dofs.end(), cr.dofs.begin(), cr.dofs.end(), std::back_inserter(common));
    for (int i : common) {
      if (i >= lay.dense_first && i < lay.dense_last()) continue;
      terms.push_back({lay.ldlt ? lay.V(i, sp.order[r]) : lay.T(i, sp.order[r]), lay.T(i, sp.order[j])});
    }
    return terms;
  };
  if (lay.dense_schur()) {
    // The products outside the dense part, added to it.
    k.add_sum(u, "", lay.W(j, j), entry(j));
    for (int r : sp.pattern[j]) k.add_sum(u, "", lay.W(r, j), entry(r));
    if (u.statements == 0) k.units.pop_back();  // nothing outside the dense part
    return;
  }
  k.assign_sum(u, "", lay.W(j, j), entry(j), "");
  for (std::size_t e = 0; e < sp.pattern[j].size(); ++e) {
    const int r = sp.pattern[j][e];
    const std::string target = lay.W(r, j);
    if (sp.structural[j][e]) {
      k.assign_sum(u, "", target, entry(r), "");
    } else {
      u.lines.push_back(target + " = 0.0;  // fill of Step 3.4");
      ++u.statements;
    }
  }
}

}  // namespace

StepCode step33(const Step3Layout& lay) {
  Kernel k;
  k.fence_every = kFenceProducts;
  if (lay.dense_schur()) dense_gram(lay, k);
  for (int j = 0; j < lay.m; ++j) column(lay, j, k);
  const bool ldlt = lay.ldlt;
  const std::string call_args = ldlt ? "g_Tr, g_V, g_W" : "g_Tr, g_W";
  return {k.functions("step33_TtT", ldlt ? "const double* T, const double* V, double* W" : "const double* T, double* W",
                      ldlt ? "T, V, W" : "T, W", false,
                      fmt::format("---- Step 3.3: W = {} (m = {}), {}. ----\n"
                                  "Entry (r, s) is computed only when the cuts of rows r and s share a dof;\n"
                                  "entries that are zero here but filled by Step 3.4 are set to 0.\n"
                                  "{}",
                                  ldlt ? "U^T D^-1 U = V^T U" : "T^T T", lay.m,
                                  lay.square_W ? fmt::format("square: entry (r, s) at W[r + {} s]", lay.ld)
                                               : "packed by columns",
                                  ops_text(k.ops))),
          k.ops, call_args};
}

}  // namespace jrgen::emit
