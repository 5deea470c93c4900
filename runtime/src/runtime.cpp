// jrgen runtime: kinematics, composite inertia (eq. 14, 18) and bias forces.
//
// Notation (docs/conventions.md): body C, its parent P, joint frame J.
// X_PC = (R, p) maps C coordinates into P.  Spatial motion m = [w; v],
// force f = [n; f], both about the frame origin, in that frame's coordinates.
// The formulas used below, written once:
//   (a) motion  P -> C:  w_C = R^T w_P,          v_C = R^T (v_P - p x w_P)
//   (b) force   C -> P:  f_P = R f_C,            n_P = R n_C + p x f_P
//   (c) inertia times motion: n = I w + h x v,   f = m v - h x w
//   (d) inertia C -> P, with hr = R h:
//       m_P = m, h_P = hr + m p,
//       I_P = R I R^T + (2 p.hr + m |p|^2) 1 - m p p^T - p hr^T - hr p^T
//   (e) motion cross motion:  [w1;v1] x [w2;v2] = [w1 x w2; w1 x v2 + v1 x w2]
//   (f) motion cross force:   [w;v] x* [n;f]    = [w x n + v x f; w x f]
#include "jrgen/runtime.hpp"

#include "kernels.hpp"
#include "spatial.hpp"

#include <Eigen/Geometry>
#include <cmath>

namespace jr {

namespace {

using spatial::cross_force;
using spatial::cross_motion;
using spatial::force_to_parent;
using spatial::motion_to_child;

using Eigen::Matrix3d;
using Eigen::Vector3d;

Vector3d vec3(const double* x) { return Vector3d(x[0], x[1], x[2]); }

Matrix3d mat3_row_major(const double* x) {
  Matrix3d R;
  R << x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], x[8];
  return R;
}

// Rotation of a unit quaternion (w, x, y, z); normalized here (docs/interface.md 3).
Matrix3d quaternion_rotation(const double* q) {
  Eigen::Quaterniond quat(q[0], q[1], q[2], q[3]);
  quat.normalize();
  return quat.toRotationMatrix();
}

// Rotation about a unit axis by angle.
Matrix3d axis_rotation(const Vector3d& axis, double angle) {
  return Eigen::AngleAxisd(angle, axis).toRotationMatrix();
}

// (c): spatial inertia times motion.
Vector6d inertia_times(const SpatialInertia& I, const Vector6d& m) {
  const Vector3d w = m.head<3>(), v = m.tail<3>();
  Vector6d f;
  f.head<3>() = I.I * w + I.h.cross(v);
  f.tail<3>() = I.m * v - I.h.cross(w);
  return f;
}

// (d)
void add_inertia_to_parent(const BodyState& b, const SpatialInertia& I_C, SpatialInertia& I_P) {
  const Vector3d hr = b.R * I_C.h;
  I_P.m += I_C.m;
  I_P.h += hr + I_C.m * b.p;
  I_P.I += b.R * I_C.I * b.R.transpose() +
           (2.0 * b.p.dot(hr) + I_C.m * b.p.squaredNorm()) * Matrix3d::Identity() -
           I_C.m * b.p * b.p.transpose() - b.p * hr.transpose() - hr * b.p.transpose();
}

// The body's own inertia about its origin, from mass, com and I_com.
SpatialInertia body_inertia(const BodyModel& bm) {
  SpatialInertia I;
  I.m = bm.mass;
  const Vector3d c = vec3(bm.com);
  I.h = bm.mass * c;
  Matrix3d Ic;
  Ic << bm.I_com[0], bm.I_com[3], bm.I_com[4], bm.I_com[3], bm.I_com[1], bm.I_com[5],
      bm.I_com[4], bm.I_com[5], bm.I_com[2];
  // Parallel axis: I_o = I_com + m (|c|^2 1 - c c^T).
  I.I = Ic + bm.mass * (c.squaredNorm() * Matrix3d::Identity() - c * c.transpose());
  return I;
}

// Joint-relative velocity S qd in C coordinates and the apparent derivative
// c_J = (dS/dt) qd of a joint whose translation is expressed in the joint frame
// (floating, planar): d/dt (R_J^T pdot) = -w_rel x (R_J^T pdot).
void joint_velocity(const BodyModel& bm, const BodyState& b, const double* v_user,
                    Vector6d& vJ, Vector6d& cJ) {
  const double* qd = v_user + bm.v_user;
  vJ.setZero();
  for (int k = 0; k < bm.nv; ++k) vJ += b.S.col(k) * qd[k];
  cJ.setZero();
  if (bm.kind == JointKind::kFloating || bm.kind == JointKind::kPlanar) {
    cJ.tail<3>() = -vJ.head<3>().cross(vJ.tail<3>());
  }
}

}  // namespace

