// The extreme cases in time of docs/simulation.md ("Extreme cases in
// time"; issue 21 item 4): models under tests/simulate/extreme/, their start
// states, references (exact where one exists) and the measurement of one run
// (error, energy and invariant drift, constraint drift, counters, CPU time,
// or the named failure).  Shared by extreme_test.cpp (asserts) and
// extreme_table.cpp (the table of the docs).
#pragma once

#include <algorithm>
#include <cmath>
#include <ctime>
#include <functional>
#include <jrgen/simulate.hpp>
#include <string>
#include <vector>

#include "reference/reference_files.hpp"
#include "sim_x_dp12.hpp"
#include "sim_x_dp15.hpp"
#include "sim_x_dp6.hpp"
#include "sim_x_dp9.hpp"
#include "sim_x_dph6.hpp"
#include "sim_x_dph9.hpp"
#include "sim_x_par.hpp"
#include "sim_x_parp.hpp"
#include "sim_x_pspring.hpp"
#include "sim_x_rope.hpp"
#include "sim_x_spring.hpp"
#include "sim_x_toggle.hpp"
#include "sim_x_top.hpp"

namespace jrgen::extreme {

using Vec = std::vector<double>;

struct Case {
  std::string name;
  sim::System sys;
  Vec q0, v0;
  double t_end = 1.0;
  /// Scale of the q error: the error is max_i |q_i - q_ref,i| / q_scale.
  double q_scale = 1.0;
  /// Exact q(t_end) when known (else empty: the reference file below).
  Vec q_exact;
  /// Otherwise the independent reference trajectory (SUNDIALS CVODE on the
  /// dynamics of tests/reference/; docs/testing.md, "References"):
  /// tests/simulate/extreme/reference/<ref_file>.tsv, its row at t_end.
  std::string ref_file;
  /// The simulation layer's own tight run that was the reference before the
  /// files (trajectory_reference_test compares it with the file).
  std::string ref_method = "dopri5";
  double ref_tol = 1e-13;
  /// A conserved quantity besides the energy (nullptr: none), and its scale.
  std::function<double(const double* y)> invariant;
  double invariant_scale = 1.0;
  std::string invariant_name;
  /// The Mechanism's settings (default: projection, singular_damping 1e-10).
  sim::MechanismSettings ms;
};

struct Result {
  bool ok = false;
  std::string failure;          ///< Failure::what() when !ok
  double t_fail = NAN;          ///< Failure::t when !ok
  double err = NAN;             ///< q error at t_end / q_scale
  double e_drift = NAN;         ///< max |E - E0| / E_scale over the accepted steps
  double e_scale = NAN;         ///< max kinetic energy + |E - E0| seen (J)
  double inv_drift = NAN;       ///< max |I - I0| / invariant_scale
  double phi = 0.0, phiqv = 0.0;  ///< max |Phi|, max |Phiq v| over the run
  bool nonfinite = false;       ///< a NaN or infinity reached the observer (a silent blow-up)
  sim::Stats st;
  double cpu_s = 0.0;
  Vec y;                        ///< state at t_end (when ok)
};

inline Result measure(const Case& c, const std::string& method, double tol, const Vec* q_ref) {
  const sim::Mechanism m(c.sys, c.ms);
  Result r;
  const int nq = c.sys.nq, nv = c.sys.nv;
  Vec y;
  try {
    y = m.initial_state(c.q0.data(), c.v0.data());
  } catch (const sim::Failure& f) {
    r.failure = f.what();
    r.t_fail = f.t;
    return r;
  }
  const double e0 = m.energy(y.data());
  const double i0 = c.invariant ? c.invariant(y.data()) : 0.0;
  double e_dev = 0.0, e_scale = 0.0, i_dev = 0.0;
  sim::Settings s;
  s.method = method;
  s.rtol = s.atol = tol;
  const std::clock_t t0 = std::clock();
  try {
    r.st = m.run(0.0, c.t_end, y, s, [&](double, const double* yy) {
      for (int i = 0; i < nq + nv; ++i)
        if (!std::isfinite(yy[i])) r.nonfinite = true;
      const double e = m.energy(yy);
      e_dev = std::max(e_dev, std::abs(e - e0));
      e_scale = std::max(e_scale, std::abs(e - c.sys.potential_energy(yy)) + std::abs(e - e0));
      if (c.invariant) i_dev = std::max(i_dev, std::abs(c.invariant(yy) - i0));
      r.phi = std::max(r.phi, m.phi_norm(yy));
      r.phiqv = std::max(r.phiqv, m.phiqv_norm(yy));
    });
    r.ok = true;
  } catch (const sim::Failure& f) {
    r.failure = f.what();
    r.t_fail = f.t;
  }
  r.cpu_s = double(std::clock() - t0) / CLOCKS_PER_SEC;
  r.e_scale = e_scale;
  r.e_drift = e_scale > 0.0 ? e_dev / e_scale : e_dev;
  if (c.invariant) r.inv_drift = i_dev / c.invariant_scale;
  if (!r.ok) return r;
  const Vec& ref = !c.q_exact.empty() ? c.q_exact : *q_ref;
  r.err = 0.0;
  for (int i = 0; i < nq; ++i) r.err = std::max(r.err, std::abs(y[i] - ref[i]) / c.q_scale);
  r.y = y;
  return r;
}

/// q(t_end) of the case's reference file (empty when the case has an exact
/// solution).
inline Vec reference(const Case& c) {
  if (!c.q_exact.empty()) return {};
  const reference::ReferenceFile f = reference::read_reference_file(
      std::string(JRGEN_SOURCE_DIR) + "/tests/simulate/extreme/reference/" + c.ref_file + ".tsv");
  const Vec& row = f.row_at(c.t_end);
  Vec q(c.sys.nq);
  for (int i = 0; i < c.sys.nq; ++i) q[i] = row[f.column("q" + std::to_string(i))];
  return q;
}

// ---- the cases ---------------------------------------------------------------

inline Case double_pendulum(const std::string& name, const sim::System& sys, const std::string& file) {
  Case c;
  c.name = name;
  c.ref_file = file;
  c.sys = sys;
  c.q0 = {1.0, -0.5};
  c.v0 = {0.0, 0.0};
  c.t_end = 5.0;
  return c;
}

inline Case light_tip_1e6() { return double_pendulum("double pendulum, tip 1e-6 kg", JRGEN_SIM_SYSTEM(sim_x_dp6), "dp_light_tip_1e6"); }
inline Case light_tip_1e9() { return double_pendulum("double pendulum, tip 1e-9 kg", JRGEN_SIM_SYSTEM(sim_x_dp9), "dp_light_tip_1e9"); }
inline Case light_tip_1e12() {
  return double_pendulum("double pendulum, tip 1e-12 kg", JRGEN_SIM_SYSTEM(sim_x_dp12), "dp_light_tip_1e12");
}
inline Case heavy_tip_1e9() { return double_pendulum("double pendulum, tip 1e9 kg", JRGEN_SIM_SYSTEM(sim_x_dph9), "dp_heavy_tip_1e9"); }
inline Case heavy_tip_1e6() { return double_pendulum("double pendulum, tip 1e6 kg", JRGEN_SIM_SYSTEM(sim_x_dph6), "dp_heavy_tip_1e6"); }
inline Case light_tip_1e15() {
  return double_pendulum("double pendulum, tip 1e-15 kg", JRGEN_SIM_SYSTEM(sim_x_dp15), "dp_light_tip_1e15");
}

/// 1 kg on 1e9 N/m, x0 = 1 mm, 10 periods: x(t) = x0 cos(w t).
inline Case spring_1e9() {
  Case c;
  c.name = "joint spring 1e9 N/m";
  c.sys = JRGEN_SIM_SYSTEM(sim_x_spring);
  const double x0 = 1e-3, w = std::sqrt(1e9);
  c.q0 = {x0};
  c.v0 = {0.0};
  c.t_end = 10 * 2 * M_PI / w;
  c.q_scale = x0;
  c.q_exact = {x0 * std::cos(w * c.t_end)};
  return c;
}

/// The 1e9 N/m elastic pendulum released 0.5 rad out, at rest length, spin 1 rad/s.
inline Case point_spring_1e9() {
  Case c;
  c.name = "point spring 1e9 N/m pendulum";
  c.sys = JRGEN_SIM_SYSTEM(sim_x_pspring);
  c.q0 = {-std::cos(0.5), std::sin(0.5), 0.0};  // (z, x, theta)
  c.v0 = {0.0, 0.0, 1.0};
  c.t_end = 2.0;
  c.ref_file = "point_spring_1e9";
  c.ref_method = "radau5";  // dopri5 at 1e-13 takes 10^5 steps of the 3e4 1/s mode
  c.ref_tol = 1e-12;
  return c;
}

/// 50-link rope released straight, `angle` rad from the vertical (pi/2:
/// horizontal, the tip whips).
inline Case rope50(double angle = 1.0) {
  Case c;
  c.name = angle == 1.0 ? "rope, 50 links" : "rope, 50 links, released horizontal";
  c.sys = JRGEN_SIM_SYSTEM(sim_x_rope);
  c.q0.assign(c.sys.nq, 0.0);
  c.q0[0] = angle;
  c.v0.assign(c.sys.nv, 0.0);
  c.ref_file = angle == 1.0 ? "rope50" : "rope50_horizontal";
  c.t_end = 0.5;
  return c;
}

/// theta(t_end) of the parallelogram's reduced equation (5/3) theta'' =
/// 2 g sin(theta) (parallelogram.urdf) by jrgen's own integrators on that
/// 2-state ODE: at a method's tolerance, the error that method makes on the
/// reduced equation alone.  The reference theta (parallelogram() below) is
/// the same equation integrated by SUNDIALS CVODE (reference files).
inline double parallelogram_theta(double theta0, double w0, double t_end, const char* method = "dopri5",
                                  double tol = 1e-13) {
  sim::OdeProblem p;
  p.n = 2;
  p.rhs = [](double, const double* y, double* dy, std::string&) {
    dy[0] = y[1];
    dy[1] = 0.6 * 2 * 9.81 * std::sin(y[0]);
    return 0;
  };
  Vec y = {theta0, w0};
  sim::Settings s;
  s.method = method;
  s.rtol = s.atol = tol;
  sim::integrate(p, 0.0, t_end, y, s);
  return y[0];
}

/// Parallelogram four-bar in its plane of gravity, released at theta = 0.3
/// with 1 rad/s: it swings through its change points theta = pi/2 (first
/// at t = 0.57) and 3 pi/2 and back (theta between 0.3 and 2 pi - 0.3).
/// With `flat`: released at the change point itself, theta = pi/2, 1 rad/s.
inline Case parallelogram(bool proximal, bool flat = false) {
  Case c;
  c.name = proximal ? "parallelogram, --singular proximal" : "parallelogram";
  if (flat) c.name += ", started flat";
  c.sys = proximal ? JRGEN_SIM_SYSTEM(sim_x_parp) : JRGEN_SIM_SYSTEM(sim_x_par);
  const double th = flat ? M_PI / 2 : 0.3, w = 1.0;
  c.q0 = {th, -th, th};
  c.v0 = {w, -w, w};
  c.t_end = 3.0;
  // theta(t_end) of the reduced equation by SUNDIALS CVODE at 1e-14
  // (tests/simulate/extreme/reference/parallelogram_reduced*.tsv).
  const reference::ReferenceFile f = reference::read_reference_file(
      std::string(JRGEN_SOURCE_DIR) + "/tests/simulate/extreme/reference/parallelogram_reduced" +
      (flat ? "_flat" : "") + ".tsv");
  const double te = f.row_at(c.t_end)[f.column("th")];
  c.q_exact = {te, -te, te};
  return c;
}

/// The near-change-point four-bar (rocker 1.001 m) swinging from its
/// parallelogram-like start through its near-flat configuration and toggle.
inline Case near_toggle() {
  Case c;
  c.name = "four-bar 1e-3 from change point";
  c.sys = JRGEN_SIM_SYSTEM(sim_x_toggle);
  c.q0 = {0.3, -0.3, 0.3};
  c.v0 = {1.0, -1.0, 1.0};
  c.t_end = 3.0;
  c.ref_file = "near_toggle";
  return c;
}

/// World z component of the top's angular momentum about the pivot:
/// L = R(quat) diag(A, A, C) w, A = 0.012, C = 0.004 (top.urdf).
inline double top_lz(const double* y) {
  const double w = y[0], x = y[1], yq = y[2], z = y[3];
  const double n2 = w * w + x * x + yq * yq + z * z;
  const double lb[3] = {0.012 * y[4], 0.012 * y[5], 0.004 * y[6]};
  // third row of the rotation matrix of the (normalized) quaternion
  const double r20 = 2 * (x * z - w * yq) / n2, r21 = 2 * (yq * z + w * x) / n2,
               r22 = 1 - 2 * (x * x + yq * yq) / n2;
  return r20 * lb[0] + r21 * lb[1] + r22 * lb[2];
}

/// The heavy top tilted 0.3 rad, spinning at `spin` rad/s about its axis.
inline Case top(double spin) {
  Case c;
  c.name = "top, spin " + std::to_string(int(spin)) + " rad/s";
  c.sys = JRGEN_SIM_SYSTEM(sim_x_top);
  c.q0 = {std::cos(0.15), std::sin(0.15), 0.0, 0.0};
  c.v0 = {0.0, 0.0, spin};
  c.t_end = 1.0;
  c.invariant = top_lz;
  c.invariant_scale = 0.004 * spin;  // |L| ~ C w3
  c.invariant_name = "L_z";
  c.ref_file = "top_" + std::to_string(int(spin));
  return c;
}

}  // namespace jrgen::extreme
