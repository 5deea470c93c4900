// The same tree mechanism loaded into MuJoCo 2.2 (for the report's MuJoCo
// column): an MJCF written from jrgen's topology (one MuJoCo body per jrgen
// body, i.e. per moving joint with its fused links; joint frame = body frame;
// fused inertia with its centre of mass and full inertia tensor; zero
// armature, zero damping), the configuration mapped to MuJoCo's qpos, and the
// velocity map v_jrgen = P v_mujoco used to compare the two mass matrices:
// M_mujoco = P^T M_jrgen P.
//
// For the full forward-dynamics table the model also carries the joints'
// damping, and forward() runs mj_forward with contacts, limits, equality
// constraints, friction loss, the constraint solver, actuation and sensors
// disabled (passive forces only when there is damping), gravity MuJoCo's
// default (0, 0, -9.81), jrgen's default too.
//
// Joint types: revolute/continuous -> hinge, prismatic -> slide, ball -> ball,
// floating -> freejoint (root bodies only), planar -> slide e1, slide e2,
// hinge about the normal (MuJoCo applies a body's joints in order: translate,
// then rotate, as jrgen's planar joint).  Free joints: MuJoCo's linear
// velocity is in the world frame, jrgen's in the floating joint's frame
// (docs/conventions.md); P rotates it.  Angular velocities are in the body
// frame in both.
#pragma once

#include <Eigen/Core>
#include <string>

#include "topology/topology.hpp"

struct mjModel_;
struct mjData_;

namespace jrgen::report {

class MujocoModel {
 public:
  /// Writes the MJCF to `mjcf_path` and loads it.  ok() is false (and error()
  /// says why) when MuJoCo rejects the model.
  MujocoModel(const topology::Tree& tree, const std::string& mjcf_path);
  ~MujocoModel();
  MujocoModel(const MujocoModel&) = delete;
  MujocoModel& operator=(const MujocoModel&) = delete;

  bool ok() const { return m_ != nullptr; }
  const std::string& error() const { return error_; }
  int nv() const;

  /// qpos from jrgen's q (user order), then mj_forward: fills qM.
  void set_configuration(const Eigen::VectorXd& q_jrgen);
  /// MuJoCo's dense M (mj_fullM of qM), nv x nv.
  Eigen::MatrixXd dense_mass_matrix() const;
  /// v_jrgen = P v_mujoco.
  const Eigen::MatrixXd& P() const { return P_; }

  /// Full forward dynamics: qpos from q, qvel = P^T v, qfrc_applied = P^T tau
  /// (P is orthogonal: a permutation with rotation blocks).
  void set_state(const Eigen::VectorXd& q_jrgen, const Eigen::VectorXd& v_jrgen, const Eigen::VectorXd& tau_jrgen);
  /// The timed call: mj_forward.
  void forward();
  /// qdd = P qacc of the last forward(), jrgen's layout.
  Eigen::VectorXd qdd() const;

  /// The timed call: mj_factorM (L^T D L of qM into qLD) and mj_solveM.
  void factor_and_solve(const double* rhs, double* x);

 private:
  const topology::Tree& tree_;
  mjModel_* m_ = nullptr;
  mjData_* d_ = nullptr;
  std::string error_;
  Eigen::MatrixXd P_;
  void set_qpos(const Eigen::VectorXd& q_jrgen);
};

}  // namespace jrgen::report
