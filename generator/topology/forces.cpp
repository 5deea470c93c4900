// Force elements on the body tree (docs/interface.md section 2b): <spring> points
// moved onto the bodies that carry their links (fixed joints fused), rest
// lengths resolved; <joint_spring> and <joint_force> onto their joints' bodies.
#include <algorithm>
#include <cmath>

#include "ir/error.hpp"
#include "topology/topology.hpp"

namespace jrgen::topology {

namespace {

// World placement of every body at the zero configuration (every joint
// coordinate 0, identity quaternions): the joint frames composed root first
// (parents have larger Lemma 2 indices).
std::vector<ir::Pose> zero_configuration_poses(const Tree& tree) {
  std::vector<ir::Pose> X_W(tree.bodies.size());
  for (std::size_t i = tree.bodies.size(); i-- > 0;) {
    const Body& b = tree.bodies[i];
    X_W[i] = b.parent_lem < 0 ? b.X_PJ : compose(X_W[b.parent_lem], b.X_PJ);
  }
  return X_W;
}

Eigen::Vector3d world_point(const std::vector<ir::Pose>& X_W, int body, const Eigen::Vector3d& p) {
  return body < 0 ? p : Eigen::Vector3d(X_W[body].R * p + X_W[body].p);
}

Spring place_spring(const ir::Robot& robot, const Tree& tree, const std::vector<ir::Pose>& X_W, int s) {
  const ir::Spring& is = robot.springs[s];
  const LinkPlacement& k = tree.links[is.link_k];
  const LinkPlacement& l = tree.links[is.link_l];
  Spring spring;
  spring.name = is.name;
  spring.spring_ir = s;
  spring.body_k = k.body_lem;
  spring.body_l = l.body_lem;
  spring.p_k = k.X_BL.R * is.p_k + k.X_BL.p;
  spring.p_l = l.X_BL.R * is.p_l + l.X_BL.p;
  spring.stiffness = is.stiffness;
  spring.damping = is.damping;
  if (!spring.p_k.allFinite() || !spring.p_l.allFinite())
    throw Error(is.where, "spring", is.name,
                "its points, composed with the fixed joints of their links, overflow double precision; "
                "check xyz (metres)");
  if (spring.body_k == spring.body_l)
    throw Error(is.where, "spring", is.name,
                "joins two links of the same rigid body (after fusing fixed joints); it exerts no net force: attach it to "
                "links that move relative to each other, or remove it");
  if (is.rest_given) {
    spring.rest_length = is.rest_length;
    return spring;
  }
  const Eigen::Vector3d a = world_point(X_W, spring.body_k, spring.p_k);
  const Eigen::Vector3d b = world_point(X_W, spring.body_l, spring.p_l);
  spring.rest_length = (b - a).norm();
  // Zero up to the rounding of the composed frames: the direction of the
  // force at rest is undefined there.
  if (!(spring.rest_length > 1e-12 * std::max({1.0, a.norm(), b.norm()})))
    throw Error(is.where, "spring", is.name,
                "its two points coincide at the zero configuration, so rest_length (by default their "
                "distance there) leaves the force's direction undefined at rest; give rest_length");
  return spring;
}

}  // namespace

bool Tree::has_force_elements() const {
  if (!springs.empty()) return true;
  for (const Body& b : bodies)
    if (b.stiffness != 0.0 || b.force != 0.0) return true;
  return false;
}

void place_force_elements(const ir::Robot& robot, Tree& tree) {
  const std::vector<ir::Pose> X_W = zero_configuration_poses(tree);
  for (int s = 0; s < static_cast<int>(robot.springs.size()); ++s)
    tree.springs.push_back(place_spring(robot, tree, X_W, s));
  // A one-dof joint's body is the one its child link sits on.
  auto body_of = [&](int joint) -> Body& { return tree.bodies[tree.links[robot.joints[joint].child_link].body_lem]; };
  for (const ir::JointSpring& js : robot.joint_springs) {
    Body& b = body_of(js.joint);
    b.stiffness = js.stiffness;
    b.rest = js.rest;
    b.damping += js.damping;
  }
  for (const ir::JointForce& jf : robot.joint_forces) body_of(jf.joint).force = jf.value;
}

}  // namespace jrgen::topology
