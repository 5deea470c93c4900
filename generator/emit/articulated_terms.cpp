#include "emit/articulated_terms.hpp"

#include <fmt/format.h>

#include "emit/force_elements.hpp"

namespace jrgen::emit {

namespace {

// A spatial inertia (rigid or articulated) in one body's coordinates, as the
// map from motion [w; v] to force [n; f]: [[A, B], [B^T, C]], A and C
// symmetric (all nine entries kept: the Program shares the mirrored ones).
struct Inertia6 {
  Mat3 A, B, C;
};

Mat3 add(const Mat3& X, const Mat3& Y) {
  Mat3 Z;
  for (int k = 0; k < 9; ++k) Z[k] = X[k] + Y[k];
  return Z;
}

Mat3 skew(const Vec3& p) { return {0.0, -1.0 * p[2], p[1], p[2], 0.0, -1.0 * p[0], -1.0 * p[1], p[0], 0.0}; }

// The rigid body's inertia about its frame origin: A = I_com + m (|c|^2 1 - c c^T),
// B = [m c]x, C = m 1 (formula (c) of runtime/src/runtime.cpp).
Inertia6 rigid_inertia(const ir::Inertial& in) {
  const Eigen::Vector3d c = in.com, h = in.mass * in.com;
  const Eigen::Matrix3d Io =
      in.I_com + in.mass * (c.squaredNorm() * Eigen::Matrix3d::Identity() - c * c.transpose());
  Eigen::Matrix3d H;
  H << 0.0, -h.z(), h.y(), h.z(), 0.0, -h.x(), -h.y(), h.x(), 0.0;
  return {mat3(0.5 * (Io + Io.transpose()).eval()), mat3(H), mat3(in.mass * Eigen::Matrix3d::Identity())};
}

Motion6 times(const Inertia6& I, const Motion6& m) {
  const Vec3 w = angular(m), v = linear(m);
  return join(mul(I.A, w) + mul(I.B, v), tmul(I.B, w) + mul(I.C, v));
}

// The inertia of child C in its parent's coordinates: with X_PC = (R, p) and
// P = [p]x, rotate (A' = R A R^T, ...), then shift:
//   [[A' + P B'^T - (B' + P C') P,  B' + P C'], [B'^T - C' P,  C']].
Inertia6 to_parent(const BodyFrame& b, const Inertia6& I) {
  const Mat3 Rt = transpose(b.R);
  const Mat3 A = mul(mul(b.R, I.A), Rt), B = mul(mul(b.R, I.B), Rt), C = mul(mul(b.R, I.C), Rt);
  const Mat3 P = skew(b.p);
  const Mat3 Bs = add(B, mul(P, C));
  Mat3 negP;
  for (int k = 0; k < 9; ++k) negP[k] = -1.0 * P[k];
  // (The lower left block, B'^T - C' P, is the transpose of B' + P C'.)
  return {add(add(A, mul(P, transpose(B))), mul(Bs, negP)), Bs, C};
}

// Symmetric n x n (n <= 6) D = L diag(d) L^T in place, and its inverse.
std::vector<Value> symmetric_inverse(std::vector<Value> D, int n, std::vector<Value>& pivots) {
  std::vector<Value> L(n * n, 0.0), d(n);
  for (int j = 0; j < n; ++j) {
    Value dj = D[j * n + j];
    for (int k = 0; k < j; ++k) dj = dj - L[j * n + k] * L[j * n + k] * d[k];
    d[j] = dj;
    pivots.push_back(dj);
    L[j * n + j] = 1.0;
    for (int i = j + 1; i < n; ++i) {
      Value s = D[i * n + j];
      for (int k = 0; k < j; ++k) s = s - L[i * n + k] * L[j * n + k] * d[k];
      L[i * n + j] = s / dj;
    }
  }
  // D^-1 = L^-T diag(1/d) L^-1, column by column from the unit vectors.
  std::vector<Value> inv(n * n);
  for (int c = 0; c < n; ++c) {
    std::vector<Value> y(n, 0.0);
    for (int i = 0; i < n; ++i) {
      Value s = i == c ? Value(1.0) : Value(0.0);
      for (int k = 0; k < i; ++k) s = s - L[i * n + k] * y[k];
      y[i] = s;
    }
    for (int i = 0; i < n; ++i) y[i] = y[i] / d[i];
    for (int i = n - 1; i >= 0; --i) {
      Value s = y[i];
      for (int k = i + 1; k < n; ++k) s = s - L[k * n + i] * y[k];
      y[i] = s;
    }
    for (int i = 0; i < n; ++i) inv[i * n + c] = y[i];
  }
  return inv;
}

// Per body of the backward sweep.
struct Sweep {
  std::vector<Motion6> U;  // IA S, one column per dof
  std::vector<Value> Dinv; // nv x nv
  std::vector<Value> u;    // tau - damping qd - S^T pA
};

}  // namespace

ArticulatedResult articulated_body(Program& P, const topology::Tree& t, const std::vector<BodyFrame>& frames,
                                   const std::vector<BodyMotion6>& motion, const Eigen::Vector3d& gravity,
                                   const std::string& v, const std::string& tau) {
  const std::size_t nb = t.bodies.size();
  std::vector<Inertia6> IA(nb);
  std::vector<Motion6> pA(nb);
  for (std::size_t i = 0; i < nb; ++i) {
    const Inertia6 I = rigid_inertia(t.bodies[i].inertial);
    IA[i] = I;
    pA[i] = cross_force(motion[i].v, times(I, motion[i].v));  // velocity-product force
  }
  // The force elements' part of h (section 2b) enters as tau - h_forces, as
  // the runtime's articulated-body route passes it.
  std::vector<Value> h_forces(t.nv, 0.0);
  add_force_elements(P, t, frames, motion, h_forces);
  std::vector<Sweep> sw(nb);
  ArticulatedResult out;
  out.qdd.assign(t.nv, 0.0);
  out.pivots.assign(t.nv, 0.0);
  // Backward sweep, leaves first (Lemma 2 order): articulated inertias.
  for (std::size_t i = 0; i < nb; ++i) {
    const topology::Body& b = t.bodies[i];
    P.comment(fmt::format("body {}: articulated inertia of '{}' (backward sweep)", i, b.joint_name));
    Sweep& s = sw[i];
    const int n = b.nv;
    for (int k = 0; k < n; ++k) s.U.push_back(times(IA[i], frames[i].S[k]));
    std::vector<Value> D(n * n);
    for (int r = 0; r < n; ++r)
      for (int c = 0; c < n; ++c) D[r * n + c] = r <= c ? dot6(frames[i].S[r], s.U[c]) : D[c * n + r];
    std::vector<Value> piv;
    s.Dinv = symmetric_inverse(D, n, piv);
    for (int k = 0; k < n; ++k) out.pivots[b.v_lem + k] = piv[k];
    for (int k = 0; k < n; ++k) {
      Value uk = P.input(fmt::format("{}[{}]", tau, b.v_user + k));
      if (t.has_force_elements()) uk = uk - h_forces[b.v_lem + k];
      if (b.damping != 0.0) uk = uk - b.damping * P.input(fmt::format("{}[{}]", v, b.v_user + k));
      s.u.push_back(uk - dot6(frames[i].S[k], pA[i]));
    }
    if (b.parent_lem < 0) continue;
    // Ia = IA - U D^-1 U^T, pa = pA + Ia c + U D^-1 u, moved to the parent.
    std::vector<Motion6> W(n);  // U D^-1
    for (int k = 0; k < n; ++k) {
      Motion6 w{};
      for (int l = 0; l < n; ++l)
        for (int r = 0; r < 6; ++r) w[r] = w[r] + s.U[l][r] * s.Dinv[l * n + k];
      W[k] = w;
    }
    Inertia6 Ia = IA[i];
    for (int k = 0; k < n; ++k)
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
          Ia.A[3 * r + c] = Ia.A[3 * r + c] - W[k][r] * s.U[k][c];
          Ia.B[3 * r + c] = Ia.B[3 * r + c] - W[k][r] * s.U[k][3 + c];
          Ia.C[3 * r + c] = Ia.C[3 * r + c] - W[k][3 + r] * s.U[k][3 + c];
        }
    Motion6 pa = pA[i] + times(Ia, motion[i].c);
    for (int k = 0; k < n; ++k)
      for (int r = 0; r < 6; ++r) pa[r] = pa[r] + W[k][r] * s.u[k];
    const Inertia6 X = to_parent(frames[i], Ia);
    Inertia6& IP = IA[b.parent_lem];
    IP = {add(IP.A, X.A), add(IP.B, X.B), add(IP.C, X.C)};
    pA[b.parent_lem] = pA[b.parent_lem] + force_to_parent(frames[i], pa);
  }
  // Forward sweep, root end first: accelerations; gravity as the base's -g.
  std::vector<Motion6> a(nb);
  const Motion6 a_base = join({0.0, 0.0, 0.0}, vec3(-gravity));
  for (std::size_t i = nb; i-- > 0;) {
    const topology::Body& b = t.bodies[i];
    P.comment(fmt::format("body {}: acceleration of '{}' (forward sweep)", i, b.joint_name));
    const Sweep& s = sw[i];
    const int n = b.nv;
    const Motion6 a_in = motion_to_child(frames[i], b.parent_lem < 0 ? a_base : a[b.parent_lem]) + motion[i].c;
    std::vector<Value> r(n);
    for (int k = 0; k < n; ++k) r[k] = s.u[k] - dot6(s.U[k], a_in);
    Motion6 ai = a_in;
    for (int k = 0; k < n; ++k) {
      Value qdd = 0.0;
      for (int l = 0; l < n; ++l) qdd = qdd + s.Dinv[k * n + l] * r[l];
      out.qdd[b.v_lem + k] = qdd;
      for (int c = 0; c < 6; ++c) ai[c] = ai[c] + frames[i].S[k][c] * qdd;
    }
    a[i] = ai;
  }
  return out;
}

}  // namespace jrgen::emit