void kinematics(const Model& model, BodyState* bodies, const double* q) {
  for (std::int32_t i = 0; i < model.nb; ++i) {
    const BodyModel& bm = model.bodies[i];
    BodyState& b = bodies[i];
    const double* qi = q + bm.q_user;
    const Matrix3d R_PJ = mat3_row_major(bm.R_PJ);
    const Vector3d p_PJ = vec3(bm.p_PJ);
    const Vector3d axis = vec3(bm.axis);
    Vector3d t = Vector3d::Zero();  // translation of C's origin in J
    // Only the joint's nv columns of S exist (BodyState); the rest stays untouched.
    b.S.leftCols(bm.nv).setZero();
    Matrix3d R_J = Matrix3d::Identity();  // rotation of the joint alone (C relative to J)
    switch (bm.kind) {
      case JointKind::kRevolute:
        R_J = axis_rotation(axis, qi[0]);
        b.S.col(0).head<3>() = axis;  // the axis is fixed under its own rotation
        break;
      case JointKind::kPrismatic:
        t = axis * qi[0];
        b.S.col(0).tail<3>() = axis;
        break;
      case JointKind::kBall:
        R_J = quaternion_rotation(qi);
        b.S.topLeftCorner<3, 3>().setIdentity();
        break;
      case JointKind::kFloating:
        R_J = quaternion_rotation(qi + 3);
        t = vec3(qi);
        b.S.block<3, 3>(3, 0) = R_J.transpose();  // pdot is in J, S in C
        b.S.block<3, 3>(0, 3).setIdentity();
        break;
      case JointKind::kPlanar: {
        const Vector3d e1 = vec3(bm.e1), e2 = vec3(bm.e2);
        R_J = axis_rotation(axis, qi[2]);
        t = e1 * qi[0] + e2 * qi[1];
        b.S.col(0).tail<3>() = R_J.transpose() * e1;
        b.S.col(1).tail<3>() = R_J.transpose() * e2;
        b.S.col(2).head<3>() = axis;
        break;
      }
    }
    b.R = R_PJ * R_J;
    b.p = p_PJ + R_PJ * t;
  }
}

void world_poses(const Model& model, BodyState* bodies) {
  // Parents have larger indices (Lemma 2): walk from the root end.
  for (std::int32_t i = model.nb - 1; i >= 0; --i) {
    BodyState& b = bodies[i];
    const std::int32_t parent = model.bodies[i].parent;
    if (parent < 0) {
      b.R_WC = b.R;
      b.p_WC = b.p;
    } else {
      const BodyState& P = bodies[parent];
      b.R_WC = P.R_WC * b.R;
      b.p_WC = P.p_WC + P.R_WC * b.p;
    }
  }
}

std::int32_t packed_index(const Model& model, std::int32_t row_lem, std::int32_t col_lem) {
  std::int32_t k = model.M_col_start[col_lem];
  for (std::int32_t r = col_lem; r >= 0; r = model.dof_parent[r], ++k)
    if (r == row_lem) return k;
  return -1;
}

void mass_matrix_packed(const Model& model, BodyState* bodies, double* Mp) {
  // Composite inertias, eq. (14) (K_i = K_{i+1} + M_i, summed over children):
  // children come first in Lemma 2 order, so one forward sweep accumulates.
  for (std::int32_t i = 0; i < model.nb; ++i) bodies[i].Ic = body_inertia(model.bodies[i]);
  for (std::int32_t i = 0; i < model.nb; ++i) {
    const std::int32_t parent = model.bodies[i].parent;
    if (parent >= 0) add_inertia_to_parent(bodies[i], bodies[i].Ic, bodies[parent].Ic);
  }
  // Blocks of eq. (18): M[i, j] = S_j^T X^T Ic_i S_i for j on the path from i
  // to the base.  F holds Ic_i S_i, carried up the path as a force.
  Eigen::Matrix<double, 6, 6> F;
  for (std::int32_t i = 0; i < model.nb; ++i) {
    const BodyModel& bm = model.bodies[i];
    const std::int32_t nv_i = bm.nv;
    for (std::int32_t k = 0; k < nv_i; ++k) F.col(k) = inertia_times(bodies[i].Ic, bodies[i].S.col(k));
    // Diagonal block, lower triangle only: column v_lem + k holds rows v_lem + k ...
    for (std::int32_t k = 0; k < nv_i; ++k) {
      const std::int32_t col = bm.v_lem + k;
      for (std::int32_t r = k; r < nv_i; ++r)
        Mp[model.M_col_start[col] + (r - k)] = bodies[i].S.col(r).dot(F.col(k));
    }
    // Off-diagonal blocks with every ancestor body.
    std::int32_t offset = nv_i;  // distance from dof v_lem up the chain, past this body
    std::int32_t child = i;
    for (std::int32_t j = bm.parent; j >= 0; j = model.bodies[j].parent) {
      for (std::int32_t k = 0; k < nv_i; ++k) F.col(k) = force_to_parent(bodies[child], F.col(k));
      const BodyModel& bj = model.bodies[j];
      for (std::int32_t k = 0; k < nv_i; ++k) {
        const std::int32_t col = bm.v_lem + k;
        for (std::int32_t r = 0; r < bj.nv; ++r)
          Mp[model.M_col_start[col] + (offset - k) + r] = bodies[j].S.col(r).dot(F.col(k));
      }
      offset += bj.nv;
      child = j;
    }
  }
}

