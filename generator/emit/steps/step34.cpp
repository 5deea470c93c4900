// Step 3.4 of Section 4.3, straight-line: factor W = L_W L_W^T (or
// L_W D_W L_W^T) in place, fill included, in the elimination order of
// schur_pattern(), and solve W lambda = z_m.  A dense W goes to the
// runtime's dense kernels instead (the factor with the forward solve in the
// same passes).  check_digits_W() follows, for both shapes of Step 3.
#include <fmt/format.h>

#include <algorithm>
#include <iterator>
#include <map>

#include "emit/format.hpp"
#include "emit/steps/pivots.hpp"
#include "emit/steps/step3.hpp"
#include "emit/steps/step_text.hpp"

namespace jrgen::emit {

namespace {

// The runtime's right-looking loops factor in the order of L D L^T
// (jrgen/constraint_solve.hpp): m (m^2 - 1) / 6 products and subtractions,
// one product f = w / d per pair of columns, one division per pivot; L L^T
// then scales each column by 1 / sqrt(d) = sqrt(d) / d (a square root and a
// product per pivot, a product per entry).  The forward substitution rides
// along: g = u / d per pivot with rows below (m - 1), a product and a
// subtraction per entry, and with L L^T the scaling y = u / sqrt(d) (m).  The
// backward substitution is that of the unrolled solve: a product and a
// subtraction per entry, m scalings.
void dense_ops(const Step3Layout& lay, OpCount& factor, OpCount& solve) {
  const long long mm = lay.m, updates = mm * (mm * mm - 1) / 6, below = mm * (mm - 1) / 2;
  factor.add = updates + below;
  factor.mul = updates + below + (mm - 1) + below + (lay.ldlt ? 0 : below + 2 * mm);
  factor.div = mm;
  factor.sqrt = lay.ldlt ? 0 : mm;
  solve.add = below;
  solve.mul = below + mm;
}

// Up to kMaxFixedDenseSchur rows the square layout with m a compile-time
// constant (the schur_square_*_fixed loops: every trip count known), beyond
// the packed layout and runtime loops.
std::string dense_text(const Step3Layout& lay, const OpCount& factor, const OpCount& solve) {
  const int m = lay.m;
  auto call = [&](const char* kernel) {
    return lay.square_W ? fmt::format("jr::schur_square_{}_fixed<{}>(W, Winv, ", kernel, m)
                        : fmt::format("jr::schur_dense_{}(W, Winv, {}, ", kernel, m);
  };
  const char* flag = lay.ldlt ? "true" : "false";
  return call_function(fmt::format("---- Step 3.4 (a): factor W = {} in place (dense, m = {}: the runtime's loops), ----\n"
                                   "with the forward substitution of z_m (into g_zw, elimination order) in the same "
                                   "passes.\n{}",
                                   lay.ldlt ? "L_W D_W L_W^T" : "L_W L_W^T", m, ops_text(factor, true)),
                       "int step34_factor(double* __restrict W, double* __restrict Winv)",
                       {"double pivot = 0.0;",
                        fmt::format("const std::int32_t position = {}kSchurOrder, {}, kPivotTolerance, &pivot, g_zw, "
                                    "g_zm);",
                                    call("factor_forward"), flag),
                        "return position < 0 ? 0 : constraints_singular(kSchurOrder[position], pivot);"}) +
         "\n\n" +
         call_function("---- Step 3.4 (b): backward substitution, lambda into z_m. ----\n" + ops_text(solve),
                       "void step34_solve(const double* __restrict W, const double* __restrict Winv, double* "
                       "__restrict zm)",
                       {fmt::format("{}kSchurOrder, {}, g_zw, zm);", call("backward"), flag)});
}

// The rows of column j's factor that share a column left of the diagonal
// with row r.
std::vector<int> common_left(const SchurPattern& sp, int j, int r) {
  std::vector<int> c;
  std::set_intersection(sp.row_list[j].begin(), sp.row_list[j].end(), sp.row_list[r].begin(), sp.row_list[r].end(),
                        std::back_inserter(c));
  return c;
}

// Column j of L_W L_W^T, as Step 1's eq. (25)-(26).
void column_llt(const Step3Layout& lay, int j, Kernel& k, Kernel::Unit& u) {
  const SchurPattern& sp = lay.sp;
  const std::string in = "  ";
  const std::string diag = lay.W(j, j);
  std::vector<Term> sq;
  for (int i : sp.row_list[j]) sq.push_back({lay.W(j, i), lay.W(j, i)});
  k.update(u, in, "d", diag, sq, "", "const double ", "sd");
  u.lines.push_back(in + pivot_test(diag, fmt::format("constraints_singular({}, d)", sp.order[j]), "kPivotTolerance"));
  u.lines.push_back(in + diag + " = std::sqrt(d);");
  u.statements += 2;
  k.ops.sqrt += 1;
  if (!lay.divide) {
    u.lines.push_back(in + fmt::format("Winv[{}] = 1.0 / {};", j, diag));
    k.ops.div += 1;
  } else {
    u.lines.push_back(in + fmt::format("Winv[{}] = d;  // the pivot itself, for check_digits_W", j));
  }
  ++u.statements;
  for (int r : sp.pattern[j]) {
    std::vector<Term> terms;
    for (int i : common_left(sp, j, r)) terms.push_back({lay.W(j, i), lay.W(r, i)});
    k.update(u, in, lay.W(r, j), lay.W(r, j), terms, lay.pivot_scale(j));
  }
}

// Column j of L_W D_W L_W^T as Step 1's (ldlt_pivot): products
// w_i = W[j,i] D[i], or with --divide an entry W[r,i] kept unscaled
// (L_W D_W) until column r, which divides it by its pivot and needs both
// forms.
void column_ldlt(const Step3Layout& lay, int j, Kernel& k, Kernel::Unit& u) {
  const SchurPattern& sp = lay.sp;
  const bool unscaled = lay.divide;
  LdltPivot pivot;
  for (int i : sp.row_list[j]) {
    pivot.entries.push_back(lay.W(j, i));
    pivot.pivots.push_back(lay.W(i, i));
  }
  pivot.base = pivot.diag = lay.W(j, j);
  pivot.fail = fmt::format("constraints_singular({}, d)", sp.order[j]);
  pivot.inverse = fmt::format("Winv[{}]", j);
  pivot.reciprocal = !lay.divide;
  pivot.check = "check_digits_W";
  pivot.tolerance = "kPivotTolerance";
  const std::vector<std::string> names = ldlt_pivot(k, u, pivot, unscaled);
  std::map<int, std::string> w;  // left column -> its factor
  for (std::size_t n = 0; n < names.size(); ++n) w[sp.row_list[j][n]] = names[n];
  for (int r : sp.pattern[j]) {
    std::vector<Term> terms;
    for (int i : common_left(sp, j, r))
      terms.push_back(unscaled ? Term{lay.W(r, i), w[i]} : Term{w[i], lay.W(r, i)});
    if (unscaled && terms.empty()) continue;  // stays unscaled until column r
    k.update(u, "  ", lay.W(r, j), lay.W(r, j), terms, unscaled ? Scale() : lay.pivot_scale(j));
  }
}

Kernel factor_kernel(const Step3Layout& lay) {
  Kernel k;
  for (int j = 0; j < lay.m; ++j) {
    Kernel::Unit& u = k.unit();
    u.lines.push_back(fmt::format("// column {}: {}", j, row_label(lay.t, lay.row_at(j))));
    u.lines.push_back("{");
    if (lay.ldlt) column_ldlt(lay, j, k, u);
    else column_llt(lay, j, k, u);
    u.lines.push_back("}");
  }
  return k;
}

// W lambda = z_m: forward, then backward substitution, z_m in place.
Kernel solve_kernel(const Step3Layout& lay) {
  const SchurPattern& sp = lay.sp;
  const bool ldlt = lay.ldlt;
  Kernel k;
  for (int j = 0; j < lay.m; ++j) {  // forward
    std::vector<Term> terms;
    for (int i : sp.row_list[j]) terms.push_back({lay.W(j, i), fmt::format("zm[{}]", sp.order[i])});
    if (ldlt && terms.empty()) continue;
    Kernel::Unit& u = k.unit();
    u.lines.push_back(fmt::format("// forward, row {}", j));
    const std::string z = fmt::format("zm[{}]", sp.order[j]);
    k.update(u, "", z, z, terms, ldlt ? Scale() : lay.pivot_scale(j));
  }
  for (int j = lay.m - 1; j >= 0; --j) {  // backward
    std::vector<Term> terms;
    // Farthest rows first: the position solved just before enters last, so
    // the serial chain of the back substitution is one product per row.
    for (auto r = sp.pattern[j].rbegin(); r != sp.pattern[j].rend(); ++r)
      terms.push_back({lay.W(*r, j), fmt::format("zm[{}]", sp.order[*r])});
    Kernel::Unit& u = k.unit();
    u.lines.push_back(fmt::format("// backward, row {}", j));
    const std::string z = fmt::format("zm[{}]", sp.order[j]);
    if (ldlt) {
      (lay.divide ? k.ops.div : k.ops.mul) += 1;
      k.update(u, "", z, z + lay.pivot_scale(j).applied(), terms, "");
    } else {
      k.update(u, "", z, z, terms, lay.pivot_scale(j));
    }
  }
  return k;
}

}  // namespace

std::string check_digits_W(bool inverse, int power, const char* order) {
  return fmt::format(
      "// After Step 3.4 (a): T^T T singular to working precision although every pivot\n"
      "// passed its own test (kSpreadLimit); names the loop joint and row of the\n"
      "// smallest pivot and gives d_min / d_max.\n"
      "int check_digits_W(const double* Winv) {{\n"
      "  double ratio = 0.0;\n"
      "  const std::int32_t j = jr::pivot_spread(Winv, nc, {}, {}, kSpreadLimit, &ratio);\n"
      "  if (j < 0) return kSuccess;\n"
      "  return fail_row(kConstraintsSingular,\n"
      "                  \"constraint rows singular to working precision (smallest pivot of T^T T below 1e-13 \"\n"
      "                  \"of the largest)\",\n"
      "                  {}[j], ratio);\n"
      "}}",
      inverse ? "true" : "false", power, order);
}

StepCode step34(const Step3Layout& lay) {
  const char* factored = lay.ldlt ? "L_W D_W L_W^T" : "L_W L_W^T";
  StepCode out;
  if (lay.dense_schur()) {
    OpCount factor, solve;
    dense_ops(lay, factor, solve);
    out.text = dense_text(lay, factor, solve);
    out.ops = factor;
    out.ops += solve;
  } else {
    const Kernel f = factor_kernel(lay), s = solve_kernel(lay);
    out.text = f.functions("step34_factor", "double* W, double* Winv", "W, Winv", true,
                           fmt::format("---- Step 3.4 (a): factor W = {} in place, unrolled, fill included. ----\n{}",
                                       factored, ops_text(f.ops, true))) +
               "\n\n" +
               s.functions("step34_solve", "const double* W, const double* Winv, double* zm", "W, Winv, zm", false,
                           "---- Step 3.4 (b): solve W lambda = z_m in place. ----\n" + ops_text(s.ops));
    out.ops = f.ops;
    out.ops += s.ops;
  }
  // The dense kernels leave 1 / d (L D L^T) or 1 / l (L L^T) in Winv, as the
  // straight-line factor does without --divide; with it, the pivots d.
  const bool inverse = lay.dense_schur() || !lay.divide;
  out.text += "\n\n" + check_digits_W(inverse, inverse ? (lay.ldlt ? 1 : 2) : 1, "kSchurOrder");
  return out;
}

}  // namespace jrgen::emit
