#include "emit/report.hpp"
#include "emit/terms.hpp"

#include <fmt/format.h>

#include <array>

namespace jrgen::emit {

namespace {

// The whole call: which route forward_dynamics takes and the operations of
// its specialized blocks (issue 20, item 4).
std::string forward_dynamics_section(const Solver& solver) {
  std::string out = "\n## forward_dynamics\n\n" + solver.route + ".\n";
  if (solver.terms_ops.empty()) return out;
  out += "\nOperations of its specialized terms per block, counted as emitted: additions\n"
         "(A), multiplications (M), divisions (D), square roots (SQ), sines and cosines\n"
         "(T).  \"Unfolded\" counts the same program with nothing known at generation\n"
         "time folded (x * 0, x * 1, x + 0 kept: zero axis entries, identity rotations,\n"
         "zero offsets, zero gravity); the difference is what specialization removed.\n\n"
         "| block | A | M | D | SQ | T | total | unfolded | removed |\n"
         "|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  OpCount total, unfolded_total;
  for (std::size_t k = 0; k < solver.terms_ops.size(); ++k) {
    const auto& [name, c] = solver.terms_ops[k];
    const OpCount u = k < solver.terms_unfolded_ops.size() ? solver.terms_unfolded_ops[k].second : OpCount{};
    out += fmt::format("| {} | {} | {} | {} | {} | {} | {} | {} | {:.0f} % |\n", name, c.add, c.mul, c.div, c.sqrt,
                       c.trig, flops(c), flops(u), flops(u) ? 100.0 * (1.0 - double(flops(c)) / double(flops(u))) : 0.0);
    total += c;
    unfolded_total += u;
  }
  out += fmt::format("| total | {} | {} | {} | {} | {} | {} | {} | {:.0f} % |\n", total.add, total.mul, total.div,
                     total.sqrt, total.trig, flops(total), flops(unfolded_total),
                     flops(unfolded_total) ? 100.0 * (1.0 - double(flops(total)) / double(flops(unfolded_total))) : 0.0);
  if (!solver.fd_runs_steps) return out + "\nThe whole call is this program (no factorization of M).\n";
  OpCount steps;
  for (const StepOps& s : solver.ops) steps += s.ops;
  out += fmt::format("\nThe whole call: these terms, {} operations, then Steps 1-4 above, {}: {} in all.\n",
                     flops(total), flops(steps), flops(total) + flops(steps));
  return out;
}

}  // namespace

std::string operation_report(const ir::Robot& robot, const topology::Tree& tree, const Solver& solver) {
  static const std::array<const char*, 8> kSteps = {"1", "2", "3.1", "3.2", "3.3", "3.4", "3.5", "4"};
  std::array<OpCount, 8> per_step{};
  OpCount total;
  for (const StepOps& s : solver.ops)
    for (std::size_t k = 0; k < kSteps.size(); ++k)
      if (s.step == kSteps[k]) {
        per_step[k] += s.ops;
        total += s.ops;
      }
  std::string out = fmt::format("# Operation counts: {}\n\n", robot.name);
  out += fmt::format("nq = {}, nv = {}, bodies = {}, stored entries of L = {}.\n\n", tree.nq, tree.nv,
                     tree.bodies.size(), tree.nnz());
  out += "Additions (A, subtractions included), multiplications (M), divisions (D)\n"
         "and square roots (SQ) in the emitted code of each step of Section 4.3,\n"
         "counted as written (Step 0 and index permutations cost none).\n\n";
  out += "| |";
  for (const char* s : kSteps) out += fmt::format(" {} |", s);
  out += " Total |\n|---|";
  for (std::size_t k = 0; k <= kSteps.size(); ++k) out += "---:|";
  out += "\n";
  auto row = [&](const char* label, long long OpCount::*field) {
    out += fmt::format("| {} |", label);
    for (const OpCount& c : per_step) out += fmt::format(" {} |", c.*field);
    out += fmt::format(" {} |\n", total.*field);
  };
  row("A", &OpCount::add);
  row("M", &OpCount::mul);
  row("D", &OpCount::div);
  row("SQ", &OpCount::sqrt);

  // The paper's counts for its HMMWV 14-body model (Section 6), for scale.
  out += "\n## Reference: the paper's HMMWV 14-body model\n\n"
         "Negrut, Serban & Potra (1997), Section 6: 27 coordinates, 16 constraint rows.\n\n"
         "Table 1, *Gauss* (LU of the 43 x 43 augmented matrix):\n\n"
         "| | Fact | FS | BS | Total |\n|---|---:|---:|---:|---:|\n"
         "| A | 25585 | 903 | 903 | 27391 |\n| M | 25585 | 903 | 903 | 27391 |\n"
         "| D | 903 | 0 | 43 | 946 |\n| SQ | 0 | 0 | 0 | 0 |\n\n"
         "Table 2, *Alg-S* (the same algorithm, loops over topology tables):\n\n"
         "| | 1 | 2 | 3.1 | 3.2 | 3.3 | 3.4 | 3.5 | 4 | Total |\n"
         "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n"
         "| A | 975 | 165 | 708 | 172 | 834 | 680 | 145 | 192 | 3871 |\n"
         "| M | 975 | 165 | 804 | 172 | 1135 | 680 | 162 | 165 | 4258 |\n"
         "| D | 165 | 27 | 174 | 0 | 0 | 120 | 0 | 27 | 513 |\n"
         "| SQ | 27 | 0 | 0 | 0 | 0 | 16 | 0 | 0 | 43 |\n\n";
  out += solver.divide
             ? "This code was emitted with --divide: where the paper divides (each entry of\n"
               "L by its pivot), so does the straight-line code; steps that run the\n"
               "runtime's loops multiply by one reciprocal per pivot instead (jrgen's notes\n"
               "name them).  Step 3.4 here also counts the two triangular solves for lambda,\n"
               "which Table 2 leaves out (its 680 additions are the factorization alone).\n"
               "The default arithmetic, without --divide, is described below.\n\n"
             : "";
  out += "Where the paper divides (each entry of L by its pivot), the emitted code\n"
         "multiplies by one reciprocal per pivot, so some of the paper's D appear here\n"
         "as M; Step 3.4 here also counts the two triangular solves for lambda, which\n"
         "Table 2 leaves out (its 680 additions are the factorization alone).  A dense\n"
         "Step 3.4 (every row reaching a common dof, as the HMMWV's chassis) factors in\n"
         "the order of L D L^T, one product w / d per entry, and L L^T then scales each\n"
         "column by 1 / sqrt(d): one more product per entry, for a shorter serial chain\n"
         "from one pivot to the next; the forward substitution for lambda rides along\n"
         "(one more product per pivot; docs/benchmarks.md, run 7).  The straight-line\n"
         "L L^T Step 1 takes 1 / L[j,j] as sqrt(d) * (1 / d), one more product per\n"
         "column, so that the square root and the division run side by side (run 8).\n";
  if (tree.nv == 27 && tree.nc() == 16) {
    const long long alg_s[4] = {3871, 4258, 513, 43};
    const long long ours[4] = {total.add, total.mul, total.div, total.sqrt};
    const char* labels[4] = {"A", "M", "D", "SQ"};
    out += "\nThis model has the paper's dimensions; totals against *Alg-S*:\n\n"
           "| | this code | Alg-S | ratio |\n|---|---:|---:|---:|\n";
    for (int k = 0; k < 4; ++k)
      out += fmt::format("| {} | {} | {} | {:.2f} |\n", labels[k], ours[k], alg_s[k],
                         static_cast<double>(ours[k]) / static_cast<double>(alg_s[k]));
    out += fmt::format("| M + D | {} | {} | {:.2f} |\n", total.mul + total.div, 4258 + 513,
                       static_cast<double>(total.mul + total.div) / (4258.0 + 513.0));
  }
  out += forward_dynamics_section(solver);
  return out;
}

}  // namespace jrgen::emit