template <bool kGravity, bool kDamping>
void bias_forces(const Model& model, BodyState* bodies, const double* v, double* h_lem) {
  // Forward sweep (root end first): velocities and bias accelerations at
  // qdd = 0.  Gravity enters as a base acceleration of -g (Featherstone's
  // trick), so it costs nothing when kGravity is false.
  Vector6d a_base = Vector6d::Zero();
  if constexpr (kGravity) a_base.tail<3>() = -Vector3d(model.gravity[0], model.gravity[1], model.gravity[2]);
  Vector6d vJ, cJ;
  for (std::int32_t i = model.nb - 1; i >= 0; --i) {
    const BodyModel& bm = model.bodies[i];
    BodyState& b = bodies[i];
    joint_velocity(bm, b, v, vJ, cJ);
    if (bm.parent < 0) {
      b.v = vJ;
      b.a = motion_to_child(b, a_base) + cJ;
    } else {
      const BodyState& P = bodies[bm.parent];
      b.v = motion_to_child(b, P.v) + vJ;
      b.a = motion_to_child(b, P.a) + cJ + cross_motion(b.v, vJ);
    }
    const SpatialInertia I = body_inertia(bm);
    b.f = inertia_times(I, b.a) + cross_force(b.v, inertia_times(I, b.v));
  }
  // Backward sweep (leaves first): project and pass forces to the parent.
  for (std::int32_t i = 0; i < model.nb; ++i) {
    const BodyModel& bm = model.bodies[i];
    BodyState& b = bodies[i];
    for (std::int32_t k = 0; k < bm.nv; ++k) {
      double hk = b.S.col(k).dot(b.f);
      if constexpr (kDamping) hk += bm.damping * v[bm.v_user + k];
      h_lem[bm.v_lem + k] = hk;
    }
    if (bm.parent >= 0) bodies[bm.parent].f += force_to_parent(b, b.f);
  }
}

template void bias_forces<false, false>(const Model&, BodyState*, const double*, double*);
template void bias_forces<false, true>(const Model&, BodyState*, const double*, double*);
template void bias_forces<true, false>(const Model&, BodyState*, const double*, double*);
template void bias_forces<true, true>(const Model&, BodyState*, const double*, double*);

void bias_forces(const Model& model, BodyState* bodies, const double* v, double* h_lem, bool gravity,
                 bool damping) {
  if (gravity) {
    if (damping) bias_forces<true, true>(model, bodies, v, h_lem);
    else bias_forces<true, false>(model, bodies, v, h_lem);
  } else {
    if (damping) bias_forces<false, true>(model, bodies, v, h_lem);
    else bias_forces<false, false>(model, bodies, v, h_lem);
  }
}

void unpack_mass_matrix(const Model& model, const double* Mp, double* M_user) {
  const std::int32_t nv = model.nv;
  for (std::int32_t k = 0; k < nv * nv; ++k) M_user[k] = 0.0;
  for (std::int32_t c = 0; c < nv; ++c) {
    std::int32_t k = model.M_col_start[c];
    for (std::int32_t r = c; r >= 0; r = model.dof_parent[r], ++k) {
      const std::int32_t ru = model.dof_user[r], cu = model.dof_user[c];
      M_user[ru + nv * cu] = Mp[k];
      M_user[cu + nv * ru] = Mp[k];
    }
  }
}

void pack_mass_matrix(const Model& model, const double* M_user, double* Mp) {
  const std::int32_t nv = model.nv;
  for (std::int32_t c = 0; c < nv; ++c) {
    std::int32_t k = model.M_col_start[c];
    for (std::int32_t r = c; r >= 0; r = model.dof_parent[r], ++k)
      Mp[k] = M_user[model.dof_user[r] + nv * model.dof_user[c]];
  }
}

