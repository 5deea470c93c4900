// Force elements from their definitions (reference_forces.hpp, docs/forces.md).
#include "reference/reference_forces.hpp"

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "reference/reference_dynamics.hpp"

namespace jrgen::reference {
namespace {

using Eigen::MatrixXd;
using Eigen::Vector3d;
using Eigen::VectorXd;

/// Offsets of each joint's first q and v coordinate (user order).
void joint_offsets(const ir::Robot& robot, std::vector<int>& iq, std::vector<int>& iv) {
  int nq = 0, nv = 0;
  for (const ir::Joint& j : robot.joints) {
    iq.push_back(nq);
    iv.push_back(nv);
    nq += ir::joint_nq(j.type);
    nv += ir::joint_nv(j.type);
  }
}

Vector3d point_world(const std::vector<LinkPose>& poses, int link, const Vector3d& p) {
  return poses[link].p_WL + poses[link].R_WL * p;
}

/// The spring's rest length: given, or its length at the neutral configuration.
double rest_length(const ir::Robot& robot, const ir::Spring& s) {
  if (s.rest_given) return s.rest_length;
  const std::vector<LinkPose> poses = link_poses(robot, neutral_configuration(robot));
  return (point_world(poses, s.link_l, s.p_l) - point_world(poses, s.link_k, s.p_k)).norm();
}

}  // namespace

VectorXd force_element_bias(const ir::Robot& robot, const VectorXd& q, const VectorXd& v) {
  VectorXd h = VectorXd::Zero(robot.nv());
  if (!robot.springs.empty()) {
    const std::vector<LinkPose> poses = link_poses(robot, q);
    for (const ir::Spring& s : robot.springs) {
      const Vector3d a = point_world(poses, s.link_k, s.p_k), b = point_world(poses, s.link_l, s.p_l);
      const Vector3d d = b - a;
      const double L = d.norm();
      if (!(L > 0.0)) continue;  // no direction: zero force (docs/forces.md)
      const MatrixXd Ja = link_jacobian(robot, q, s.link_k, s.p_k).topRows(3);
      const MatrixXd Jb = link_jacobian(robot, q, s.link_l, s.p_l).topRows(3);
      const double Ldot = d.dot(Jb * v - Ja * v) / L;
      const double F = s.stiffness * (L - rest_length(robot, s)) + s.damping * Ldot;
      const Vector3d f_b = -(F / L) * d;
      h -= Jb.transpose() * f_b - Ja.transpose() * f_b;
    }
  }
  std::vector<int> iq, iv;
  joint_offsets(robot, iq, iv);
  for (const ir::JointSpring& s : robot.joint_springs)
    h[iv[s.joint]] += s.stiffness * (q[iq[s.joint]] - s.rest) + s.damping * v[iv[s.joint]];
  for (const ir::JointForce& f : robot.joint_forces) h[iv[f.joint]] -= f.value;
  return h;
}

double force_element_potential(const ir::Robot& robot, const VectorXd& q) {
  double V = 0.0;
  const std::vector<LinkPose> poses = link_poses(robot, q);
  for (const ir::Spring& s : robot.springs) {
    const double L = (point_world(poses, s.link_l, s.p_l) - point_world(poses, s.link_k, s.p_k)).norm();
    V += 0.5 * s.stiffness * std::pow(L - rest_length(robot, s), 2);
  }
  std::vector<int> iq, iv;
  joint_offsets(robot, iq, iv);
  for (const ir::JointSpring& s : robot.joint_springs) V += 0.5 * s.stiffness * std::pow(q[iq[s.joint]] - s.rest, 2);
  return V;
}

}  // namespace jrgen::reference
