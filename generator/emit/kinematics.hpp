// The kinematics block of the specialized terms (issue 20, item 1): joint
// transforms, motion subspaces and body velocities of one model as
// straight-line Program values, with every constant of the model folded in
// (fixed joint frames, identity rotations, zero offsets, axis-aligned axes;
// one sine and cosine per revolute or planar joint, shared through the
// Program).  The formulas are those of the runtime's jr::kinematics and of
// the forward sweep of jr::bias_forces (runtime/src/runtime.cpp; notation of
// docs/conventions.md): body C, its parent P, joint frame J,
//   R = R_PC = R_PJ R_J(q),  p = p_PC = p_PJ + R_PJ t(q),
// spatial motion [w; v] in C coordinates, angular part first.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "emit/program.hpp"
#include "topology/topology.hpp"

namespace jrgen::emit {

using Motion6 = std::array<Value, 6>;  ///< spatial motion or force, angular part first

/// One moving body of the tree (Lemma 2 order).
struct BodyFrame {
  Mat3 R;                      ///< R_PC: C coordinates into P coordinates
  Vec3 p;                      ///< p_PC: C's origin in P
  std::vector<Motion6> S;      ///< nv columns of the motion subspace, C coordinates
};

/// Joint transforms and motion subspaces at q (Program inputs "<q>[i]",
/// user order); quaternions normalized as the runtime does.  Lemma 2 order.
std::vector<BodyFrame> joint_frames(Program& program, const topology::Tree& tree, const std::string& q = "q");

/// Per body at (q, v) with qdd = 0 and no gravity: the velocity v_C and the
/// velocity-product acceleration a_C (C coordinates), by the forward sweep of
/// recursive Newton-Euler (root end first), and the body's own term of it,
/// c = c_J + v_C x v_J (a_C = X a_P + c; the articulated-body algorithm's c_i).
struct BodyMotion6 {
  Motion6 v;
  Motion6 a;
  Motion6 c;
};
std::vector<BodyMotion6> body_velocities(Program& program, const topology::Tree& tree,
                                         const std::vector<BodyFrame>& frames, const std::string& v = "v");

// Spatial algebra on Values (formulas (a)-(f) of runtime/src/runtime.cpp).
Motion6 motion_to_child(const BodyFrame& b, const Motion6& m_P);  ///< (a)
Motion6 force_to_parent(const BodyFrame& b, const Motion6& f_C);  ///< (b)
Motion6 cross_motion(const Motion6& a, const Motion6& b);         ///< (e)
Motion6 cross_force(const Motion6& v, const Motion6& f);          ///< (f)
Motion6 operator+(const Motion6& a, const Motion6& b);
Value dot6(const Motion6& a, const Motion6& b);
Vec3 angular(const Motion6& m);
Vec3 linear(const Motion6& m);
Motion6 join(const Vec3& angular, const Vec3& linear);

}  // namespace jrgen::emit