// ---- Cut joints ----------------------------------------------------------------
//
// For a scalar row Phi, with body k's frame origin velocity and angular
// velocity (v_k, w_k) and likewise for l, the derivative is written as
//   (g)  Phi_dot = c_wk . w_k + c_vk . v(P_k) + c_wl . w_l + c_vl . v(P_l),
// v(P) the velocity of the body-fixed point P.  A dof j of a body J on the
// path from k (or l) to the base moves body k with world twist (w_j, v_j at
// J's origin o_J), so (g) gives its Jacobian entry
//   (h)  (c_w + (P - o_J) x c_v) . w_j + c_v . v_j.
// gamma = -(d/dt Phiq) v is -Phi_ddot at qdd = 0, from the bias
// accelerations of the bodies (no gravity):
//   point    e . r:  Phi_ddot = e_dd . r + 2 e_d . r_d + e . r_dd
//   dot      a . b:  Phi_ddot = a_dd . b + 2 a_d . b_d + a . b_dd
//   distance:        Phi_ddot = (r_d . r_d + r . r_dd) / D
// with e_d = w x e and e_dd = alpha x e + w x (w x e) for a body-fixed e.

int cut_kind_rows(CutKind kind) {
  switch (kind) {
    case CutKind::kSpherical: return 3;
    case CutKind::kRevolute: return 5;
    case CutKind::kPrismatic: return 5;
    case CutKind::kCylindrical: return 4;
    case CutKind::kUniversal: return 4;
    case CutKind::kFixed: return 6;
    case CutKind::kDistance: return 1;
    case CutKind::kMimic: return 1;
  }
  return 0;
}

