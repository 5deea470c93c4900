#include "emit/steps/pivots.hpp"

#include <fmt/format.h>

namespace jrgen::emit {

std::string pivot_test(const std::string& base, const std::string& fail, const std::string& tolerance) {
  return fmt::format("if (!(d > {} * {})) return {};", tolerance, base, fail);
}

// --divide keeps W = L D instead of L (eq. 26 without the division): an entry
// of column i stays unscaled until column k is reached, which needs
// L[k,i] = W[k,i] / D[i] (D[i] is known by then) as well as W[k,i] itself.
std::vector<std::string> ldlt_pivot(Kernel& k, Kernel::Unit& u, const LdltPivot& c, bool unscaled) {
  const std::string in = "  ";
  std::vector<std::string> names;
  std::vector<Term> dterms;
  for (std::size_t n = 0; n < c.entries.size(); ++n) {
    const std::string name = fmt::format("{}{}", unscaled ? "l" : "w", n);
    u.lines.push_back(in + fmt::format("const double {} = {} {} {};", name, c.entries[n], unscaled ? "/" : "*",
                                       c.pivots[n]));
    ++u.statements;
    (unscaled ? k.ops.div : k.ops.mul) += 1;
    dterms.push_back(unscaled ? Term{c.entries[n], name} : Term{name, c.entries[n]});
    names.push_back(name);
  }
  k.update(u, in, "d", c.base, dterms, "", "const double ", "sd");
  u.lines.push_back(in + pivot_test(c.base, c.fail, c.tolerance));
  u.lines.push_back(in + c.diag + " = d;");
  u.statements += 2;
  if (c.reciprocal) {
    u.lines.push_back(in + c.inverse + " = 1.0 / d;");
    k.ops.div += 1;
  } else {
    u.lines.push_back(in + c.inverse + " = d;  // the pivot itself, for " + c.check);
  }
  ++u.statements;
  if (unscaled)
    for (std::size_t n = 0; n < names.size(); ++n) {
      u.lines.push_back(in + fmt::format("{} = {};", c.entries[n], names[n]));
      ++u.statements;
    }
  return names;
}

}  // namespace jrgen::emit
