// Step 3.1 of Section 4.3, straight-line: L T = Phiq^T (L U = Phiq^T with
// L D L^T), only the rows of Lemma 3, T stored by dofs (Step3Layout).
#include <fmt/format.h>

#include <algorithm>

#include "emit/format.hpp"
#include "emit/steps/step3.hpp"
#include "emit/steps/step_text.hpp"

namespace jrgen::emit {

namespace {

// The chains of a cut: dofs on the path from k (and from l) to the base.
std::vector<int> chain(const topology::Tree& t, int body) {
  std::vector<int> out;
  for (int d = body >= 0 ? t.bodies[body].v_lem : -1; d >= 0; d = t.dof_parent[d]) out.push_back(d);
  return out;
}

// For each dof of the cut (same order as cut.dofs), the dofs of the cut that
// are its descendants: L[i, v] T[v] can be non-zero only for these (Lemma 3).
std::vector<std::vector<int>> cut_descendants(const topology::Tree& t, const topology::Cut& cut) {
  std::vector<std::vector<int>> out(cut.dofs.size());
  for (const std::vector<int>& ch : {chain(t, cut.body_k), chain(t, cut.body_l)})
    for (std::size_t a = 0; a < ch.size(); ++a)
      for (std::size_t b = 0; b < a; ++b) {
        std::vector<int>& list = out[dof_index(cut, ch[a])];
        if (std::find(list.begin(), list.end(), ch[b]) == list.end()) list.push_back(ch[b]);
      }
  for (std::vector<int>& list : out) std::sort(list.begin(), list.end());
  return out;
}

// Row i of T: entry (i, g) sums over the descendants v of i on the paths of
// g's cut, from the packed Phiq entry (none at the common ancestors of k
// and l, where Phiq is exactly zero).
void row_of_T(const Step3Layout& lay, const std::vector<std::vector<std::vector<int>>>& cdesc, int i, Kernel& k) {
  const topology::Tree& t = lay.t;
  const TByDofs& td = lay.td;
  Kernel::Unit& u = k.unit();
  u.lines.push_back(fmt::format("// row {} of T: {} ({} constraint rows)", i, dof_label(t, i), td.rows[i].size()));
  auto descendants = [&](int g) -> const std::vector<int>& {
    return cdesc[lay.rows[g].cut][dof_index(t.cuts[lay.rows[g].cut], i)];
  };
  auto base_index = [&](int g) {
    const topology::Cut& cut = t.cuts[lay.rows[g].cut];
    const int idx = dof_index(cut, i);
    return idx < cut.num_distinct ? lay.rows[g].t_start + idx : -1;
  };
  // Two neighbouring entries of row i of T whose sums run over the same
  // descendants, each holding both rows next to each other, become one
  // statement on a pair of doubles (Kernel::update_pair).
  auto pairable = [&](int g, int g2) {
    if (td.at(i, g2) != td.at(i, g) + 1 || (base_index(g) < 0) != (base_index(g2) < 0)) return false;
    if (descendants(g) != descendants(g2)) return false;
    for (int v : descendants(g))
      if (td.at(v, g2) != td.at(v, g) + 1) return false;
    return true;
  };
  // LDLT: unit diagonal.  --divide: by the pivot L[i,i] itself.
  const Scale scale = lay.ldlt     ? Scale()
                      : lay.divide ? Scale::divided_by(L(t, i, i))
                                   : Scale(fmt::format("Dinv[{}]", i));
  const std::vector<int>& gs = td.rows[i];
  for (std::size_t p = 0; p < gs.size();) {
    const int g = gs[p];
    const int b = base_index(g);
    if (descendants(g).empty() && b < 0) {  // (cannot happen: a common dof has descendants on the paths)
      u.lines.push_back(lay.T(i, g) + " = 0.0;");
      ++u.statements;
      p += 1;
    } else if (p + 1 < gs.size() && pairable(g, gs[p + 1])) {
      std::vector<Term> terms;
      for (int v : descendants(g)) terms.push_back({L(t, i, v), fmt::format("jr::load2(T + {})", td.at(v, g))});
      const std::string base = b < 0 ? "" : fmt::format("jr::set2(P[{}], P[{}])", b, base_index(gs[p + 1]));
      k.update_pair(u, "", fmt::format("T + {}", td.at(i, g)), base, terms, scale);
      p += 2;
    } else {
      std::vector<Term> terms;
      for (int v : descendants(g)) terms.push_back({L(t, i, v), lay.T(v, g)});
      k.update(u, "", lay.T(i, g), b < 0 ? "" : fmt::format("P[{}]", b), terms, scale);
      p += 1;
    }
  }
}

}  // namespace

StepCode step31(const Step3Layout& lay) {
  const topology::Tree& t = lay.t;
  Kernel k;
  k.fence_every = kFenceProducts;
  std::vector<std::vector<std::vector<int>>> cdesc(t.cuts.size());
  for (std::size_t c = 0; c < t.cuts.size(); ++c) cdesc[c] = cut_descendants(t, t.cuts[c]);
  for (int i = 0; i < t.nv; ++i)
    if (!lay.td.rows[i].empty()) row_of_T(lay, cdesc, i, k);
  const bool ldlt = lay.ldlt;
  const char* U = ldlt ? "U" : "T";
  const std::string call_args = ldlt ? "g_L, g_T, g_Tr" : "g_L, g_Dinv, g_T, g_Tr";
  return {k.functions("step31_solve_T",
                      ldlt ? "const double* L, const double* P, double* T"
                           : "const double* L, const double* Dinv, const double* P, double* T",
                      ldlt ? "L, P, T" : "L, Dinv, P, T", false,
                      fmt::format("---- Step 3.1: solve L {0} = Phiq^T (P: the packed Phiq, cut row by cut row). ----\n"
                                  "Lemma 3: the column of row r of cut j is non-zero only at dofs of\n"
                                  "d[k] U d[l]; only those are stored and computed.  {0} is stored by\n"
                                  "its rows (dofs, descendants first), each row's constraint rows in\n"
                                  "elimination order, so neighbouring statements touch neighbouring entries.{1}\n"
                                  "{2}",
                                  U, ldlt ? " L has a unit diagonal: U = L^-1 Phiq^T." : "", ops_text(k.ops))),
          k.ops, call_args};
}

}  // namespace jrgen::emit