namespace {

// World motion of every body at qdd = 0 without gravity (needs kinematics()).
void body_motions(const Model& model, BodyState* bodies, BodyMotion* motion, const double* v) {
  Vector6d vJ, cJ;
  for (std::int32_t i = model.nb - 1; i >= 0; --i) {
    const BodyModel& bm = model.bodies[i];
    BodyState& b = bodies[i];
    BodyMotion& m = motion[i];
    if (bm.parent < 0) {
      m.R = b.R;
      m.p = b.p;
    } else {
      m.R = motion[bm.parent].R * b.R;
      m.p = motion[bm.parent].p + motion[bm.parent].R * b.p;
    }
    if (v == nullptr) continue;
    joint_velocity(bm, b, v, vJ, cJ);
    if (bm.parent < 0) {
      b.v = vJ;
      b.a = cJ;
    } else {
      const BodyState& P = bodies[bm.parent];
      b.v = motion_to_child(b, P.v) + vJ;
      b.a = motion_to_child(b, P.a) + cJ + cross_motion(b.v, vJ);
    }
    const Vector3d w_B = b.v.head<3>(), v_B = b.v.tail<3>();
    m.w = m.R * w_B;
    m.v = m.R * v_B;
    m.alpha = m.R * b.a.head<3>();
    m.a = m.R * (b.a.tail<3>() + w_B.cross(v_B));  // classical acceleration of the origin
  }
}

// A frame fixed on a body, in the world, with the motion of its origin and
// of its body.
struct FrameMotion {
  Matrix3d R;
  Vector3d p, w, v, alpha, a;
};

FrameMotion frame_motion(std::int32_t body, const double* R_BF, const double* p_BF, const BodyMotion* motion,
                         bool with_velocity) {
  FrameMotion f;
  const Matrix3d R = mat3_row_major(R_BF);
  const Vector3d p = vec3(p_BF);
  if (body < 0) {
    f.R = R;
    f.p = p;
    f.w = f.v = f.alpha = f.a = Vector3d::Zero();
    return f;
  }
  const BodyMotion& m = motion[body];
  f.R = m.R * R;
  const Vector3d r = m.R * p;
  f.p = m.p + r;
  if (with_velocity) {
    f.w = m.w;
    f.alpha = m.alpha;
    f.v = m.v + m.w.cross(r);
    f.a = m.a + m.alpha.cross(r) + m.w.cross(m.w.cross(r));
  } else {
    f.w = f.v = f.alpha = f.a = Vector3d::Zero();
  }
  return f;
}

// One scalar row: value, -Phi_ddot at qdd = 0, and the coefficients of (g).
struct CutRow {
  double phi = 0.0, gamma = 0.0;
  Vector3d cwk = Vector3d::Zero(), cvk = Vector3d::Zero(), cwl = Vector3d::Zero(), cvl = Vector3d::Zero();
};

CutRow point_row(const Vector3d& e, const FrameMotion& k, const FrameMotion& l) {
  const Vector3d r = l.p - k.p, rd = l.v - k.v, rdd = l.a - k.a;
  const Vector3d ed = k.w.cross(e), edd = k.alpha.cross(e) + k.w.cross(k.w.cross(e));
  CutRow row;
  row.phi = e.dot(r);
  row.gamma = -(edd.dot(r) + 2.0 * ed.dot(rd) + e.dot(rdd));
  row.cwk = e.cross(r);
  row.cvk = -e;
  row.cvl = e;
  return row;
}

CutRow dot_row(const Vector3d& a, const Vector3d& b, const FrameMotion& k, const FrameMotion& l) {
  const Vector3d ad = k.w.cross(a), add = k.alpha.cross(a) + k.w.cross(k.w.cross(a));
  const Vector3d bd = l.w.cross(b), bdd = l.alpha.cross(b) + l.w.cross(l.w.cross(b));
  CutRow row;
  row.phi = a.dot(b);
  row.gamma = -(add.dot(b) + 2.0 * ad.dot(bd) + a.dot(bdd));
  row.cwk = a.cross(b);
  row.cwl = b.cross(a);
  return row;
}

CutRow distance_row(double D, const FrameMotion& k, const FrameMotion& l) {
  const Vector3d r = l.p - k.p, rd = l.v - k.v, rdd = l.a - k.a;
  CutRow row;
  row.phi = (r.squaredNorm() - D * D) / (2.0 * D);
  row.gamma = -(rd.squaredNorm() + r.dot(rdd)) / D;
  row.cvk = -r / D;
  row.cvl = r / D;
  return row;
}

// u, w completing a unit axis to a right-handed orthonormal basis (u, w, axis),
// chosen by a fixed rule so that rows are reproducible.
void complete_basis(const Vector3d& axis, Vector3d& u, Vector3d& w) {
  const Vector3d helper = std::abs(axis.x()) < 0.9 ? Vector3d::UnitX() : Vector3d::UnitY();
  u = (helper - helper.dot(axis) * axis).normalized();
  w = axis.cross(u);
}

// Every row of a cut, in the order documented in runtime.hpp.
int cut_rows(const CutModel& cut, const FrameMotion& k, const FrameMotion& l, CutRow* rows) {
  const Vector3d xk = k.R.col(0), yk = k.R.col(1), zk = k.R.col(2);
  const Vector3d xl = l.R.col(0), yl = l.R.col(1), zl = l.R.col(2);
  const Vector3d axis = vec3(cut.axis);
  Vector3d u, w;
  complete_basis(axis, u, w);
  const Vector3d u_W = k.R * u, w_W = k.R * w, axis_l_W = l.R * axis;
  int n = 0;
  auto points_xyz = [&] {
    rows[n++] = point_row(xk, k, l);
    rows[n++] = point_row(yk, k, l);
    rows[n++] = point_row(zk, k, l);
  };
  auto orientation = [&] {
    rows[n++] = dot_row(yk, zl, k, l);
    rows[n++] = dot_row(zk, xl, k, l);
    rows[n++] = dot_row(xk, yl, k, l);
  };
  auto axis_aligned = [&] {
    rows[n++] = dot_row(u_W, axis_l_W, k, l);
    rows[n++] = dot_row(w_W, axis_l_W, k, l);
  };
  auto across_axis = [&] {
    rows[n++] = point_row(u_W, k, l);
    rows[n++] = point_row(w_W, k, l);
  };
  switch (cut.kind) {
    case CutKind::kSpherical: points_xyz(); break;
    case CutKind::kRevolute: points_xyz(); axis_aligned(); break;
    case CutKind::kPrismatic: orientation(); across_axis(); break;
    case CutKind::kCylindrical: axis_aligned(); across_axis(); break;
    case CutKind::kUniversal:
      points_xyz();
      rows[n++] = dot_row(k.R * axis, l.R * vec3(cut.child_axis), k, l);
      break;
    case CutKind::kFixed: points_xyz(); orientation(); break;
    case CutKind::kDistance: rows[n++] = distance_row(cut.distance, k, l); break;
    case CutKind::kMimic: break;  // not a frame constraint: mimic_row
  }
  return n;
}

// The mimic row (runtime.hpp, CutKind): Phi = q_l - m q_k - o, gamma = 0.
CutRow mimic_row(const Model& model, const CutModel& cut, const double* q) {
  CutRow row;
  row.phi = q[model.bodies[cut.body_l].q_user] - cut.axis[0] * q[model.bodies[cut.body_k].q_user] - cut.distance;
  return row;
}

// Its Jacobian entry at a dof: 1 at the mimic joint's, -m at the leader's.
double mimic_entry(const Model& model, const CutModel& cut, std::int32_t dof) {
  if (dof == model.bodies[cut.body_l].v_lem) return 1.0;
  if (dof == model.bodies[cut.body_k].v_lem) return -cut.axis[0];
  return 0.0;
}

// Walks the dofs on the paths of body_k and body_l to the base in increasing
// Lemma 2 order, calling f(index, dof, on_k, on_l).
template <typename F>
void for_each_cut_dof(const Model& model, std::int32_t body_k, std::int32_t body_l, F&& f) {
  std::int32_t dk = body_k >= 0 ? model.bodies[body_k].v_lem : -1;
  std::int32_t dl = body_l >= 0 ? model.bodies[body_l].v_lem : -1;
  std::int32_t index = 0;
  while (dk >= 0 || dl >= 0) {
    std::int32_t d;
    bool on_k = false, on_l = false;
    if (dl < 0 || (dk >= 0 && dk < dl)) {
      d = dk;
      on_k = true;
    } else if (dk < 0 || dl < dk) {
      d = dl;
      on_l = true;
    } else {
      d = dk;
      on_k = on_l = true;
    }
    f(index++, d, on_k, on_l);
    if (on_k) dk = model.dof_parent[dk];
    if (on_l) dl = model.dof_parent[dl];
  }
}

// Body owning a dof (dofs of a body are contiguous from v_lem).
std::int32_t dof_owner(const Model& model, std::int32_t dof, std::int32_t hint) {
  std::int32_t b = hint;
  while (model.bodies[b].v_lem + model.bodies[b].nv <= dof) b = model.bodies[b].parent;
  return b;
}

// Jacobian entry (h) of one row for a dof with world twist (wj, vj) of a body
// with origin o.
double row_entry(const CutRow& row, bool on_k, bool on_l, const Vector3d& wj, const Vector3d& vj,
                 const Vector3d& o, const Vector3d& Pk, const Vector3d& Pl) {
  double e = 0.0;
  if (on_k) e += (row.cwk + (Pk - o).cross(row.cvk)).dot(wj) + row.cvk.dot(vj);
  if (on_l) e += (row.cwl + (Pl - o).cross(row.cvl)).dot(wj) + row.cvl.dot(vj);
  return e;
}

// Shared driver: rows of every cut and their Jacobian entries, handed to
// `emit(cut index, row index, row, dof index on the path, dof, entry)`.
template <typename RowF, typename EntryF>
void evaluate_cuts(const Model& model, const ConstraintModel& cm, BodyState* bodies, BodyMotion* motion,
                   const double* q, const double* v, bool jacobian, RowF&& on_row, EntryF&& on_entry) {
  kinematics(model, bodies, q);
  body_motions(model, bodies, motion, v);
  CutRow rows[6];
  for (std::int32_t c = 0; c < cm.ncuts; ++c) {
    const CutModel& cut = cm.cuts[c];
    if (cut.kind == CutKind::kMimic) {
      on_row(c, 0, mimic_row(model, cut, q));
      if (jacobian)
        for_each_cut_dof(model, cut.body_k, cut.body_l, [&](std::int32_t index, std::int32_t dof, bool, bool) {
          on_entry(c, 0, index, dof, mimic_entry(model, cut, dof));
        });
      continue;
    }
    const FrameMotion k = frame_motion(cut.body_k, cut.R_k, cut.p_k, motion, v != nullptr);
    const FrameMotion l = frame_motion(cut.body_l, cut.R_l, cut.p_l, motion, v != nullptr);
    const int n = cut_rows(cut, k, l, rows);
    for (int r = 0; r < n; ++r) on_row(c, r, rows[r]);
    if (!jacobian) continue;
    for_each_cut_dof(model, cut.body_k, cut.body_l, [&](std::int32_t index, std::int32_t dof, bool on_k, bool on_l) {
      // A dof on both paths moves Fk and Fl together rigidly, and every row
      // depends only on their relative placement: its entries are exactly 0.
      if (on_k && on_l) return;
      const std::int32_t owner = dof_owner(model, dof, on_k ? cut.body_k : cut.body_l);
      const BodyModel& bm = model.bodies[owner];
      const Vector6d& S = bodies[owner].S.col(dof - bm.v_lem);
      const Vector3d wj = motion[owner].R * S.head<3>(), vj = motion[owner].R * S.tail<3>();
      for (int r = 0; r < n; ++r)
        on_entry(c, r, index, dof, row_entry(rows[r], on_k, on_l, wj, vj, motion[owner].p, k.p, l.p));
    });
  }
}

}  // namespace

