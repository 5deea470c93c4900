// Steps 1, 2 and 4 of the algorithm of Section 4.3 (internal to the emit
// stage): the factorization M = L L^T or L D L^T (Step 1, eq. 25-26), the
// forward (Step 2) and the backward substitution (Step 4), in the shape the
// Plan chose.  Each writes the template value of its step and counts its
// operations (--report).
#pragma once

#include <string>
#include <vector>

#include "emit/emitter.hpp"
#include "emit/plan.hpp"
#include "topology/topology.hpp"

namespace jrgen::emit {

/// The template values step1, step2, step4 and the operations of each.
struct Steps124 {
  std::string step1, step2, step4;
  OpCount ops1, ops2, ops4;
};

// Straight-line shape (Shape::kUnrolled): one unit per step.  `desc` holds
// each dof's descendants (topology::Tree::descendants()).
std::string step1_unrolled(const topology::Tree& t, const Plan& plan, const std::vector<std::vector<int>>& desc,
                           OpCount& ops);                                  // steps/step1.cpp
std::string step2_unrolled(const topology::Tree& t, const Plan& plan, const std::vector<std::vector<int>>& desc,
                           OpCount& ops);                                  // steps/step2.cpp
std::string step4_unrolled(const topology::Tree& t, const Plan& plan, OpCount& ops);  // steps/step4.cpp

/// "M = L L^T" or "M = L D L^T, D on the diagonal of L" (steps/step1.cpp).
std::string factor_note(const Plan& plan);

/// Step 1 for solve_augmented when it has no straight-line copy reading the
/// dense M (Plan::fused false): gather M, then factor (steps/step1.cpp).
std::string step1_gather_then_factor();

/// The operations of the runtime's loops on the packed layout (the shapes
/// other than kUnrolled), in the Steps124 counts (steps/table_steps.cpp).
Steps124 runtime_loop_ops(const topology::Tree& t, const Plan& plan);

// The shapes that call the runtime's loops: fill step1, step2, step4 of `s`,
// whose counts runtime_loop_ops() set.
void table_steps(const topology::Tree& t, const Plan& plan, Steps124& s);       // steps/table_steps.cpp
void supernodal_steps(const topology::Tree& t, const Plan& plan, Steps124& s);  // steps/supernodal_steps.cpp
void parallel_steps(const topology::Tree& t, const Plan& plan, Steps124& out);  // steps/parallel_steps.cpp

}  // namespace jrgen::emit
