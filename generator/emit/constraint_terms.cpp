#include "emit/constraint_terms.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <map>

#include "emit/format.hpp"

namespace jrgen::emit {

namespace {

// A placement X_FB (B coordinates into F coordinates): x_F = R x_B + p.
struct Pose {
  Mat3 R;
  Vec3 p;
};

Pose constant_pose(const ir::Pose& X) { return {mat3(X.R), vec3(X.p)}; }

Pose compose(const Pose& a, const Pose& b) { return {mul(a.R, b.R), a.p + mul(a.R, b.p)}; }

// X_FC from X_FP and the joint transform X_PC of body C (one step down).
Pose down(const Pose& X_FP, const BodyFrame& C) { return compose(X_FP, {C.R, C.p}); }

// X_FP from X_FC and X_PC (one step up): R_FP = R_FC R_PC^T, p_FP = p_FC - R_FP p_PC.
Pose up(const Pose& X_FC, const BodyFrame& C) {
  const Mat3 R = mul(X_FC.R, transpose(C.R));
  return {R, X_FC.p - mul(R, C.p)};
}

// The inverse of a constant placement, computed at generation time.
Pose constant_inverse(const ir::Pose& X) {
  ir::Pose inv;
  inv.R = X.R.transpose();
  inv.p = -(inv.R * X.p);
  return constant_pose(inv);
}

// Bodies from `body` up to the lowest common ancestor with `other`
// (exclusive), and that ancestor (-1: the fixed base).  Parents have larger
// Lemma 2 indices; the base counts as the largest.
std::vector<int> path_to_common(const topology::Tree& tree, int body, int other, int& common) {
  const auto rank = [&](int b) { return b < 0 ? static_cast<int>(tree.bodies.size()) : b; };
  int a = body, b = other;
  while (a != b) {
    if (rank(a) < rank(b)) a = tree.bodies[a].parent_lem;
    else b = tree.bodies[b].parent_lem;
  }
  common = a;
  std::vector<int> path;
  for (int x = body; x != common; x = tree.bodies[x].parent_lem) path.push_back(x);
  return path;
}

// Placements in Fk coordinates of every body on the cut's two paths, of their
// common ancestor (key -1 for the fixed base) and of Fl (returned): up from
// Fk to the common ancestor, then down to l.
struct CutFrames {
  std::map<int, Pose> body;  // X_{Fk, body}
  std::vector<int> k_path, l_path;
  Pose Fl;                   // X_{Fk, Fl}
};

CutFrames cut_frames(const topology::Tree& tree, const topology::Cut& cut, const std::vector<BodyFrame>& frames) {
  CutFrames f;
  int common = -1;
  f.k_path = path_to_common(tree, cut.body_k, cut.body_l, common);
  f.l_path = path_to_common(tree, cut.body_l, cut.body_k, common);
  Pose X = constant_inverse(cut.X_BkF);  // X_{Fk, k}
  int at = cut.body_k;
  for (int b : f.k_path) {
    f.body[b] = X;
    X = up(X, frames[b]);
    at = tree.bodies[b].parent_lem;
  }
  f.body[at] = X;  // the common ancestor (at == common)
  for (auto it = f.l_path.rbegin(); it != f.l_path.rend(); ++it) {
    X = down(X, frames[*it]);
    f.body[*it] = X;
  }
  f.Fl = compose(X, constant_pose(cut.X_BlF));
  return f;
}

// Twist (w, v at the body origin o) of one dof in Fk coordinates: the
// runtime's world twist R_WC S (runtime.cpp, evaluate_cuts) with Fk in place
// of the world.  The translations of floating and planar joints are along a
// direction e of the joint frame J (S = R_J^T e in C), so
// R_FC S = R_FP R_PJ R_J R_J^T e = R_FP R_PJ e: the product R_J R_J^T, which
// the Program cannot see is the identity, is left out.
struct Twist {
  Vec3 w, v, o;
};

Twist dof_twist(const topology::Tree& tree, const std::vector<BodyFrame>& frames, const CutFrames& f, int dof) {
  const int J = tree.dof_body[dof];
  const topology::Body& b = tree.bodies[J];
  const int col = dof - b.v_lem;
  const Pose& X = f.body.at(J);
  const bool floating_linear = b.type == ir::JointType::Floating && col < 3;
  const bool planar_linear = b.type == ir::JointType::Planar && col < 2;
  if (floating_linear || planar_linear) {
    const Pose& XP = f.body.at(b.parent_lem);
    const Eigen::Vector3d e = floating_linear ? Eigen::Vector3d::Unit(col).eval() : (col == 0 ? b.e1 : b.e2);
    const Eigen::Vector3d e_P = b.X_PJ.R * e;
    return {{0.0, 0.0, 0.0}, mul(XP.R, vec3(e_P)), X.p};
  }
  const Motion6& S = frames[J].S[static_cast<std::size_t>(col)];
  return {mul(X.R, angular(S)), mul(X.R, linear(S)), X.p};
}

// One scalar row in Fk coordinates (runtime.cpp, "Cut joints", (g) and (h)):
// a point or distance row's Jacobian entry is e . g with g the velocity at
// P_l given by the dof, signed (-1 on k's path, +1 on l's); a dot row a . b
// has (a x b) . w_j on k's path and -(a x b) . w_j on l's.
struct Row {
  bool point = true;
  Vec3 coef;  // e (point, distance) or a x b (dot)
  Value phi, gamma;
};

// Absolute motion of the cut frame on `body` (offset p_BF in body
// coordinates), in Fk coordinates: w, alpha, and the velocity and
// acceleration of the frame origin.
struct FrameMotion {
  Vec3 w, alpha, v, a;
};

FrameMotion frame_motion(int body, const Eigen::Vector3d& p_BF, const Mat3& R_FkB,
                         const std::vector<BodyMotion6>& motion) {
  if (body < 0 || motion.empty()) return {{0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}};
  const BodyMotion6& m = motion[static_cast<std::size_t>(body)];
  const Vec3 w = angular(m.v), vo = linear(m.v), alpha = angular(m.a);
  const Vec3 r = vec3(p_BF);
  const Vec3 wr = cross(w, r);
  // Classical acceleration of the origin (a_lin + w x v_o), then of the point.
  const Vec3 a_point = linear(m.a) + cross(w, vo) + cross(alpha, r) + cross(w, wr);
  return {mul(R_FkB, w), mul(R_FkB, alpha), mul(R_FkB, vo + wr), mul(R_FkB, a_point)};
}

// gamma = -Phi_ddot at qdd = 0 for a direction e fixed on a frame moving with
// angular velocity w and acceleration alpha: e_d = w x e, e_dd = alpha x e + w x (w x e).
void derivatives(const Vec3& e, const FrameMotion& m, Vec3& ed, Vec3& edd) {
  ed = cross(m.w, e);
  edd = cross(m.alpha, e) + cross(m.w, ed);
}

Row point_row(const Eigen::Vector3d& e_k, const Vec3& r, const FrameMotion& k, const FrameMotion& l) {
  const Vec3 e = vec3(e_k);
  Row row{true, e, dot(e, r), 0.0};
  Vec3 ed, edd;
  derivatives(e, k, ed, edd);
  row.gamma = -(dot(edd, r) + 2.0 * dot(ed, l.v - k.v) + dot(e, l.a - k.a));
  return row;
}

Row dot_row(const Eigen::Vector3d& a_k, const Vec3& b, const FrameMotion& k, const FrameMotion& l) {
  const Vec3 a = vec3(a_k);
  Row row{false, cross(a, b), dot(a, b), 0.0};
  Vec3 ad, add, bd, bdd;
  derivatives(a, k, ad, add);
  derivatives(b, l, bd, bdd);
  row.gamma = -(dot(add, b) + 2.0 * dot(ad, bd) + dot(a, bdd));
  return row;
}

Row distance_row(double D, const Vec3& r, const FrameMotion& k, const FrameMotion& l) {
  const Vec3 rd = l.v - k.v, rdd = l.a - k.a;
  Row row{true, (1.0 / D) * r, (dot(r, r) - D * D) / (2.0 * D), 0.0};
  row.gamma = -(dot(rd, rd) + dot(r, rdd)) / D;
  return row;
}

// u, w completing the unit axis to a right-handed orthonormal basis, by the
// runtime's rule (runtime.cpp, complete_basis), at generation time.
void complete_basis(const Eigen::Vector3d& axis, Eigen::Vector3d& u, Eigen::Vector3d& w) {
  const Eigen::Vector3d helper = std::abs(axis.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  u = (helper - helper.dot(axis) * axis).normalized();
  w = axis.cross(u);
}

// Every row of the cut in the order of runtime.hpp ("Rows per type"), with
// Fk at the origin of its own coordinates.
std::vector<Row> cut_rows(const topology::Cut& cut, const Pose& Fl, const FrameMotion& k, const FrameMotion& l) {
  const Eigen::Vector3d ex = Eigen::Vector3d::UnitX(), ey = Eigen::Vector3d::UnitY(), ez = Eigen::Vector3d::UnitZ();
  const Vec3& r = Fl.p;
  const auto column = [&](int c) { return Vec3{Fl.R[c], Fl.R[3 + c], Fl.R[6 + c]}; };
  Eigen::Vector3d u, w;
  complete_basis(cut.axis, u, w);
  const Vec3 axis_l = mul(Fl.R, vec3(cut.axis));
  std::vector<Row> rows;
  const auto points_xyz = [&] {
    for (const Eigen::Vector3d& e : {ex, ey, ez}) rows.push_back(point_row(e, r, k, l));
  };
  const auto orientation = [&] {
    rows.push_back(dot_row(ey, column(2), k, l));
    rows.push_back(dot_row(ez, column(0), k, l));
    rows.push_back(dot_row(ex, column(1), k, l));
  };
  const auto axis_aligned = [&] {
    rows.push_back(dot_row(u, axis_l, k, l));
    rows.push_back(dot_row(w, axis_l, k, l));
  };
  const auto across_axis = [&] {
    rows.push_back(point_row(u, r, k, l));
    rows.push_back(point_row(w, r, k, l));
  };
  switch (cut.type) {
    case ir::CutType::Spherical: points_xyz(); break;
    case ir::CutType::Revolute: points_xyz(); axis_aligned(); break;
    case ir::CutType::Prismatic: orientation(); across_axis(); break;
    case ir::CutType::Cylindrical: axis_aligned(); across_axis(); break;
    case ir::CutType::Universal:
      points_xyz();
      rows.push_back(dot_row(cut.axis, mul(Fl.R, vec3(cut.child_axis)), k, l));
      break;
    case ir::CutType::Fixed: points_xyz(); orientation(); break;
    case ir::CutType::Distance: rows.push_back(distance_row(cut.distance, r, k, l)); break;
    case ir::CutType::Mimic: break;  // not a frame constraint: mimic_row
  }
  return rows;
}

// A mimic row (runtime.hpp, CutKind::kMimic): Phi = q_l - m q_k - o, the
// Jacobian 1 and -m at the two joints' dofs (0 at every other dof of the
// cut's list), gamma = 0; kept rows written as constraint_terms does.
void mimic_row(Program& P, const topology::Tree& tree, const topology::Cut& cut, bool gamma, ConstraintValues& out,
               Value* phiq) {
  const topology::Body& l = tree.bodies[static_cast<std::size_t>(cut.body_l)];
  const topology::Body& k = tree.bodies[static_cast<std::size_t>(cut.body_k)];
  for (std::size_t kept = 0; kept < cut.kept_rows.size(); ++kept) {
    out.phi.push_back(P.input(fmt::format("q[{}]", l.q_user)) - cut.multiplier * P.input(fmt::format("q[{}]", k.q_user)) -
                      cut.offset);
    if (gamma) out.gamma.push_back(0.0);
    for (std::size_t index = 0; index < cut.dofs.size(); ++index) {
      const int dof = cut.dofs[index];
      phiq[kept * cut.dofs.size() + index] = dof == l.v_lem ? Value(1.0) : dof == k.v_lem ? Value(-cut.multiplier) : Value(0.0);
    }
  }
}

// The Jacobian entries of the kept rows of one cut at its distinct dofs,
// eq. (h) of runtime.cpp in Fk coordinates (P_k = 0).
void jacobian_entries(const topology::Tree& tree, const topology::Cut& cut, const std::vector<BodyFrame>& frames,
                      const CutFrames& f, const std::vector<Row>& rows, Value* out) {
  const std::size_t num_dofs = cut.dofs.size();
  for (int index = 0; index < cut.num_distinct; ++index) {
    const int dof = cut.dofs[static_cast<std::size_t>(index)];
    const bool on_k = std::find(f.k_path.begin(), f.k_path.end(), tree.dof_body[dof]) != f.k_path.end();
    const Twist t = dof_twist(tree, frames, f, dof);
    // g = -/+ (w_j x (P_l - o_j) + v_j): the signed velocity of the point at P_l.
    const Vec3 g = on_k ? cross(t.w, t.o - f.Fl.p) - t.v : cross(t.w, f.Fl.p - t.o) + t.v;
    for (std::size_t kept = 0; kept < cut.kept_rows.size(); ++kept) {
      const Row& row = rows[static_cast<std::size_t>(cut.kept_rows[kept])];
      const Value e = row.point ? dot(row.coef, g) : (on_k ? dot(row.coef, t.w) : -dot(row.coef, t.w));
      out[kept * num_dofs + static_cast<std::size_t>(index)] = e;
    }
  }
}

}  // namespace

ConstraintValues constraint_terms(Program& program, const topology::Tree& tree, const std::vector<BodyFrame>& frames,
                                  const std::vector<BodyMotion6>& motion) {
  ConstraintValues out;
  std::size_t nnz = 0;
  for (const topology::Cut& cut : tree.cuts) nnz += cut.kept_rows.size() * cut.dofs.size();
  out.phiq_packed.assign(nnz, Value(0.0));
  std::size_t phiq_start = 0;
  for (const topology::Cut& cut : tree.cuts) {
    program.comment(fmt::format("cut '{}' ({}): bodies {} and {}, in the coordinates of its frame on k",
                                comment_text(cut.name), ir::cut_type_name(cut.type), cut.body_k, cut.body_l));
    if (cut.type == ir::CutType::Mimic) {
      mimic_row(program, tree, cut, !motion.empty(), out, out.phiq_packed.data() + phiq_start);
      phiq_start += cut.kept_rows.size() * cut.dofs.size();
      continue;
    }
    const CutFrames f = cut_frames(tree, cut, frames);
    const FrameMotion k = frame_motion(cut.body_k, cut.X_BkF.p, mat3(cut.X_BkF.R.transpose()), motion);
    const FrameMotion l = frame_motion(cut.body_l, cut.X_BlF.p, cut.body_l < 0 ? identity3() : f.body.at(cut.body_l).R,
                                       motion);
    const std::vector<Row> rows = cut_rows(cut, f.Fl, k, l);
    for (int r : cut.kept_rows) {
      out.phi.push_back(rows[static_cast<std::size_t>(r)].phi);
      if (!motion.empty()) out.gamma.push_back(rows[static_cast<std::size_t>(r)].gamma);
    }
    jacobian_entries(tree, cut, frames, f, rows, out.phiq_packed.data() + phiq_start);
    phiq_start += cut.kept_rows.size() * cut.dofs.size();
  }
  return out;
}

}  // namespace jrgen::emit
