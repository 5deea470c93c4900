// Reference cut-joint constraints; see reference_constraints.hpp.
//
// Derivatives of the relative placement (local numbers (a)-(f)).  With
// R_k = R_WFk, r = p_WFl - p_WFk, and (omega, alpha) the angular velocity and
// bias acceleration of each frame's link in W:
//
//   (a) R = R_k^T R_WFl,  p = R_k^T r
//   For any world vector x(t):  d/dt (R_k^T x) = R_k^T (x_dot - omega_k x x),
//   since d/dt R_k = [omega_k]x R_k.  Hence
//   (b) R_dot = [omega_r]x R,      omega_r = R_k^T (omega_l - omega_k)
//       (R_k^T [d]x R_WFl = [R_k^T d]x R for d = omega_l - omega_k)
//   (c) p_dot = R_k^T s,           s = r_dot - omega_k x r
//   (d) omega_r_dot = R_k^T (alpha_l - alpha_k - omega_k x (omega_l - omega_k))
//   (e) R_ddot = [omega_r_dot]x R + [omega_r]x [omega_r]x R
//   (f) p_ddot = R_k^T (s_dot - omega_k x s),  s_dot = r_ddot - alpha_k x r - omega_k x r_dot
// The Jacobians follow from (b) and (c) with every velocity replaced by its
// Jacobian (J = [J_v; J_omega] of each frame, 6 x nv):
//   Omega = R_k^T (J_omega_l - J_omega_k)          (omega_r = Omega v)
//   P     = R_k^T (J_v_l - J_v_k + [r]x J_omega_k)  (p_dot = P v)
// and the rows (header) differentiate as
//   e . p                 row e^T P          second derivative e . p_ddot
//   a . (R b)             row (R b x a)^T Omega   (a . (omega_r x R b))
//                                            second derivative a . (R_ddot b)
//   (|p|^2 - D^2) / (2D)  row p^T P / D      second derivative (|p_dot|^2 + p . p_ddot) / D
// At qdd = 0 the second derivative is (d/dt Phiq) v, so gamma is its negative.
#include "reference/reference_constraints.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "reference/reference_dynamics.hpp"

namespace jrgen::reference {

namespace {

using Eigen::Matrix3d;
using Eigen::MatrixXd;
using Eigen::Vector3d;
using Eigen::VectorXd;

Matrix3d skew(const Vector3d& x) {
  Matrix3d S;
  S << 0.0, -x.z(), x.y(), x.z(), 0.0, -x.x(), -x.y(), x.x(), 0.0;
  return S;
}

/// The relative placement (a), its Jacobians and its first two derivatives.
struct Relative {
  Matrix3d R, R_ddot;
  Vector3d p, p_dot, p_ddot, omega_r;
  MatrixXd Omega, P;  ///< 3 x nv
};

Relative relative(const FrameState& k, const FrameState& l, bool with_velocity) {
  Relative rel;
  const Matrix3d Rk_T = k.R_WF.transpose();
  const Vector3d r = l.p_WF - k.p_WF;
  rel.R = Rk_T * l.R_WF;  // (a)
  rel.p = Rk_T * r;
  rel.Omega = Rk_T * (l.J.bottomRows<3>() - k.J.bottomRows<3>());
  rel.P = Rk_T * (l.J.topRows<3>() - k.J.topRows<3>() + skew(r) * k.J.bottomRows<3>());
  rel.omega_r = rel.p_dot = rel.p_ddot = Vector3d::Zero();
  rel.R_ddot = Matrix3d::Zero();
  if (!with_velocity) return rel;
  const Vector3d r_dot = l.vel - k.vel, r_ddot = l.acc - k.acc;
  rel.omega_r = Rk_T * (l.omega - k.omega);  // (b)
  const Vector3d s = r_dot - k.omega.cross(r);
  rel.p_dot = Rk_T * s;  // (c)
  const Vector3d omega_r_dot = Rk_T * (l.alpha - k.alpha - k.omega.cross(l.omega - k.omega));  // (d)
  rel.R_ddot = skew(omega_r_dot) * rel.R + skew(rel.omega_r) * skew(rel.omega_r) * rel.R;        // (e)
  const Vector3d s_dot = r_ddot - k.alpha.cross(r) - k.omega.cross(r_dot);
  rel.p_ddot = Rk_T * (s_dot - k.omega.cross(s));  // (f)
  return rel;
}

/// Appends rows to a CutRows under construction.
struct RowWriter {
  const Relative& rel;
  CutRows& out;
  int n = 0;

