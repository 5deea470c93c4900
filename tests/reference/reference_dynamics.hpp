// Independent reference implementation of the tree dynamics, for tests only.
//
// Deliberately written differently from the production runtime (6-D spatial
// algebra in body coordinates, Featherstone-style): everything here lives in
// the WORLD frame W with 3-D vectors, rotation matrices and geometric
// Jacobians, so that the two implementations can check each other.
//
// Input is the ir::Robot exactly as the URDF reader produces it: links in
// document order, joints in user order, fixed joints included, nothing fused.
// All vectors q, v, qdd, tau, h and all dense matrices are in user order
// (docs/interface.md section 3): joints in robot.joints order, each contributing
// joint_nq / joint_nv coordinates (fixed joints none).  Joint kinematics follow
// docs/conventions.md ("translate in the joint frame, then rotate"):
//
//   revolute/continuous  q = angle       v = angle rate       omega = axis*v (axis in J)
//   prismatic            q = travel      v = travel rate      linear = axis*v (in J)
//   ball                 q = quat w,x,y,z  v = omega of C rel. P, in C
//   floating             q = p (in J), quat   v = p_dot (in J), omega (in C)
//   planar (normal n)    q = x, y, theta  v = rates; linear x_dot e1 + y_dot e2 (in J),
//                        omega = n theta_dot; (n,e1,e2) cyclic: z->(x,y), x->(y,z), y->(z,x)
//
// The root link (robot.root_link) is fixed to the world at the identity; its
// mass is ignored.  Links attached by fixed joints move with their parent and
// their mass counts.  Gravity is a world-frame vector.
#pragma once

#include <Eigen/Core>
#include <random>
#include <vector>

#include "ir/ir.hpp"

namespace jrgen::reference {

/// Zeros, identity quaternions (w = 1).
Eigen::VectorXd neutral_configuration(const ir::Robot& robot);

/// Angles and travels uniform in [-1, 1] (prismatic travels, planar and
/// floating translations scaled by 0.3), uniformly random unit quaternions.
Eigen::VectorXd random_configuration(const ir::Robot& robot, std::mt19937_64& rng);

/// Every velocity coordinate uniform in [-1, 1].
Eigen::VectorXd random_velocity(const ir::Robot& robot, std::mt19937_64& rng);

/// One step of length dt at constant v (conventions.md): quat <- quat * exp(omega dt / 2)
/// (quat normalized first), floating p <- p + p_dot dt, all others q <- q + v dt.
Eigen::VectorXd integrate(const ir::Robot& robot, const Eigen::VectorXd& q,
                          const Eigen::VectorXd& v, double dt);

/// Time derivative of q for velocity v (quat_dot = 1/2 quat * (0, omega_C),
/// other coordinates their rates).  Size nq.  For integrating in R^nq.
Eigen::VectorXd configuration_rate(const ir::Robot& robot, const Eigen::VectorXd& q,
                                   const Eigen::VectorXd& v);

/// Placement of a link frame L in the world W.
struct LinkPose {
  Eigen::Matrix3d R_WL = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p_WL = Eigen::Vector3d::Zero();
};

/// One pose per robot.links entry (same indexing); the root link at identity.
std::vector<LinkPose> link_poses(const ir::Robot& robot, const Eigen::VectorXd& q);

/// Pose, velocity and acceleration of a link frame, all in world coordinates.
struct LinkMotion {
  Eigen::Matrix3d R_WL = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p_WL = Eigen::Vector3d::Zero();
  Eigen::Vector3d omega = Eigen::Vector3d::Zero();  ///< angular velocity of L in W
  Eigen::Vector3d vel = Eigen::Vector3d::Zero();    ///< velocity of L's origin in W
  Eigen::Vector3d alpha = Eigen::Vector3d::Zero();  ///< angular acceleration of L in W
  Eigen::Vector3d acc = Eigen::Vector3d::Zero();    ///< acceleration of L's origin in W
};

/// World-frame velocity/acceleration recursion from the root.  qdd may be
/// empty (= zero: the "bias" accelerations J_dot v).
std::vector<LinkMotion> link_motions(const ir::Robot& robot, const Eigen::VectorXd& q,
                                     const Eigen::VectorXd& v,
                                     const Eigen::VectorXd& qdd = Eigen::VectorXd());

/// Geometric Jacobian of a point fixed on a link (point_in_link in the link
/// frame), 6 x nv: rows 0-2 linear velocity of the point in W, rows 3-5
/// angular velocity of the link in W.
Eigen::MatrixXd link_jacobian(const ir::Robot& robot, const Eigen::VectorXd& q, int link,
                              const Eigen::Vector3d& point_in_link);

/// J_dot v of the point (linear acceleration in W at qdd = 0).
Eigen::Vector3d point_bias_acceleration(const ir::Robot& robot, const Eigen::VectorXd& q,
                                        const Eigen::VectorXd& v, int link,
                                        const Eigen::Vector3d& point_in_link);

/// J_dot v of the link's angular velocity (angular acceleration in W at qdd = 0).
Eigen::Vector3d angular_bias_acceleration(const ir::Robot& robot, const Eigen::VectorXd& q,
                                          const Eigen::VectorXd& v, int link);

/// nv x nv: sum over non-root links of J_c^T diag(m I3, I_W) J_c, J_c the
/// Jacobian at the link's centre of mass, I_W the rotational inertia about the
/// COM in world coordinates.
Eigen::MatrixXd mass_matrix(const ir::Robot& robot, const Eigen::VectorXd& q);

/// h such that M qdd = tau - h: Coriolis + centrifugal - gravity generalized
/// force + damping * v (world-frame Newton-Euler projected with J_c^T).
Eigen::VectorXd bias_forces(const ir::Robot& robot, const Eigen::VectorXd& q,
                            const Eigen::VectorXd& v, const Eigen::Vector3d& gravity);

/// tau = M qdd + h, computed by Newton-Euler with the qdd terms included in the
/// acceleration recursion (a second route to M qdd + h, for cross checks).
Eigen::VectorXd inverse_dynamics(const ir::Robot& robot, const Eigen::VectorXd& q,
                                 const Eigen::VectorXd& v, const Eigen::VectorXd& qdd,
                                 const Eigen::Vector3d& gravity);

/// qdd = M^{-1} (tau - h) by a dense Cholesky factorization.
Eigen::VectorXd forward_dynamics(const ir::Robot& robot, const Eigen::VectorXd& q,
                                 const Eigen::VectorXd& v, const Eigen::VectorXd& tau,
                                 const Eigen::Vector3d& gravity);

/// Sum over non-root links of 1/2 m |v_com|^2 + 1/2 omega^T I_W omega, with
/// velocities from the world-frame recursion (not from M).
double kinetic_energy(const ir::Robot& robot, const Eigen::VectorXd& q, const Eigen::VectorXd& v);

/// -sum over non-root links of m g . p_com (zero at the world origin).
double potential_energy(const ir::Robot& robot, const Eigen::VectorXd& q,
                        const Eigen::Vector3d& gravity);

}  // namespace jrgen::reference
