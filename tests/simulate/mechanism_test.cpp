// jrgen::sim::Mechanism on generated solvers: energy kept by the
// error-controlled methods, constraints kept by projection (and less so by
// Baumgarte), quaternions of ball and floating joints, the assembled start.
//
// The energy uses the generated potential_energy(); the first test checks it
// against the independent reference's (tests/reference) with the gravity
// each solver was generated with.
//
// Energy asserts: with tolerance tol on every state component, the global
// error of y over a few periods stays a small multiple of tol x |y| (the ODE
// tests measure 0.3-3 x); the energy error is then about |dE/dy| x that,
// i.e. tol x (the energies in play, kinetic and potential, |E|_scale).  The
// asserts allow 100 x tol x |E|_scale; the measured values are printed.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <jrgen/simulate.hpp>
#include <string>
#include <vector>

#include "common/model_cases.hpp"
#include "gen_loops_fourbar_conservative.hpp"
#include "reference/reference_dynamics.hpp"
#include "sim_ball_floating.hpp"
#include "sim_double_pendulum.hpp"
#include "sim_stiff_damped.hpp"
#include "sim_stiff_spring.hpp"
#include "urdf/urdf_reader.hpp"

namespace jrgen {
namespace {

using sim::Mechanism;
using sim::Settings;
using sim::Stabilization;

// The independent reference's potential energy, for the check below.
struct Potential {
  ir::Robot robot;
  Eigen::Vector3d gravity;
  int nq;
  double operator()(const double* q) const {
    return reference::potential_energy(robot, Eigen::Map<const Eigen::VectorXd>(q, nq), gravity);
  }
};

sim::System double_pendulum() { return JRGEN_SIM_SYSTEM(sim_dp); }
sim::System ball_floating() { return JRGEN_SIM_SYSTEM(sim_bf); }
sim::System fourbar() { return JRGEN_SIM_SYSTEM(gen_loops_fourbar_conservative); }

// The generated potential_energy() (through JRGEN_SIM_SYSTEM) against the
// reference at a few configurations: the same sum of m g . p_com, to
// rounding (eps x the terms, ~1e-15 x 30 J).
TEST(Mechanism, GeneratedPotentialEnergyMatchesReference) {
  const Potential dp{urdf::read_robot(JRGEN_SOURCE_DIR "/tests/cli/double_pendulum.urdf"), {0, 0, -9.81}, sim_dp::nq};
  const Potential bf{urdf::read_robot(JRGEN_SOURCE_DIR "/tests/simulate/ball_floating.urdf"), {0, 0, -9.81},
                     sim_bf::nq};
  const Potential fb{testing::read_model_case(testing::find_model_case("loops_fourbar_conservative")), {0, -9.81, 0},
                     gen_loops_fourbar_conservative::nq};
  const double q_dp[2] = {0.7, -1.1}, q_fb[3] = {0.3, -0.2, 0.4};
  const double q_bf[11] = {0.9, 0.3, -0.2, 0.1, 0.1, 0.2, 0.3, 0.8, 0.1, 0.5, -0.2};
  std::vector<double> qn(q_bf, q_bf + 11);
  for (int i : {0, 7}) {  // the reference does not normalize
    const double n = std::sqrt(qn[i] * qn[i] + qn[i + 1] * qn[i + 1] + qn[i + 2] * qn[i + 2] + qn[i + 3] * qn[i + 3]);
    for (int k = 0; k < 4; ++k) qn[i + k] /= n;
  }
  EXPECT_NEAR(double_pendulum().potential_energy(q_dp), dp(q_dp), 1e-12);
  EXPECT_NEAR(fourbar().potential_energy(q_fb), fb(q_fb), 1e-12);
  EXPECT_NEAR(ball_floating().potential_energy(qn.data()), bf(qn.data()), 1e-12);
}

struct Trace {
  double e0 = 0.0, e_drift = 0.0, e_scale = 0.0, phi = 0.0, phiqv = 0.0, v_scale = 0.0;
  sim::Stats st;
};

Trace run(const Mechanism& m, std::vector<double> y, const Settings& s, double t_end) {
  Trace tr;
  tr.e0 = m.energy(y.data());
  EXPECT_TRUE(std::isfinite(tr.e0));  // a NaN energy would pass every drift test
  const int nq = m.system().nq, nv = m.system().nv;
  tr.st = m.run(0.0, t_end, y, s, [&](double, const double* yy) {
    const double e = m.energy(yy);
    tr.e_drift = std::max(tr.e_drift, std::abs(e - tr.e0));
    // Scale: the potential energy's swing plus the kinetic energy.
    tr.e_scale = std::max(tr.e_scale, std::abs(e - m.system().potential_energy(yy)) + std::abs(e - tr.e0));
    tr.phi = std::max(tr.phi, m.phi_norm(yy));
    tr.phiqv = std::max(tr.phiqv, m.phiqv_norm(yy));
    for (int i = 0; i < nv; ++i) tr.v_scale = std::max(tr.v_scale, std::abs(yy[nq + i]));
  });
  return tr;
}

TEST(Mechanism, DoublePendulumKeepsEnergy) {
  const Mechanism m(double_pendulum());
  const double q0[2] = {1.2, -0.7}, v0[2] = {0.5, 1.0};
  for (const char* method : {"auto", "radau5", "sdirk4", "dopri5"}) {
    for (double tol : {1e-6, 1e-9}) {
      Settings s;
      s.method = method;
      s.rtol = s.atol = tol;
      const Trace tr = run(m, m.initial_state(q0, v0), s, 5.0);
      std::printf("double pendulum %s tol %g: steps %ld rejected %ld fd_calls %ld, energy drift %.2e of %.2e\n",
                  method, tol, tr.st.steps, tr.st.rejected, tr.st.f_calls, tr.e_drift, tr.e_scale);
      EXPECT_LT(tr.e_drift, 100 * tol * tr.e_scale);
    }
  }
}

TEST(Mechanism, BallAndFloatingJointsKeepEnergyAndUnitQuaternions) {
  const Mechanism m(ball_floating());
  ASSERT_EQ(sim_bf::nq, 11);
  // Ball: tilted by 0.4 rad about an oblique axis; floating: at rest position, turned.
  const double a = 0.2, b = 0.3;
  const double q0[11] = {std::cos(a), std::sin(a) * 0.6, std::sin(a) * 0.8, 0.0, 0.1, 0.2, 0.3, std::cos(b), 0.0,
                         0.0, std::sin(b)};
  const double v0[9] = {1.0, -0.5, 2.0, 0.3, 0.1, 2.0, 3.0, -1.0, 5.0};
  Settings s;
  s.method = "radau5";
  s.rtol = s.atol = 1e-9;
  std::vector<double> y = m.initial_state(q0, v0);
  const Trace tr = run(m, y, s, 2.0);
  std::printf("ball+floating radau5: steps %ld fd_calls %ld, energy drift %.2e of %.2e\n", tr.st.steps, tr.st.f_calls,
              tr.e_drift, tr.e_scale);
  EXPECT_LT(tr.e_drift, 100 * 1e-9 * tr.e_scale);
  m.run(0.0, 2.0, y, s);
  for (int i : {0, 7}) {
    const double n = std::hypot(std::hypot(y[i], y[i + 1]), std::hypot(y[i + 2], y[i + 3]));
    EXPECT_NEAR(n, 1.0, 1e-15 * 4);
  }
  // Free fall of the brick's joint-frame origin is not a check of x (the
  // origin is off the centre of mass); energy is.  A wrong quaternion rate
  // (child vs parent frame, or a missing 1/2) breaks the energy by O(1).
}

TEST(Mechanism, AssembledDefaultAndAssemblyOfAGivenStart) {
  const Mechanism m(fourbar());
  // q_assembled closes the loop.
  std::vector<double> qa(gen_loops_fourbar_conservative::q_assembled,
                         gen_loops_fourbar_conservative::q_assembled + gen_loops_fourbar_conservative::nq);
  qa.resize(m.size(), 0.0);
  EXPECT_LT(m.phi_norm(qa.data()), 1e-12);
  // A start off the loop is assembled and says so; velocities are projected.
  const double q0[3] = {qa[0] + 0.05, qa[1] - 0.03, qa[2] + 0.02}, v0[3] = {1.0, 0.0, 0.0};
  bool assembled = false;
  const std::vector<double> y = m.initial_state(q0, v0, &assembled);
  EXPECT_TRUE(assembled);
  EXPECT_LT(m.phi_norm(y.data()), 1e-12);
  EXPECT_LT(m.phiqv_norm(y.data()), 1e-12);
  EXPECT_GT(std::abs(y[3]), 0.1);  // the crank still moves
}

TEST(Mechanism, FourbarProjectionKeepsConstraintsBaumgarteDrifts) {
  const double q0[3] = {gen_loops_fourbar_conservative::q_assembled[0] + 0.3, 0.0, 0.0};
  const double v0[3] = {2.0, 0.0, 0.0};
  const double tol = 1e-8;
  Trace proj[4], baum, none;
  const char* methods[4] = {"sdirk4", "dopri5", "auto", "radau5"};
  for (int k = 0; k < 4; ++k) {
    const Mechanism m(fourbar());
    Settings s;
    s.method = methods[k];
    s.rtol = s.atol = tol;
    proj[k] = run(m, m.initial_state(q0, v0), s, 3.0);
    std::printf("fourbar %s projection: steps %ld rejected %ld fd_calls %ld jac %ld; max |Phi| %.2e, |Phiq v| %.2e, "
                "energy drift %.2e of %.2e\n",
                methods[k], proj[k].st.steps, proj[k].st.rejected, proj[k].st.f_calls, proj[k].st.jacobians,
                proj[k].phi, proj[k].phiqv, proj[k].e_drift, proj[k].e_scale);
    // Projection: Newton to phi_tol 1e-12 (the model is a metre in size);
    // velocities exactly up to rounding: eps x |v| x cond ~ 1e-14.
    EXPECT_LE(proj[k].phi, 1e-12);
    EXPECT_LT(proj[k].phiqv, 1e-12 * std::max(1.0, proj[k].v_scale));
    EXPECT_LT(proj[k].e_drift, 100 * tol * proj[k].e_scale);
  }
  {
    sim::MechanismSettings ms;
    ms.stabilization = Stabilization::kBaumgarte;
    const Mechanism m(fourbar(), ms);
    Settings s;
    s.method = "sdirk4";
    s.rtol = s.atol = tol;
    baum = run(m, m.initial_state(q0, v0), s, 3.0);
    ms.stabilization = Stabilization::kNone;
    const Mechanism mn(fourbar(), ms);
    none = run(mn, mn.initial_state(q0, v0), s, 3.0);
  }
  std::printf("fourbar sdirk4 baumgarte (10, 10): steps %ld fd_calls %ld; max |Phi| %.2e, |Phiq v| %.2e, energy drift %.2e\n",
              baum.st.steps, baum.st.f_calls, baum.phi, baum.phiqv, baum.e_drift);
  std::printf("fourbar sdirk4 none: steps %ld; max |Phi| %.2e, |Phiq v| %.2e, energy drift %.2e\n", none.st.steps,
              none.phi, none.phiqv, none.e_drift);
  // Baumgarte keeps Phi of the order of the local errors (tol), far above
  // the projection's; it stays bounded (below 1e3 x tol).
  EXPECT_GT(baum.phi, 100 * proj[0].phi);
  EXPECT_LT(baum.phi, 1e3 * tol);
}

// A stiff mechanism (tests/simulate/stiff_damped_pendulum.urdf: the elbow's
// damper relaxes at ~5e3 1/s): dopri5 is held to h ~ 3.3 / 5e3 by stability,
// the default switches to radau5.  Both end within tolerance of a tight
// sdirk4 reference (global error over a run whose fast mode decays: a few
// tol x |y|; asserted 100 tol, measured printed).
TEST(Mechanism, StiffDampedPendulumDefaultBeatsExplicit) {
  const Mechanism m(JRGEN_SIM_SYSTEM(sim_sd));
  const double q0[2] = {1.0, 0.5}, v0[2] = {0.0, 0.0};
  const double t_end = 3.0, tol = 1e-6;
  std::vector<double> ref = m.initial_state(q0, v0);
  Settings sr;
  sr.method = "sdirk4";
  sr.rtol = sr.atol = 1e-11;
  m.run(0.0, t_end, ref, sr);
  long fd[2];
  const char* methods[2] = {"dopri5", "auto"};
  for (int k = 0; k < 2; ++k) {
    Settings s;
    s.method = methods[k];
    s.rtol = s.atol = tol;
    std::vector<double> y = m.initial_state(q0, v0);
    const sim::Stats st = m.run(0.0, t_end, y, s);
    double err = 0.0;
    for (int i = 0; i < m.size(); ++i) err = std::max(err, std::abs(y[i] - ref[i]) / (1.0 + std::abs(ref[i])));
    std::printf("stiff damped pendulum %s: steps %ld rejected %ld fd_calls %ld jacobians %ld switched %ld, error %.2e\n",
                methods[k], st.steps, st.rejected, st.f_calls, st.jacobians, st.switches, err);
    EXPECT_LT(err, 100 * tol);
    fd[k] = st.f_calls;
    if (k == 1) EXPECT_EQ(st.switches, 1);
  }
  EXPECT_LT(10 * fd[1], fd[0]);
}

// A stiff damped joint spring (tests/simulate/stiff_spring_pendulum.urdf,
// generated potential_energy() including the spring): the default switches
// to radau5 and needs far fewer forward-dynamics calls than dopri5; the
// energy never grows (spring damping and nothing else do work) by more than
// the integration error, 100 tol x the pendulum's energy (46 J, after the
// spring's 2e4 J are gone; measured rises 1e-13 and 1e-8 J).
TEST(Mechanism, StiffJointSpringEnergyDecreases) {
  const Mechanism m(JRGEN_SIM_SYSTEM(sim_ss));
  const double q0[2] = {1.0, 0.0}, v0[2] = {0.0, 0.0};  // the spring starts 0.2 rad from rest
  const double tol = 1e-6;
  long fd[2];
  const char* methods[2] = {"dopri5", "auto"};
  for (int k = 0; k < 2; ++k) {
    Settings s;
    s.method = methods[k];
    s.rtol = s.atol = tol;
    std::vector<double> y = m.initial_state(q0, v0);
    double e_prev = m.energy(y.data()), rise = 0.0;
    const double e0 = e_prev;
    const sim::Stats st = m.run(0.0, 2.0, y, s, [&](double, const double* yy) {
      const double e = m.energy(yy);
      rise = std::max(rise, e - e_prev);
      e_prev = e;
    });
    std::printf("stiff spring %s: steps %ld rejected %ld fd_calls %ld switched %ld, E %.6f -> %.6f, largest rise %.2e\n",
                methods[k], st.steps, st.rejected, st.f_calls, st.switches, e0, e_prev, rise);
    ASSERT_TRUE(std::isfinite(e0));
    EXPECT_LT(rise, 100 * tol * std::abs(e_prev));
    EXPECT_LT(e_prev, e0);  // the spring's damper dissipates
    fd[k] = st.f_calls;
  }
  EXPECT_LT(10 * fd[1], fd[0]);
}

// Joint forces reach forward_dynamics: tau = h(q, v) (gravity compensation)
// makes qdd = 0, so a pendulum released at rest stays where it is (to the
// rounding of M^-1 (tau - h) = 0: 1e-15 per step).  Without them it falls.
TEST(Mechanism, JointForcesFromSetForces) {
  Mechanism m(double_pendulum());
  const double q0[2] = {1.0, -0.5};
  Settings s;
  std::vector<double> y = m.initial_state(q0, nullptr);
  m.set_forces([](double, const double* q, const double* v, double* tau) { sim_dp::bias_forces(q, v, tau); });
  m.run(0.0, 1.0, y, s);
  EXPECT_NEAR(y[0], 1.0, 1e-12);
  EXPECT_NEAR(y[1], -0.5, 1e-12);
  m.set_forces(nullptr);
  m.run(0.0, 1.0, y, s);
  EXPECT_GT(std::abs(y[0] - 1.0), 0.1);
}

TEST(Mechanism, SolverFailureNamesTimeAndJoint) {
  // A NaN velocity is status 3 from the generated solver, naming the joint.
  const Mechanism m(double_pendulum());
  std::vector<double> y = {0.1, 0.2, std::nan(""), 0.0};
  Settings s;
  try {
    m.run(0.0, 1.0, y, s);
    ADD_FAILURE() << "no failure";
  } catch (const sim::Failure& f) {
    std::printf("%s\n", f.what());
    EXPECT_NE(std::string(f.what()).find("at t = 0"), std::string::npos);
    EXPECT_NE(std::string(f.what()).find("shoulder"), std::string::npos);
  }
}

}  // namespace
}  // namespace jrgen
