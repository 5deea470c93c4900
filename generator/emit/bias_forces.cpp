#include "emit/bias_forces.hpp"

#include <fmt/format.h>

#include "emit/force_elements.hpp"
#include "emit/mass_matrix.hpp"

namespace jrgen::emit {

namespace {

// The body accelerations at qdd = 0 with gravity: without gravity those of
// body_velocities (shared with any other block that uses them); with it, the
// same forward sweep from the base acceleration [0; -g] (Featherstone's
// trick): a_C = X a_P + c, c = c_J + v_C x v_J the body's own term.
std::vector<Motion6> accelerations(Program& P, const topology::Tree& t, const std::vector<BodyFrame>& frames,
                                   const std::vector<BodyMotion6>& motion, const Eigen::Vector3d& gravity) {
  std::vector<Motion6> a(t.bodies.size());
  if (gravity.isZero(0.0)) {
    for (std::size_t i = 0; i < a.size(); ++i) a[i] = motion[i].a;
    return a;
  }
  const Motion6 a_base = join({0.0, 0.0, 0.0}, vec3(-gravity));
  for (std::size_t i = a.size(); i-- > 0;) {
    const int parent = t.bodies[i].parent_lem;
    P.comment(fmt::format("body {}: acceleration of '{}' with gravity", i, t.bodies[i].joint_name));
    a[i] = motion_to_child(frames[i], parent < 0 ? a_base : a[parent]) + motion[i].c;
  }
  return a;
}

}  // namespace

std::vector<Value> bias_forces(Program& P, const topology::Tree& t, const std::vector<BodyFrame>& frames,
                               const std::vector<BodyMotion6>& motion, const Eigen::Vector3d& gravity,
                               const std::string& v) {
  const std::vector<Motion6> a = accelerations(P, t, frames, motion, gravity);
  // Per body: f = I a + v x* (I v), I the body's own (constant) inertia.
  std::vector<Motion6> f(t.bodies.size());
  for (std::size_t i = 0; i < f.size(); ++i) {
    P.comment(fmt::format("body {}: Newton-Euler force of '{}'", i, t.bodies[i].joint_name));
    const RigidInertia I = rigid_body_inertia(t.bodies[i].inertial);
    f[i] = inertia_times(I, a[i]) + cross_force(motion[i].v, inertia_times(I, motion[i].v));
  }
  // Backward sweep, leaves first: every child has added its force before its
  // parent is projected.
  std::vector<Value> h(static_cast<std::size_t>(t.nv), 0.0);
  for (std::size_t i = 0; i < f.size(); ++i) {
    const topology::Body& b = t.bodies[i];
    P.comment(fmt::format("body {}: bias forces of '{}'", i, b.joint_name));
    for (int k = 0; k < b.nv; ++k) {
      Value hk = dot6(frames[i].S[k], f[i]);
      if (b.damping != 0.0) hk += b.damping * P.input(fmt::format("{}[{}]", v, b.v_user + k));
      h[static_cast<std::size_t>(b.v_lem + k)] = hk;
    }
    if (b.parent_lem >= 0) f[b.parent_lem] = f[b.parent_lem] + force_to_parent(frames[i], f[i]);
  }
  add_force_elements(P, t, frames, motion, h);  // springs, joint springs, joint forces (section 2b)
  return h;
}

}  // namespace jrgen::emit
