#include "emit/mass_matrix.hpp"

#include <fmt/format.h>

namespace jrgen::emit {

RigidInertia rigid_body_inertia(const ir::Inertial& in) {
  // As jr::body_inertia: I_o = I_com + m (|c|^2 1 - c c^T), h = m c; the
  // upper triangle mirrored, so the Values of I are exactly symmetric.
  const Eigen::Vector3d c = in.com;
  const Eigen::Matrix3d Io = in.I_com + in.mass * (c.squaredNorm() * Eigen::Matrix3d::Identity() - c * c.transpose());
  RigidInertia I{in.mass, vec3(in.mass * c), {}};
  for (int r = 0; r < 3; ++r)
    for (int k = r; k < 3; ++k) I.I[3 * r + k] = I.I[3 * k + r] = Io(r, k);
  return I;
}

Motion6 inertia_times(const RigidInertia& I, const Motion6& m) {
  const Vec3 w = angular(m), v = linear(m);
  return join(mul(I.I, w) + cross(I.h, v), I.m * v - cross(I.h, w));
}

RigidInertia add_to_parent(const BodyFrame& b, const RigidInertia& C, const RigidInertia& P) {
  // (d) with hr = R h:  m_P += m,  h_P += hr + m p,
  //   I_P += R I R^T + (2 p.hr + m |p|^2) 1 - m p p^T - p hr^T - hr p^T,
  // the symmetric update computed on its upper triangle only.
  const Vec3& p = b.p;
  const Vec3 hr = mul(b.R, C.h);
  const Vec3 mp = C.m * p;
  RigidInertia out{P.m + C.m, P.h + (hr + mp), {}};
  const Mat3 RI = mul(b.R, C.I);
  const Value d = 2.0 * dot(p, hr) + dot(mp, p);
  for (int r = 0; r < 3; ++r)
    for (int c = r; c < 3; ++c) {
      Value e = RI[3 * r] * b.R[3 * c] + RI[3 * r + 1] * b.R[3 * c + 1] + RI[3 * r + 2] * b.R[3 * c + 2];
      if (r == c) e += d;
      e = e - mp[r] * p[c] - p[r] * hr[c] - hr[r] * p[c];
      out.I[3 * r + c] = out.I[3 * c + r] = P.I[3 * r + c] + e;
    }
  return out;
}

namespace {

// Eq. (14): composite inertias, K_i = M_i + the sum over i's children; the
// children come first in Lemma 2 order, so one leaves-first sweep completes
// each body before it is added to its parent.
std::vector<RigidInertia> composite_inertias(Program& P, const topology::Tree& t,
                                             const std::vector<BodyFrame>& frames) {
  std::vector<RigidInertia> Ic(t.bodies.size());
  for (std::size_t i = 0; i < t.bodies.size(); ++i) Ic[i] = rigid_body_inertia(t.bodies[i].inertial);
  for (std::size_t i = 0; i < t.bodies.size(); ++i) {
    const int parent = t.bodies[i].parent_lem;
    if (parent < 0) continue;
    P.comment(fmt::format("body {}: composite inertia of '{}' added to its parent", i, t.bodies[i].joint_name));
    Ic[parent] = add_to_parent(frames[i], Ic[i], Ic[parent]);
  }
  return Ic;
}

}  // namespace

std::vector<Value> mass_matrix_packed(Program& P, const topology::Tree& t, const std::vector<BodyFrame>& frames) {
  const std::vector<RigidInertia> Ic = composite_inertias(P, t, frames);
  std::vector<Value> M(static_cast<std::size_t>(t.nnz()), 0.0);
  const auto at = [&](int row, int col) -> Value& { return M[static_cast<std::size_t>(t.packed(row, col))]; };
  for (std::size_t i = 0; i < t.bodies.size(); ++i) {
    const topology::Body& b = t.bodies[i];
    P.comment(fmt::format("body {}: columns of M of '{}' (eq. 18)", i, b.joint_name));
    // F = Ic_i S_i; the diagonal block S_i^T F (lower triangle).
    std::vector<Motion6> F(static_cast<std::size_t>(b.nv));
    for (int k = 0; k < b.nv; ++k) F[k] = inertia_times(Ic[i], frames[i].S[k]);
    for (int k = 0; k < b.nv; ++k)
      for (int r = k; r < b.nv; ++r) at(b.v_lem + r, b.v_lem + k) = dot6(frames[i].S[r], F[k]);
    // F carried up the path to the root, projected on every ancestor's S.
    for (int child = static_cast<int>(i), j = b.parent_lem; j >= 0; child = j, j = t.bodies[j].parent_lem) {
      for (int k = 0; k < b.nv; ++k) F[k] = force_to_parent(frames[child], F[k]);
      for (int k = 0; k < b.nv; ++k)
        for (int r = 0; r < t.bodies[j].nv; ++r) at(t.bodies[j].v_lem + r, b.v_lem + k) = dot6(frames[j].S[r], F[k]);
    }
  }
  return M;
}

}  // namespace jrgen::emit
