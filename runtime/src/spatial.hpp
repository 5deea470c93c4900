// jrgen runtime, internal: the spatial algebra shared by runtime.cpp (M, h,
// constraint terms) and articulated.cpp (articulated-body algorithm).  Spatial
// vectors are [angular; linear] in a body's own coordinates; a body C with
// parent P has X_PC = (R, p): R = R_PC, p = C's origin in P coordinates.
#pragma once

#include <Eigen/Geometry>  // cross products

#include "jrgen/runtime.hpp"

namespace jr::spatial {

// (a) motion P -> C: [R^T w; R^T (v - p x w)].
inline Vector6d motion_to_child(const BodyState& b, const Vector6d& m_P) {
  const Eigen::Vector3d w_P = m_P.head<3>(), v_P = m_P.tail<3>();
  Vector6d m_C;
  m_C.head<3>() = b.R.transpose() * w_P;
  m_C.tail<3>() = b.R.transpose() * (v_P - b.p.cross(w_P));
  return m_C;
}

// (b) force C -> P: [R n + p x (R f); R f].
inline Vector6d force_to_parent(const BodyState& b, const Vector6d& f_C) {
  Vector6d f_P;
  f_P.tail<3>() = b.R * f_C.tail<3>();
  f_P.head<3>() = b.R * f_C.head<3>() + b.p.cross(f_P.tail<3>());
  return f_P;
}

// (e) motion cross motion.
inline Vector6d cross_motion(const Vector6d& a, const Vector6d& b) {
  Vector6d out;
  out.head<3>() = a.head<3>().cross(b.head<3>());
  out.tail<3>() = a.head<3>().cross(b.tail<3>()) + a.tail<3>().cross(b.head<3>());
  return out;
}

// (f) motion cross force.
inline Vector6d cross_force(const Vector6d& v, const Vector6d& f) {
  Vector6d out;
  out.head<3>() = v.head<3>().cross(f.head<3>()) + v.tail<3>().cross(f.tail<3>());
  out.tail<3>() = v.head<3>().cross(f.tail<3>());
  return out;
}

}  // namespace jr::spatial
