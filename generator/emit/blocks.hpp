// The units emit_solver() calls besides the steps (internal to the emit
// stage; generator/emit/README.md maps every unit to what it emits).
#pragma once

#include <string>

#include "emit/emitter.hpp"
#include "emit/plan.hpp"
#include "emit/template.hpp"
#include "topology/topology.hpp"

namespace jrgen::emit {

/// The constant tables of the model and the picture of L's pattern:
/// template values pattern, joint_names, joint_q_index, joint_v_index,
/// bodies, dof_parent, dof_user, col_start, dof_joint, model_init
/// (emit/model_tables.cpp).
void model_tables(const topology::Tree& t, const Options& options, TemplateValues& v);

/// solve_augmented's gathers of Q and M and the scatter of qdd (template
/// value gather; the closed loops add gather_Phiq) (emit/gathers.cpp).
std::string gathers(const topology::Tree& t, const Plan& plan);

}  // namespace jrgen::emit