void constraint_terms(const Model& model, const ConstraintModel& cm, BodyState* bodies, BodyMotion* motion,
                      const double* q, const double* v, double* phi, double* Phiq_p, double* gamma) {
  // Kept-row index of row r of cut c, or -1.
  auto kept = [&](std::int32_t c, int r) -> std::int32_t {
    const CutModel& cut = cm.cuts[c];
    if (!(cut.row_mask >> r & 1)) return -1;
    std::int32_t before = 0;
    for (int s = 0; s < r; ++s) before += cut.row_mask >> s & 1;
    return before;
  };
  evaluate_cuts(
      model, cm, bodies, motion, q, gamma ? v : nullptr, Phiq_p != nullptr,
      [&](std::int32_t c, int r, const CutRow& row) {
        const std::int32_t k = kept(c, r);
        if (k < 0) return;
        if (phi) phi[cm.cuts[c].first_row + k] = row.phi;
        if (gamma) gamma[cm.cuts[c].first_row + k] = row.gamma;
      },
      [&](std::int32_t c, int r, std::int32_t index, std::int32_t, double entry) {
        const std::int32_t k = kept(c, r);
        if (k < 0) return;
        const CutModel& cut = cm.cuts[c];
        Phiq_p[cut.phiq_start + k * cut.num_dofs + index] = entry;
      });
}

