#include "emit/report.hpp"

#include <fmt/format.h>

#include <array>

namespace jrgen::emit {

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
  return out;
}

}  // namespace jrgen::emit
