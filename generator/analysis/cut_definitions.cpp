#include "analysis/cut_definitions.hpp"

#include "analysis/runtime_model.hpp"

namespace jrgen::analysis {

namespace {

// World orientation of a cut's frame on `body` (-1: the fixed base).
Eigen::Matrix3d world_rotation(const jr::BodyState* bodies, int body, const ir::Pose& X_BF) {
  return body < 0 ? X_BF.R : Eigen::Matrix3d(bodies[body].R_WC * X_BF.R);
}

}  // namespace

int cut_against_definition(const topology::Tree& tree, RuntimeModel& rt, const Eigen::VectorXd& q) {
  jr::kinematics(rt.model(), rt.workspace(), q.data());
  jr::world_poses(rt.model(), rt.workspace());
  for (int c = 0; c < static_cast<int>(tree.cuts.size()); ++c) {
    const topology::Cut& cut = tree.cuts[c];
    const Eigen::Matrix3d R_WK = world_rotation(rt.workspace(), cut.body_k, cut.X_BkF);
    const Eigen::Matrix3d R_WL = world_rotation(rt.workspace(), cut.body_l, cut.X_BlF);
    const bool aligned_axis = cut.type == ir::CutType::Revolute || cut.type == ir::CutType::Prismatic ||
                              cut.type == ir::CutType::Cylindrical;
    const bool same_orientation = cut.type == ir::CutType::Prismatic || cut.type == ir::CutType::Fixed;
    // Rows at zero leave the axis parallel or antiparallel: the sign decides.
    if (aligned_axis && !((R_WK * cut.axis).dot(R_WL * cut.axis) > 0.0)) return c;
    // Rows at zero leave R_KL = I or a half turn (trace 3 or -1): trace 1 is 90 degrees.
    if (same_orientation && !((R_WK.transpose() * R_WL).trace() > 1.0)) return c;
  }
  return -1;
}

}  // namespace jrgen::analysis