void constraints(const Model& model, const ConstraintModel& cm, BodyState* bodies, const double* q, double* phi) {
  // Positions only: world poses in BodyState suffice.
  kinematics(model, bodies, q);
  world_poses(model, bodies);
  for (std::int32_t c = 0; c < cm.ncuts; ++c) {
    const CutModel& cut = cm.cuts[c];
    auto frame = [&](std::int32_t body, const double* R_BF, const double* p_BF) {
      FrameMotion f;
      f.R = mat3_row_major(R_BF);
      f.p = vec3(p_BF);
      if (body >= 0) {
        f.p = bodies[body].p_WC + bodies[body].R_WC * f.p;
        f.R = bodies[body].R_WC * f.R;
      }
      f.w = f.v = f.alpha = f.a = Vector3d::Zero();
      return f;
    };
    const FrameMotion k = frame(cut.body_k, cut.R_k, cut.p_k), l = frame(cut.body_l, cut.R_l, cut.p_l);
    CutRow rows[6];
    const int n = cut.kind == CutKind::kMimic ? (rows[0] = mimic_row(model, cut, q), 1) : cut_rows(cut, k, l, rows);
    std::int32_t out = cut.first_row;
    for (int r = 0; r < n; ++r)
      if (cut.row_mask >> r & 1) phi[out++] = rows[r].phi;
  }
}

void constraints_all_rows(const Model& model, const ConstraintModel& cm, BodyState* bodies, BodyMotion* motion,
                          const double* q, double* phi_all, double* Phiq_all) {
  // Row offsets of every cut with all rows.
  std::int32_t total = 0;
  for (std::int32_t c = 0; c < cm.ncuts; ++c) total += cut_kind_rows(cm.cuts[c].kind);
  if (Phiq_all)
    for (std::int64_t k = 0; k < static_cast<std::int64_t>(total) * model.nv; ++k) Phiq_all[k] = 0.0;
  auto offset = [&](std::int32_t c) {
    std::int32_t o = 0;
    for (std::int32_t i = 0; i < c; ++i) o += cut_kind_rows(cm.cuts[i].kind);
    return o;
  };
  evaluate_cuts(
      model, cm, bodies, motion, q, nullptr, Phiq_all != nullptr,
      [&](std::int32_t c, int r, const CutRow& row) {
        if (phi_all) phi_all[offset(c) + r] = row.phi;
      },
      [&](std::int32_t c, int r, std::int32_t, std::int32_t dof, double entry) {
        Phiq_all[(offset(c) + r) + static_cast<std::int64_t>(total) * model.dof_user[dof]] = entry;
      });
}

void unpack_constraint_jacobian(const Model& model, const ConstraintModel& cm, const double* Phiq_p,
                                double* Phiq_user) {
  const std::int32_t nc = cm.nc;
  for (std::int64_t k = 0; k < static_cast<std::int64_t>(nc) * model.nv; ++k) Phiq_user[k] = 0.0;
  for (std::int32_t c = 0; c < cm.ncuts; ++c) {
    const CutModel& cut = cm.cuts[c];
    std::int32_t kept = 0;
    for (int r = 0; r < cut_kind_rows(cut.kind); ++r) {
      if (!(cut.row_mask >> r & 1)) continue;
      const std::int32_t row = cut.first_row + kept;
      const double* src = Phiq_p + cut.phiq_start + kept * cut.num_dofs;
      for_each_cut_dof(model, cut.body_k, cut.body_l, [&](std::int32_t index, std::int32_t dof, bool on_k, bool on_l) {
        if (!(on_k && on_l) || cut.kind == CutKind::kMimic)  // a mimic row writes every dof
          Phiq_user[row + static_cast<std::int64_t>(nc) * model.dof_user[dof]] = src[index];
      });
      ++kept;
    }
  }
}

