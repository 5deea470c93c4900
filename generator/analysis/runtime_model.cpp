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

namespace {
jr::CutKind cut_kind(ir::CutType type) {
  switch (type) {
    case ir::CutType::Spherical: return jr::CutKind::kSpherical;
    case ir::CutType::Revolute: return jr::CutKind::kRevolute;
    case ir::CutType::Prismatic: return jr::CutKind::kPrismatic;
    case ir::CutType::Cylindrical: return jr::CutKind::kCylindrical;
    case ir::CutType::Universal: return jr::CutKind::kUniversal;
    case ir::CutType::Fixed: return jr::CutKind::kFixed;
    case ir::CutType::Distance: return jr::CutKind::kDistance;
    case ir::CutType::Mimic: return jr::CutKind::kMimic;
  }
  return jr::CutKind::kSpherical;
}

void copy_pose(const ir::Pose& X, double* R, double* p) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R[3 * r + c] = X.R(r, c);
  copy3(X.p, p);
}
}  // namespace

std::vector<jr::CutModel> cut_models(const topology::Tree& tree) {
  std::vector<jr::CutModel> out;
  std::int32_t first_row = 0, phiq_start = 0;
  for (const topology::Cut& c : tree.cuts) {
    jr::CutModel cm{};
    cm.name = c.name.c_str();
    cm.kind = cut_kind(c.type);
    cm.body_k = c.body_k;
    cm.body_l = c.body_l;
    copy_pose(c.X_BkF, cm.R_k, cm.p_k);
    copy_pose(c.X_BlF, cm.R_l, cm.p_l);
    copy3(c.axis, cm.axis);
    copy3(c.child_axis, cm.child_axis);
    cm.distance = c.distance;
    if (c.type == ir::CutType::Mimic) {  // runtime.hpp, CutKind: m in axis[0], o in distance
      cm.axis[0] = c.multiplier;
      cm.axis[1] = cm.axis[2] = 0.0;
      cm.distance = c.offset;
    }
    for (int r : c.kept_rows) cm.row_mask |= 1 << r;
    cm.first_row = first_row;
    cm.phiq_start = phiq_start;
    cm.num_dofs = static_cast<std::int32_t>(c.dofs.size());
    first_row += static_cast<std::int32_t>(c.kept_rows.size());
    phiq_start += static_cast<std::int32_t>(c.kept_rows.size() * c.dofs.size());
    out.push_back(cm);
  }
  return out;
}

std::vector<jr::SpringModel> spring_models(const topology::Tree& tree) {
  std::vector<jr::SpringModel> out;
  for (const topology::Spring& s : tree.springs) {
    jr::SpringModel sm{};
    sm.name = s.name.c_str();
    sm.body_k = s.body_k;
    sm.body_l = s.body_l;
    copy3(s.p_k, sm.p_k);
    copy3(s.p_l, sm.p_l);
    sm.stiffness = s.stiffness;
    sm.damping = s.damping;
    sm.rest_length = s.rest_length;
    out.push_back(sm);
  }
  return out;
}

std::vector<jr::JointForceModel> joint_force_models(const topology::Tree& tree) {
  std::vector<jr::JointForceModel> out;
  for (std::size_t i = 0; i < tree.bodies.size(); ++i) {
    const topology::Body& b = tree.bodies[i];
    if (b.stiffness != 0.0 || b.force != 0.0)
      out.push_back({static_cast<std::int32_t>(i), b.stiffness, b.rest, b.force});
  }
  return out;
}

RuntimeModel::RuntimeModel(const topology::Tree& tree, const Eigen::Vector3d& gravity)
    : dof_parent_(tree.dof_parent.begin(), tree.dof_parent.end()),
      dof_user_(tree.dof_user.begin(), tree.dof_user.end()),
      col_start_(tree.M_col_start.begin(), tree.M_col_start.end()),
      cuts_(cut_models(tree)),
      springs_(spring_models(tree)),
      joint_forces_(joint_force_models(tree)),
      workspace_(new jr::BodyState[tree.bodies.size()]),
      motion_(new jr::BodyMotion[tree.bodies.size()]) {
  for (const topology::Body& b : tree.bodies) bodies_.push_back(body_model(b));
  model_.nb = static_cast<std::int32_t>(bodies_.size());
  model_.nq = tree.nq;
  model_.nv = tree.nv;
  model_.bodies = bodies_.data();
  model_.dof_parent = dof_parent_.data();
  model_.dof_user = dof_user_.data();
  model_.M_col_start = col_start_.data();
  for (int k = 0; k < 3; ++k) model_.gravity[k] = gravity[k];
  constraints_.ncuts = static_cast<std::int32_t>(cuts_.size());
  constraints_.nc = tree.nc();
  constraints_.phiq_nnz = 0;
  for (const jr::CutModel& c : cuts_) {
    int kept = 0;
    for (int r = 0; r < 6; ++r) kept += c.row_mask >> r & 1;
    constraints_.phiq_nnz += kept * c.num_dofs;
  }
  constraints_.cuts = cuts_.data();
  forces_ = {static_cast<std::int32_t>(springs_.size()), springs_.data(),
             static_cast<std::int32_t>(joint_forces_.size()), joint_forces_.data()};
}

}  // namespace jrgen::analysis
