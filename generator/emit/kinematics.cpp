#include "emit/kinematics.hpp"

#include <fmt/format.h>

#include <cmath>

namespace jrgen::emit {

namespace {

// The unit axis as +-e_k: k in 0..2 and the sign, or k = -1.
std::pair<int, double> aligned_axis(const Eigen::Vector3d& a) {
  for (int k = 0; k < 3; ++k)
    if (std::abs(a[k]) == 1.0 && a[(k + 1) % 3] == 0.0 && a[(k + 2) % 3] == 0.0) return {k, a[k]};
  return {-1, 0.0};
}

// Rotation by `angle` (c = cos, s = sin) about the unit axis a: about a
// coordinate axis exactly (its row and column are those of the identity), else
// c 1 + s [a]x + (1 - c) a a^T, entry by entry in the order of Eigen's
// AngleAxis::toRotationMatrix (the runtime's).
Mat3 axis_rotation(const Eigen::Vector3d& a, Value c, Value s) {
  const auto [k, sign] = aligned_axis(a);
  if (k >= 0) {
    const int i = (k + 1) % 3, j = (k + 2) % 3;  // R = [[c, -s], [s, c]] on the (i, j) plane
    const Value ss = sign * s;
    Mat3 R = identity3();
    R[3 * i + i] = c;
    R[3 * j + j] = c;
    R[3 * i + j] = -ss;
    R[3 * j + i] = ss;
    return R;
  }
  const Value one_c = 1.0 - c;
  const Vec3 sa = s * vec3(a), ca = one_c * vec3(a);
  Mat3 R;
  R[0] = ca[0] * a[0] + c;
  R[4] = ca[1] * a[1] + c;
  R[8] = ca[2] * a[2] + c;
  const Value xy = ca[0] * a[1], xz = ca[0] * a[2], yz = ca[1] * a[2];
  R[1] = xy - sa[2];
  R[3] = xy + sa[2];
  R[2] = xz + sa[1];
  R[6] = xz - sa[1];
  R[5] = yz - sa[0];
  R[7] = yz + sa[0];
  return R;
}

// Rotation of the quaternion (w, x, y, z) = q[i..i+3], normalized: with
// s = 2 / |q|^2 the products below are those of the unit quaternion (no
// square root; Eigen's toRotationMatrix after normalize() rounds
// differently by a few ulps).
Mat3 quaternion_rotation(Program& P, const std::string& q, int i) {
  const Value w = P.input(fmt::format("{}[{}]", q, i)), x = P.input(fmt::format("{}[{}]", q, i + 1));
  const Value y = P.input(fmt::format("{}[{}]", q, i + 2)), z = P.input(fmt::format("{}[{}]", q, i + 3));
  const Value s = 2.0 / (w * w + x * x + y * y + z * z);
  const Value tx = s * x, ty = s * y, tz = s * z;
  const Value twx = tx * w, twy = ty * w, twz = tz * w, txx = tx * x, txy = ty * x, txz = tz * x;
  const Value tyy = ty * y, tyz = tz * y, tzz = tz * z;
  return {1.0 - (tyy + tzz), txy - twz, txz + twy,  //
          txy + twz, 1.0 - (txx + tzz), tyz - twx,  //
          txz - twy, tyz + twx, 1.0 - (txx + tyy)};
}

Motion6 angular_column(const Vec3& a) { return join(a, {0.0, 0.0, 0.0}); }
Motion6 linear_column(const Vec3& a) { return join({0.0, 0.0, 0.0}, a); }

// The joint alone: R_J (C relative to J), t (C's origin in J) and S.
void joint_motion(Program& P, const topology::Body& b, const std::string& q, Mat3& R_J, Vec3& t,
                  std::vector<Motion6>& S) {
  const auto qi = [&](int k) { return P.input(fmt::format("{}[{}]", q, b.q_user + k)); };
  R_J = identity3();
  t = {0.0, 0.0, 0.0};
  switch (b.type) {
    case ir::JointType::Revolute:
    case ir::JointType::Continuous:
      R_J = axis_rotation(b.axis, cos(qi(0)), sin(qi(0)));
      S = {angular_column(vec3(b.axis))};  // the axis is fixed under its own rotation
      break;
    case ir::JointType::Prismatic:
      t = qi(0) * vec3(b.axis);
      S = {linear_column(vec3(b.axis))};
      break;
    case ir::JointType::Ball:
      R_J = quaternion_rotation(P, q, b.q_user);
      S = {angular_column({1.0, 0.0, 0.0}), angular_column({0.0, 1.0, 0.0}), angular_column({0.0, 0.0, 1.0})};
      break;
    case ir::JointType::Floating: {
      R_J = quaternion_rotation(P, q, b.q_user + 3);
      t = {qi(0), qi(1), qi(2)};
      // pdot is in J, S in C: the columns of R_J^T; then omega in C.
      const Mat3 Rt = transpose(R_J);
      S = {linear_column({Rt[0], Rt[3], Rt[6]}), linear_column({Rt[1], Rt[4], Rt[7]}),
           linear_column({Rt[2], Rt[5], Rt[8]}), angular_column({1.0, 0.0, 0.0}),
           angular_column({0.0, 1.0, 0.0}), angular_column({0.0, 0.0, 1.0})};
      break;
    }
    case ir::JointType::Planar:
      R_J = axis_rotation(b.axis, cos(qi(2)), sin(qi(2)));
      t = qi(0) * vec3(b.e1) + qi(1) * vec3(b.e2);
      S = {linear_column(tmul(R_J, vec3(b.e1))), linear_column(tmul(R_J, vec3(b.e2))),
           angular_column(vec3(b.axis))};
      break;
    case ir::JointType::Fixed: break;
  }
}

}  // namespace

std::vector<BodyFrame> joint_frames(Program& program, const topology::Tree& tree, const std::string& q) {
  std::vector<BodyFrame> frames(tree.bodies.size());
  for (std::size_t i = 0; i < tree.bodies.size(); ++i) {
    const topology::Body& b = tree.bodies[i];
    program.comment(fmt::format("body {}: joint transform X_PC of '{}' ({})", i, b.joint_name,
                                ir::joint_type_name(b.type)));
    Mat3 R_J;
    Vec3 t;
    joint_motion(program, b, q, R_J, t, frames[i].S);
    const Mat3 R_PJ = mat3(b.X_PJ.R);
    frames[i].R = mul(R_PJ, R_J);
    frames[i].p = vec3(b.X_PJ.p) + mul(R_PJ, t);
  }
  return frames;
}

std::vector<BodyMotion6> body_velocities(Program& program, const topology::Tree& tree,
                                         const std::vector<BodyFrame>& frames, const std::string& v) {
  std::vector<BodyMotion6> out(tree.bodies.size());
  // Root end first: parents have larger Lemma 2 indices.
  for (std::size_t i = tree.bodies.size(); i-- > 0;) {
    const topology::Body& b = tree.bodies[i];
    program.comment(fmt::format("body {}: velocity and velocity-product acceleration of '{}'", i, b.joint_name));
    Motion6 vJ{};
    for (int k = 0; k < b.nv; ++k) {
      const Value qd = program.input(fmt::format("{}[{}]", v, b.v_user + k));
      for (int r = 0; r < 6; ++r) vJ[r] += frames[i].S[k][r] * qd;
    }
    // c_J = (dS/dt) qd for joints whose translation is in the joint frame.
    Motion6 cJ{};
    if (b.type == ir::JointType::Floating || b.type == ir::JointType::Planar)
      cJ = join({0.0, 0.0, 0.0}, -1.0 * cross(angular(vJ), linear(vJ)));
    if (b.parent_lem < 0) {
      out[i] = {vJ, cJ, cJ};
      continue;
    }
    const BodyMotion6& P = out[b.parent_lem];
    out[i].v = motion_to_child(frames[i], P.v) + vJ;
    out[i].a = motion_to_child(frames[i], P.a) + cJ + cross_motion(out[i].v, vJ);
    out[i].c = cJ + cross_motion(out[i].v, vJ);
  }
  return out;
}

Vec3 angular(const Motion6& m) { return {m[0], m[1], m[2]}; }
Vec3 linear(const Motion6& m) { return {m[3], m[4], m[5]}; }
Motion6 join(const Vec3& w, const Vec3& v) { return {w[0], w[1], w[2], v[0], v[1], v[2]}; }

Motion6 operator+(const Motion6& a, const Motion6& b) {
  Motion6 c;
  for (int r = 0; r < 6; ++r) c[r] = a[r] + b[r];
  return c;
}

Value dot6(const Motion6& a, const Motion6& b) { return dot(angular(a), angular(b)) + dot(linear(a), linear(b)); }

Motion6 motion_to_child(const BodyFrame& b, const Motion6& m_P) {
  const Vec3 w_P = angular(m_P);
  return join(tmul(b.R, w_P), tmul(b.R, linear(m_P) - cross(b.p, w_P)));
}

Motion6 force_to_parent(const BodyFrame& b, const Motion6& f_C) {
  const Vec3 f_P = mul(b.R, linear(f_C));
  return join(mul(b.R, angular(f_C)) + cross(b.p, f_P), f_P);
}

Motion6 cross_motion(const Motion6& a, const Motion6& b) {
  return join(cross(angular(a), angular(b)), cross(angular(a), linear(b)) + cross(linear(a), angular(b)));
}

Motion6 cross_force(const Motion6& v, const Motion6& f) {
  return join(cross(angular(v), angular(f)) + cross(linear(v), linear(f)), cross(angular(v), linear(f)));
}

}  // namespace jrgen::emit