std::int32_t factor_packed(const Model& model, double* L, double* Dinv, bool ldlt, double pivot_tolerance,
                           double* pivot) {
  const std::int32_t* start = model.M_col_start;
  const std::int32_t* parent = model.dof_parent;
  // Dinv[j] keeps M[j, j] until column j is reached (the pivot test is
  // relative to it, as in the straight-line code).
  for (std::int32_t j = 0; j < model.nv; ++j) Dinv[j] = L[start[j]];
  for (std::int32_t j = 0; j < model.nv; ++j) {
    const std::int32_t cj = start[j];
    const std::int32_t len = start[j + 1] - cj;  // 1 + number of ancestors
    const double d = L[cj];
    if (!(d > pivot_tolerance * Dinv[j])) {
      *pivot = d;
      return j;
    }
    double* col = L + cj + 1;  // ancestor rows of column j
    const double dinv = 1.0 / d;
    const double rows = detail::row_scale(d, dinv, ldlt, L + cj);
    Dinv[j] = rows;
    detail::update_ancestors(L, start, parent, parent[j], col, dinv, len - 1);
    for (std::int32_t a = 0; a < len - 1; ++a) col[a] *= rows;
  }
  return -1;
}

void fill_packed_rows(const Model& model, std::int32_t* entry_row, std::int32_t* row_start, std::int32_t* row_entry,
                      std::int32_t* row_col) {
  const std::int32_t* start = model.M_col_start;
  const std::int32_t nv = model.nv;
  for (std::int32_t j = 0; j <= nv; ++j) row_start[j] = 0;
  // Count each row's off-diagonal entries, then place them column by column
  // (ascending), so that each row lists its columns in ascending order.
  for (std::int32_t j = 0; j < nv; ++j) {
    std::int32_t r = j;
    for (std::int32_t k = start[j]; k < start[j + 1]; ++k, r = model.dof_parent[r]) {
      entry_row[k] = r;
      if (k > start[j]) ++row_start[r + 1];
    }
  }
  for (std::int32_t j = 0; j < nv; ++j) row_start[j + 1] += row_start[j];
  // row_start[r] serves as row r's fill cursor: it ends at the start of row
  // r + 1, and the shift below restores it.
  for (std::int32_t j = 0; j < nv; ++j)
    for (std::int32_t k = start[j] + 1; k < start[j + 1]; ++k) {
      const std::int32_t p = row_start[entry_row[k]]++;
      row_entry[p] = k;
      row_col[p] = j;
    }
  for (std::int32_t j = nv; j > 0; --j) row_start[j] = row_start[j - 1];
  row_start[0] = 0;
}

void forward_packed(const Model& model, const PackedRows& rows, const double* L, const double* Dinv, bool ldlt,
                    double* z) {
  // Row j: z_j = (Q_j - sum over descendants k of L[j, k] z_k) / L[j, j]
  // (times 1 with ldlt), descendants first (Lemma 2); two partial sums.
  const std::int32_t* rs = rows.row_start;
  const std::int32_t* re = rows.row_entry;
  const std::int32_t* rc = rows.row_col;
  for (std::int32_t j = 0; j < model.nv; ++j) {
    double s0 = z[j], s1 = 0.0;
    std::int32_t k = rs[j];
    const std::int32_t end = rs[j + 1];
    for (; k + 1 < end; k += 2) {
      s0 -= L[re[k]] * z[rc[k]];
      s1 -= L[re[k + 1]] * z[rc[k + 1]];
    }
    if (k < end) s0 -= L[re[k]] * z[rc[k]];
    z[j] = ldlt ? s0 + s1 : (s0 + s1) * Dinv[j];
  }
}

void backward_packed(const Model& model, const PackedRows& rows, const double* L, const double* Dinv, bool ldlt,
                     double* z) {
  // Column j: x_j = (z_j - sum over ancestors a of L[a, j] x_a) / L[j, j]
  // (ldlt: z_j / d_j - sum ...), ancestors first; two partial sums, from the
  // root down to the parent: the parent's x_a, solved last, enters last, so
  // the chain from one column to the next is one product and one subtraction
  // (Step 4 of tree_d4_1000 4.3 -> 3.9 us in one process, run 6).
  const std::int32_t* start = model.M_col_start;
  const std::int32_t* row = rows.entry_row;
  for (std::int32_t j = model.nv - 1; j >= 0; --j) {
    double s0 = ldlt ? z[j] * Dinv[j] : z[j], s1 = 0.0;
    const std::int32_t first = start[j] + 1;
    std::int32_t k = start[j + 1] - 1;
    for (; k > first; k -= 2) {
      s0 -= L[k] * z[row[k]];
      s1 -= L[k - 1] * z[row[k - 1]];
    }
    if (k == first) s0 -= L[k] * z[row[k]];
    z[j] = ldlt ? s0 + s1 : (s0 + s1) * Dinv[j];
  }
}

const char* status_name(int status) {
  switch (status) {
    case kSuccess: return "success";
    case kMassNotPositiveDefinite: return "mass matrix not positive definite";
    case kConstraintsSingular: return "constraint rows singular (T^T T not positive definite)";
    case kNonFinite: return "non-finite value in the result";
    default: return "unknown status";
  }
}

}  // namespace jr
