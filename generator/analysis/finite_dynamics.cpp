#include "analysis/finite_dynamics.hpp"

#include <cmath>
#include <vector>

#include "analysis/constraints.hpp"
#include "analysis/runtime_model.hpp"
#include "ir/error.hpp"

namespace jrgen::analysis {

void check_finite_dynamics(const ir::Robot& robot, const topology::Tree& tree, const Eigen::Vector3d& gravity) {
  RuntimeModel rt(tree, gravity);
  const Eigen::VectorXd q0 = neutral_configuration(tree);
  const std::vector<double> v(tree.nv, 0.0);
  std::vector<double> Mp(tree.M_col_start[tree.nv]), h(tree.nv);
  jr::kinematics(rt.model(), rt.workspace(), q0.data());
  jr::mass_matrix_packed(rt.model(), rt.workspace(), Mp.data());
  jr::bias_forces(rt.model(), rt.workspace(), v.data(), h.data(), gravity != Eigen::Vector3d::Zero(), false);
  for (int d = 0; d < tree.nv; ++d) {  // Lemma 2 order: descendants first, so the first hit is deepest
    const char* what = !std::isfinite(Mp[tree.M_col_start[d]])
                           ? "its diagonal entry of the mass matrix (inertias plus masses x distances^2 of the "
                             "links it moves)"
                       : !std::isfinite(h[d]) ? "its generalized gravity force (masses x gravity x distances)"
                                              : nullptr;
    if (what == nullptr) continue;
    const ir::Joint& joint = robot.joints[tree.bodies[tree.dof_body[d]].joint_ir];
    throw Error(joint.where, "joint", joint.name,
                std::string(what) +
                    " overflows double precision at the zero configuration; check the <mass>, <inertia> and "
                    "<origin> of the links it moves (SI units)");
  }
}

}  // namespace jrgen::analysis
