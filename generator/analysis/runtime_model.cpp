#include "analysis/runtime_model.hpp"

namespace jrgen::analysis {

namespace {
jr::JointKind kind_of(ir::JointType type) {
  switch (type) {
    case ir::JointType::Prismatic: return jr::JointKind::kPrismatic;
    case ir::JointType::Ball: return jr::JointKind::kBall;
    case ir::JointType::Floating: return jr::JointKind::kFloating;
    case ir::JointType::Planar: return jr::JointKind::kPlanar;
    default: return jr::JointKind::kRevolute;
  }
}

void copy3(const Eigen::Vector3d& v, double* out) {
  for (int k = 0; k < 3; ++k) out[k] = v[k];
}
}  // namespace

jr::BodyModel body_model(const topology::Body& body) {
  jr::BodyModel bm{};
  bm.joint_name = body.joint_name.c_str();
  bm.kind = kind_of(body.type);
  bm.parent = body.parent_lem;
  bm.q_user = body.q_user;
  bm.v_user = body.v_user;
  bm.v_lem = body.v_lem;
  bm.nv = body.nv;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) bm.R_PJ[3 * r + c] = body.X_PJ.R(r, c);
  copy3(body.X_PJ.p, bm.p_PJ);
  copy3(body.axis, bm.axis);
  copy3(body.e1, bm.e1);
  copy3(body.e2, bm.e2);
  bm.mass = body.inertial.mass;
  copy3(body.inertial.com, bm.com);
  const Eigen::Matrix3d& I = body.inertial.I_com;
  const double inertia[6] = {I(0, 0), I(1, 1), I(2, 2), I(0, 1), I(0, 2), I(1, 2)};
  for (int k = 0; k < 6; ++k) bm.I_com[k] = inertia[k];
  bm.damping = body.damping;
  return bm;
}

RuntimeModel::RuntimeModel(const topology::Tree& tree, const Eigen::Vector3d& gravity)
    : dof_parent_(tree.dof_parent.begin(), tree.dof_parent.end()),
      dof_user_(tree.dof_user.begin(), tree.dof_user.end()),
      col_start_(tree.M_col_start.begin(), tree.M_col_start.end()),
      workspace_(new jr::BodyState[tree.bodies.size()]) {
  for (const topology::Body& b : tree.bodies) bodies_.push_back(body_model(b));
  model_.nb = static_cast<std::int32_t>(bodies_.size());
  model_.nq = tree.nq;
  model_.nv = tree.nv;
  model_.bodies = bodies_.data();
  model_.dof_parent = dof_parent_.data();
  model_.dof_user = dof_user_.data();
  model_.M_col_start = col_start_.data();
  for (int k = 0; k < 3; ++k) model_.gravity[k] = gravity[k];
}

}  // namespace jrgen::analysis
