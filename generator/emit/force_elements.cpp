#include "emit/force_elements.hpp"

#include <fmt/format.h>
#include <jrgen/runtime.hpp>

namespace jrgen::emit {

namespace {

// World placement of a body (R_WB, o_B), the base's being the identity.
struct WorldPose {
  Mat3 R = identity3();
  Vec3 p{0.0, 0.0, 0.0};
};

// Root first (parents have larger Lemma 2 indices): X_W = X_W,parent X_PC.
std::vector<WorldPose> world_poses(const topology::Tree& t, const std::vector<BodyFrame>& frames) {
  std::vector<WorldPose> X(t.bodies.size());
  for (std::size_t i = X.size(); i-- > 0;) {
    const int parent = t.bodies[i].parent_lem;
    if (parent < 0) {
      X[i] = {frames[i].R, frames[i].p};
    } else {
      X[i].R = mul(X[parent].R, frames[i].R);
      X[i].p = X[parent].p + mul(X[parent].R, frames[i].p);
    }
  }
  return X;
}

// World position x and velocity xd of the point p (body frame) of body i.
void point_motion(const std::vector<WorldPose>& X, const std::vector<BodyMotion6>& motion, int i,
                  const Eigen::Vector3d& p, bool velocity, Vec3& x, Vec3& xd) {
  const Vec3 r = vec3(p);
  xd = {0.0, 0.0, 0.0};
  if (i < 0) {
    x = r;
    return;
  }
  x = mul(X[i].R, r) + X[i].p;
  if (velocity) xd = mul(X[i].R, linear(motion[i].v) + cross(angular(motion[i].v), r));
}

// h -= J^T f for the world force f at the world point x of body i.
void subtract_point_force(const topology::Tree& t, const std::vector<BodyFrame>& frames,
                          const std::vector<WorldPose>& X, int i, const Vec3& x, const Vec3& f, std::vector<Value>& h) {
  for (int j = i; j >= 0; j = t.bodies[j].parent_lem) {
    const Vec3 f_j = tmul(X[j].R, f);
    const Vec3 n_j = cross(tmul(X[j].R, x - X[j].p), f_j);
    const topology::Body& b = t.bodies[j];
    for (int k = 0; k < b.nv; ++k) {
      const Motion6& S = frames[j].S[k];
      h[b.v_lem + k] = h[b.v_lem + k] - (dot(angular(S), n_j) + dot(linear(S), f_j));
    }
  }
}

}  // namespace

void add_force_elements(Program& P, const topology::Tree& t, const std::vector<BodyFrame>& frames,
                        const std::vector<BodyMotion6>& motion, std::vector<Value>& h, const std::string& q) {
  for (const topology::Body& b : t.bodies)
    if (b.stiffness != 0.0 || b.force != 0.0) {
      P.comment(fmt::format("joint spring and joint force of '{}'", b.joint_name));
      h[b.v_lem] = h[b.v_lem] + (b.stiffness * (P.input(fmt::format("{}[{}]", q, b.q_user)) - b.rest) - b.force);
    }
  if (t.springs.empty()) return;
  const std::vector<WorldPose> X = world_poses(t, frames);
  for (const topology::Spring& s : t.springs) {
    P.comment(fmt::format("spring '{}'", s.name));
    const bool damped = s.damping != 0.0;
    Vec3 a, ad, b, bd;
    point_motion(X, motion, s.body_k, s.p_k, damped, a, ad);
    point_motion(X, motion, s.body_l, s.p_l, damped, b, bd);
    const Vec3 d = b - a;
    const Value L = sqrt(dot(d, d) + jr::kSpringLengthGuard);
    Value tension = s.stiffness * (L - s.rest_length);
    if (damped) tension = tension + s.damping * (dot(d, bd - ad) / L);
    const Vec3 f_b = (-1.0 * (tension / L)) * d;
    subtract_point_force(t, frames, X, s.body_l, b, f_b, h);
    subtract_point_force(t, frames, X, s.body_k, a, -1.0 * f_b, h);
  }
}

}  // namespace jrgen::emit
