// jrgen runtime: force elements (springs, joint springs, joint forces) and
// the potential energy (docs/interface.md section 2b; formulas in runtime.hpp).
//
// A force f (world coordinates) at the world point P of body B enters the
// generalized forces of the dofs on the path from B to the base as J^T f:
// dof d of body j, with motion subspace column S_d = [s_w; s_v] in j's
// coordinates, gets s_w . (r x f_j) + s_v . f_j, where f_j = R_Wj^T f and
// r = R_Wj^T (P - o_j) (o_j, R_Wj: j's world placement).
#include <Eigen/Geometry>
#include <cmath>

#include "jrgen/runtime.hpp"

namespace jr {

namespace {

using Eigen::Vector3d;

Vector3d vec3(const double* x) { return Vector3d(x[0], x[1], x[2]); }

// World position x and velocity xd of the point p (body frame) of body i
// (needs world_poses()).  The velocity is the sum over the dofs on the path
// to the base of their world twists (w, v at the body origin o_j) applied at
// x: v + w x (x - o_j); a loop up the path (no recursion: chains may be long).
void point_motion(const Model& model, const BodyState* bodies, const double* v, std::int32_t i, const double* p,
                  Vector3d& x, Vector3d& xd) {
  const Vector3d r = vec3(p);
  xd.setZero();
  if (i < 0) {
    x = r;
    return;
  }
  x = bodies[i].R_WC * r + bodies[i].p_WC;
  if (v == nullptr) return;
  for (std::int32_t j = i; j >= 0; j = model.bodies[j].parent) {
    const BodyModel& bm = model.bodies[j];
    Vector6d twist = Vector6d::Zero();
    for (std::int32_t k = 0; k < bm.nv; ++k) twist += bodies[j].S.col(k) * v[bm.v_user + k];
    const Vector3d w = bodies[j].R_WC * twist.head<3>();
    xd += bodies[j].R_WC * twist.tail<3>() + w.cross(x - bodies[j].p_WC);
  }
}

// h -= J^T f for the world force f at world point x of body i.
void subtract_point_force(const Model& model, const BodyState* bodies, std::int32_t i, const Vector3d& x,
                          const Vector3d& f, double* h_lem) {
  for (std::int32_t j = i; j >= 0; j = model.bodies[j].parent) {
    const BodyState& b = bodies[j];
    const Vector3d f_j = b.R_WC.transpose() * f;
    const Vector3d r = b.R_WC.transpose() * (x - b.p_WC);
    const Vector3d n_j = r.cross(f_j);
    const BodyModel& bm = model.bodies[j];
    for (std::int32_t k = 0; k < bm.nv; ++k)
      h_lem[bm.v_lem + k] -= b.S.col(k).head<3>().dot(n_j) + b.S.col(k).tail<3>().dot(f_j);
  }
}

// Length of d with the guard of runtime.hpp (zero force where d = 0).
double guarded_length(const Vector3d& d) { return std::sqrt(d.dot(d) + kSpringLengthGuard); }

}  // namespace

void force_elements(const Model& model, const ForceModel& forces, BodyState* bodies, const double* q,
                    const double* v, double* h_lem) {
  for (std::int32_t j = 0; j < forces.njoints; ++j) {
    const JointForceModel& jf = forces.joints[j];
    const BodyModel& bm = model.bodies[jf.body];
    h_lem[bm.v_lem] += jf.stiffness * (q[bm.q_user] - jf.rest) - jf.force;
  }
  if (forces.nsprings == 0) return;
  world_poses(model, bodies);
  for (std::int32_t s = 0; s < forces.nsprings; ++s) {
    const SpringModel& sp = forces.springs[s];
    Vector3d a, ad, b, bd;
    point_motion(model, bodies, sp.damping != 0.0 ? v : nullptr, sp.body_k, sp.p_k, a, ad);
    point_motion(model, bodies, sp.damping != 0.0 ? v : nullptr, sp.body_l, sp.p_l, b, bd);
    const Vector3d d = b - a;
    const double L = guarded_length(d);
    // F / L: the spring's tension over its length; f_b = -(F / L) d.
    double tension = sp.stiffness * (L - sp.rest_length);
    if (sp.damping != 0.0) tension += sp.damping * (d.dot(bd - ad) / L);
    const Vector3d f_b = -(tension / L) * d;
    subtract_point_force(model, bodies, sp.body_l, b, f_b, h_lem);
    subtract_point_force(model, bodies, sp.body_k, a, -f_b, h_lem);
  }
}

double potential_energy(const Model& model, const ForceModel* forces, BodyState* bodies, const double* q) {
  kinematics(model, bodies, q);
  world_poses(model, bodies);
  const Vector3d g = vec3(model.gravity);
  double V = 0.0;
  for (std::int32_t i = 0; i < model.nb; ++i) {
    const BodyModel& bm = model.bodies[i];
    const Vector3d c = bodies[i].R_WC * vec3(bm.com) + bodies[i].p_WC;
    V -= bm.mass * g.dot(c);
  }
  if (forces == nullptr) return V;
  for (std::int32_t j = 0; j < forces->njoints; ++j) {
    const JointForceModel& jf = forces->joints[j];
    const double e = q[model.bodies[jf.body].q_user] - jf.rest;
    V += 0.5 * jf.stiffness * e * e;
  }
  for (std::int32_t s = 0; s < forces->nsprings; ++s) {
    const SpringModel& sp = forces->springs[s];
    Vector3d a, ad, b, bd;
    point_motion(model, bodies, nullptr, sp.body_k, sp.p_k, a, ad);
    point_motion(model, bodies, nullptr, sp.body_l, sp.p_l, b, bd);
    const double e = guarded_length(b - a) - sp.rest_length;
    V += 0.5 * sp.stiffness * e * e;
  }
  return V;
}

}  // namespace jr
