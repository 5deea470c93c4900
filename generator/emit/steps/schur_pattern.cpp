// The symbolic structure of T^T T and of its factor (Step 3.4 of Section
// 4.3): the elimination order of the kept rows, the structural entries (rows
// whose cuts share a dof, Lemma 3) and the fill.  Declared in emit/loops.hpp.
#include <algorithm>

#include "emit/loops.hpp"

namespace jrgen::emit {

int SchurPattern::position(int row, int col) const {
  if (row == col) return col_start[col];
  const std::vector<int>& p = pattern[col];
  return col_start[col] + 1 + static_cast<int>(std::lower_bound(p.begin(), p.end(), row) - p.begin());
}

SchurPattern schur_pattern(const topology::Tree& t) {
  SchurPattern sp;
  std::vector<int> rows_per_cut;
  for (const topology::Cut& cut : t.cuts) rows_per_cut.push_back(static_cast<int>(cut.kept_rows.size()));
  const topology::RowOrder order = topology::constraint_row_order(t, rows_per_cut);
  sp.order = order.order;
  sp.minimum_degree = order.minimum_degree;
  sp.m = static_cast<int>(sp.order.size());
  // Structural entries below the diagonal (rows whose cuts share a dof), in
  // elimination positions, then the fill of the symbolic factorization.
  const std::vector<std::vector<int>> lower = topology::constraint_row_pattern(t, rows_per_cut, sp.order);
  sp.pattern = topology::symbolic_cholesky(lower, -1, nullptr);
  sp.row_list.assign(sp.m, {});
  sp.structural.assign(sp.m, {});
  sp.col_start.assign(sp.m + 1, 0);
  for (int j = 0; j < sp.m; ++j) {
    sp.col_start[j + 1] = sp.col_start[j] + 1 + static_cast<int>(sp.pattern[j].size());
    for (int r : sp.pattern[j]) {
      sp.row_list[r].push_back(j);
      sp.structural[j].push_back(std::binary_search(lower[j].begin(), lower[j].end(), r));
    }
  }
  return sp;
}

}  // namespace jrgen::emit
