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

#include <Eigen/Geometry>
#include <cmath>

namespace jr {

namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

Vector3d vec3(const double* x) { return Vector3d(x[0], x[1], x[2]); }

Matrix3d mat3_row_major(const double* x) {
  Matrix3d R;
  R << x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], x[8];
  return R;
}

// Rotation of a unit quaternion (w, x, y, z); normalized here (INTERFACE.md 3).
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

// (a)
Vector6d motion_to_child(const BodyState& b, const Vector6d& m_P) {
  const Vector3d w_P = m_P.head<3>(), v_P = m_P.tail<3>();
  Vector6d m_C;
  m_C.head<3>() = b.R.transpose() * w_P;
  m_C.tail<3>() = b.R.transpose() * (v_P - b.p.cross(w_P));
  return m_C;
}

// (b)
Vector6d force_to_parent(const BodyState& b, const Vector6d& f_C) {
  Vector6d f_P;
  f_P.tail<3>() = b.R * f_C.tail<3>();
  f_P.head<3>() = b.R * f_C.head<3>() + b.p.cross(f_P.tail<3>());
  return f_P;
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

// (e)
Vector6d cross_motion(const Vector6d& a, const Vector6d& b) {
  Vector6d out;
  out.head<3>() = a.head<3>().cross(b.head<3>());
  out.tail<3>() = a.head<3>().cross(b.tail<3>()) + a.tail<3>().cross(b.head<3>());
  return out;
}

// (f)
Vector6d cross_force(const Vector6d& v, const Vector6d& f) {
  Vector6d out;
  out.head<3>() = v.head<3>().cross(f.head<3>()) + v.tail<3>().cross(f.tail<3>());
  out.tail<3>() = v.head<3>().cross(f.tail<3>());
  return out;
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
    b.S.setZero();
    switch (bm.kind) {
      case JointKind::kRevolute:
        b.R_J = axis_rotation(axis, qi[0]);
        b.S.col(0).head<3>() = axis;  // the axis is fixed under its own rotation
        break;
      case JointKind::kPrismatic:
        b.R_J.setIdentity();
        t = axis * qi[0];
        b.S.col(0).tail<3>() = axis;
        break;
      case JointKind::kBall:
        b.R_J = quaternion_rotation(qi);
        b.S.topLeftCorner<3, 3>().setIdentity();
        break;
      case JointKind::kFloating:
        b.R_J = quaternion_rotation(qi + 3);
        t = vec3(qi);
        b.S.block<3, 3>(3, 0) = b.R_J.transpose();  // pdot is in J, S in C
        b.S.block<3, 3>(0, 3).setIdentity();
        break;
      case JointKind::kPlanar: {
        const Vector3d e1 = vec3(bm.e1), e2 = vec3(bm.e2);
        b.R_J = axis_rotation(axis, qi[2]);
        t = e1 * qi[0] + e2 * qi[1];
        b.S.col(0).tail<3>() = b.R_J.transpose() * e1;
        b.S.col(1).tail<3>() = b.R_J.transpose() * e2;
        b.S.col(2).head<3>() = axis;
        break;
      }
    }
    b.R = R_PJ * b.R_J;
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
