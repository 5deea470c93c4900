// Independent reference for the loop-closure constraints of cut joints, for
// tests only (issue 19, item 9).
//
// Written from the definitions of docs/interface.md section 2, on top of the
// world-frame tree kinematics of reference_dynamics.hpp (ir::Robot as read,
// fixed joints not fused, user order); it calls none of the runtime's or the
// generator's constraint code.  The runtime builds its rows in the world frame
// and differentiates them through per-row coefficient vectors (runtime.cpp,
// (g)/(h)); this reference instead forms the relative placement of the frame on
// l seen from the frame on k,
//
//   R = R_WFk^T R_WFl,      p = R_WFk^T (p_WFl - p_WFk)      (both in Fk),
//
// differentiates that pair (reference_constraints.cpp, (a)-(f)) and writes every
// row as a scalar function of (R, p):
//
//   point e        e . p                 e = x, y, z of Fk, or u, w
//   dot (a, b)     a . (R b)             a in Fk, b in Fl coordinates
//   distance       (|p|^2 - D^2) / (2 D)
//
// with the rows of each type in the order runtime.hpp documents (CutKind):
//   spherical   point x, y, z
//   revolute    point x, y, z; dot(u, axis), dot(w, axis)
//   prismatic   dot(y, z), dot(z, x), dot(x, y); point u, point w
//   cylindrical dot(u, axis), dot(w, axis); point u, point w
//   universal   point x, y, z; dot(axis, child_axis)
//   fixed       point x, y, z; dot(y, z), dot(z, x), dot(x, y)
//   distance    distance
// where (u, w, axis) is a right-handed orthonormal basis of Fk.  The runtime
// fixes u, w by a rule of its own; the caller passes the basis to use, and the
// rows that use it are linear in u and w (tests fit the rotation about the
// axis that relates two such bases).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "ir/ir.hpp"

namespace jrgen::reference {

/// A frame F fixed on a link, at (q, v): placement, velocity and bias
/// acceleration (qdd = 0, no gravity) of its origin and its link, all in W,
/// and its geometric Jacobian.
struct FrameState {
  Eigen::Matrix3d R_WF = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p_WF = Eigen::Vector3d::Zero();
  Eigen::Vector3d omega = Eigen::Vector3d::Zero();  ///< angular velocity of the link
  Eigen::Vector3d vel = Eigen::Vector3d::Zero();    ///< velocity of F's origin
  Eigen::Vector3d alpha = Eigen::Vector3d::Zero();  ///< angular acceleration at qdd = 0
  Eigen::Vector3d acc = Eigen::Vector3d::Zero();    ///< origin acceleration at qdd = 0
  Eigen::MatrixXd J;  ///< 6 x nv: rows 0-2 velocity of F's origin, rows 3-5 angular velocity
};

/// The frame X_LF on `link` (an index into robot.links; the root link is the
/// fixed world).  v may be empty: then the velocities and accelerations are 0.
FrameState frame_state(const ir::Robot& robot, const Eigen::VectorXd& q, const Eigen::VectorXd& v, int link,
                       const ir::Pose& X_LF);

/// The distance D of a distance cut: its <distance value>, or |p_WFl - p_WFk|
/// at the zero configuration (docs/interface.md section 2).
double cut_distance(const ir::Robot& robot, const ir::CutJoint& cut);

/// The cut's unit <axis> in Fk and a right-handed orthonormal basis (u, w,
/// axis) completing it (a choice of this reference, not the runtime's).
void axis_basis(const ir::CutJoint& cut, Eigen::Vector3d& axis, Eigen::Vector3d& u, Eigen::Vector3d& w);

/// Every row of one cut, in the order above (ir::cut_rows(cut.type) of them).
struct CutRows {
  Eigen::VectorXd phi;    ///< Phi
  Eigen::MatrixXd Phiq;   ///< d Phi / d v, rows x nv, user order
  Eigen::VectorXd gamma;  ///< -(d/dt Phiq) v = -Phi_ddot at qdd = 0
};

/// The rows of `cut` at (q, v) with the basis (u, w) (unit, orthogonal to
/// the axis, u x w = axis) and distance D.  v may be empty: gamma is then 0.
CutRows cut_rows(const ir::Robot& robot, const ir::CutJoint& cut, double D, const Eigen::Vector3d& u,
                 const Eigen::Vector3d& w, const Eigen::VectorXd& q, const Eigen::VectorXd& v);

/// How far q is from the set docs/interface.md section 2 defines for the cut,
/// written from the definition alone (no rows): the largest applicable term of
///   |p|                 origins coincide (spherical, revolute, universal, fixed)
///   |axis x p|          origins move only along the axis (prismatic, cylindrical)
///   |R axis - axis|     the axis stays aligned, in the same sense (revolute, cylindrical)
///   ||R - I||_F         orientation fixed (prismatic, fixed)
///   |axis . R child_axis|  axes perpendicular (universal)
///   ||p| - D|           distance
/// Zero exactly on the set.  Any 2 or 3 smooth rows that encode an axis
/// alignment or an orientation also vanish elsewhere (the runtime's do at
/// R axis = -axis and at half turns about a coordinate axis of Fk); this
/// does not.
double definition_residual(const ir::Robot& robot, const ir::CutJoint& cut, double D, const Eigen::VectorXd& q);

/// The rows of `cut` that use the basis (u, w): for each, +1 when it is the
/// u member of its pair, -1 when the w member, 0 when it does not use it.
std::vector<int> basis_row_roles(ir::CutType type);

}  // namespace jrgen::reference