  void put(double phi, const MatrixXd& row, double second_derivative) {
    out.phi[n] = phi;
    out.Phiq.row(n) = row;
    out.gamma[n] = -second_derivative;
    ++n;
  }
  void point(const Vector3d& e) { put(e.dot(rel.p), e.transpose() * rel.P, e.dot(rel.p_ddot)); }
  void dot(const Vector3d& a, const Vector3d& b) {
    const Vector3d Rb = rel.R * b;
    put(a.dot(Rb), Rb.cross(a).transpose() * rel.Omega, a.dot(rel.R_ddot * b));
  }
  void distance(double D) {
    put((rel.p.squaredNorm() - D * D) / (2.0 * D), rel.p.transpose() * rel.P / D,
        (rel.p_dot.squaredNorm() + rel.p.dot(rel.p_ddot)) / D);
  }
};

}  // namespace

FrameState frame_state(const ir::Robot& robot, const VectorXd& q, const VectorXd& v, int link,
                       const ir::Pose& X_LF) {
  FrameState f;
  Matrix3d R_WL;
  Vector3d p_WL;
  if (v.size() == 0) {
    const LinkPose L = link_poses(robot, q)[link];
    R_WL = L.R_WL;
    p_WL = L.p_WL;
  } else {
    const LinkMotion L = link_motions(robot, q, v)[link];
    R_WL = L.R_WL;
    p_WL = L.p_WL;
    // A point fixed on the link (reference_dynamics.cpp, (f)).
    const Vector3d d = R_WL * X_LF.p;
    f.omega = L.omega;
    f.alpha = L.alpha;
    f.vel = L.vel + L.omega.cross(d);
    f.acc = L.acc + L.alpha.cross(d) + L.omega.cross(L.omega.cross(d));
  }
  f.R_WF = R_WL * X_LF.R;
  f.p_WF = p_WL + R_WL * X_LF.p;
  f.J = link_jacobian(robot, q, link, X_LF.p);
  return f;
}

double cut_distance(const ir::Robot& robot, const ir::CutJoint& cut) {
  if (cut.distance_given) return cut.distance;
  const VectorXd q0 = neutral_configuration(robot);
  const FrameState k = frame_state(robot, q0, VectorXd(), cut.link_k, cut.frame_k);
  const FrameState l = frame_state(robot, q0, VectorXd(), cut.link_l, cut.frame_l);
  return (l.p_WF - k.p_WF).norm();
}

void axis_basis(const ir::CutJoint& cut, Vector3d& axis, Vector3d& u, Vector3d& w) {
  axis = cut.axis.normalized();
  // The coordinate direction least aligned with the axis, made orthogonal to it.
  int i = 0;
  axis.cwiseAbs().minCoeff(&i);
  const Vector3d e = Vector3d::Unit(i);
  u = (e - e.dot(axis) * axis).normalized();
  w = axis.cross(u);
}

CutRows cut_rows(const ir::Robot& robot, const ir::CutJoint& cut, double D, const Vector3d& u, const Vector3d& w,
                 const VectorXd& q, const VectorXd& v) {
  const bool with_velocity = v.size() != 0;
  const FrameState k = frame_state(robot, q, v, cut.link_k, cut.frame_k);
  const FrameState l = frame_state(robot, q, v, cut.link_l, cut.frame_l);
  const Relative rel = relative(k, l, with_velocity);
  const int rows = ir::cut_rows(cut.type);
  const int nv = static_cast<int>(k.J.cols());
  CutRows out{VectorXd::Zero(rows), MatrixXd::Zero(rows, nv), VectorXd::Zero(rows)};
  RowWriter put{rel, out};
  const Vector3d x = Vector3d::UnitX(), y = Vector3d::UnitY(), z = Vector3d::UnitZ();
  const Vector3d axis = cut.axis.normalized(), child_axis = cut.child_axis.normalized();
  auto points_xyz = [&] {
    put.point(x);
    put.point(y);
    put.point(z);
  };
  auto orientation = [&] {  // y_k . z_l, z_k . x_l, x_k . y_l
    put.dot(y, z);
    put.dot(z, x);
    put.dot(x, y);
  };
  auto axis_aligned = [&] {  // the axis, carried by Fl, has no component along u or w of Fk
    put.dot(u, axis);
    put.dot(w, axis);
  };
  auto across_axis = [&] {  // Fl's origin has no component along u or w of Fk
    put.point(u);
    put.point(w);
  };
  switch (cut.type) {
    case ir::CutType::Spherical: points_xyz(); break;
    case ir::CutType::Revolute: points_xyz(); axis_aligned(); break;
    case ir::CutType::Prismatic: orientation(); across_axis(); break;
    case ir::CutType::Cylindrical: axis_aligned(); across_axis(); break;
    case ir::CutType::Universal: points_xyz(); put.dot(axis, child_axis); break;
    case ir::CutType::Fixed: points_xyz(); orientation(); break;
    case ir::CutType::Distance: put.distance(D); break;
    case ir::CutType::Mimic: throw std::logic_error("reference cut_rows: a mimic row is not a frame constraint");
  }
  if (put.n != rows) throw std::logic_error("reference cut_rows: row count");
  return out;
}

double definition_residual(const ir::Robot& robot, const ir::CutJoint& cut, double D, const VectorXd& q) {
  const FrameState k = frame_state(robot, q, VectorXd(), cut.link_k, cut.frame_k);
  const FrameState l = frame_state(robot, q, VectorXd(), cut.link_l, cut.frame_l);
  const Relative rel = relative(k, l, false);
  const Vector3d a = cut.axis.normalized(), c = cut.child_axis.normalized();
  const double coincide = rel.p.norm(), on_axis = a.cross(rel.p).norm();
  const double aligned = (rel.R * a - a).norm(), oriented = (rel.R - Matrix3d::Identity()).norm();
  switch (cut.type) {
    case ir::CutType::Spherical: return coincide;
    case ir::CutType::Revolute: return std::max(coincide, aligned);
    case ir::CutType::Prismatic: return std::max(on_axis, oriented);
    case ir::CutType::Cylindrical: return std::max(on_axis, aligned);
    case ir::CutType::Universal: return std::max(coincide, std::abs(a.dot(rel.R * c)));
    case ir::CutType::Fixed: return std::max(coincide, oriented);
    case ir::CutType::Distance: return std::abs(rel.p.norm() - D);
    case ir::CutType::Mimic: break;  // not a frame constraint (forces_test covers it)
  }
  return 0.0;
}

std::vector<int> basis_row_roles(ir::CutType type) {
  switch (type) {
    case ir::CutType::Revolute:
    case ir::CutType::Prismatic: return {0, 0, 0, +1, -1};
    case ir::CutType::Cylindrical: return {+1, -1, +1, -1};
    default: return std::vector<int>(ir::cut_rows(type), 0);
  }
}

}  // namespace jrgen::reference
