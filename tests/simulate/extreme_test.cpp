// Extreme cases in time (issue 21 item 4; docs/simulation.md "Extreme cases
// in time"): what each integrator keeps, and the named failures where one
// fails.  Cases and measurements: extreme_cases.hpp (shared with
// extreme_table.cpp, which prints the docs' table).
//
// Error bounds.  With rtol = atol = tol on every component, the local errors
// are ~tol x |y|; over a run the global error is a modest multiple of it
// (docs/simulation.md: 0.3-50 tol on the pendulums measured here).  The
// asserts allow 100 tol where the table measured at most 51 tol, and say
// why where they allow more.  Energy: the same 100 tol of the energy scale
// (kinetic energy plus the energy's swing, extreme_cases.hpp).
#include <gtest/gtest.h>

#include <cstdio>

#include "extreme_cases.hpp"

namespace jrgen::extreme {
namespace {

Result checked(const Case& c, const char* method, double tol, const Vec& ref) {
  const Result r = measure(c, method, tol, ref.empty() ? nullptr : &ref);
  std::printf("%s %s tol %g: %s error %.2e energy drift %.2e Phi %.1e steps %ld fd_calls %ld switched %ld\n",
              c.name.c_str(), method, tol, r.ok ? "ok" : r.failure.c_str(), r.err, r.e_drift, r.phi, r.st.steps,
              r.st.f_calls, r.st.switches);
  EXPECT_FALSE(r.nonfinite) << c.name << " " << method;  // never a silent blow-up
  return r;
}

// Mass ratios 1e6, 1e9, 1e12 (light tip) and 1e6, 1e9 (heavy tip): the generated
// solver keeps the light tip's digits (docs/extreme.md), and so the
// integrators keep the light tip's trajectory to their tolerance.
TEST(ExtremeTime, MassRatiosKeepTheTolerance) {
  const double tol = 1e-7;
  for (const Case& c : {light_tip_1e6(), light_tip_1e9(), light_tip_1e12(), heavy_tip_1e6(), heavy_tip_1e9()}) {
    const Vec ref = reference(c);
    for (const char* method : {"auto", "radau5"}) {
      const Result r = checked(c, method, tol, ref);
      ASSERT_TRUE(r.ok) << r.failure;
      EXPECT_LT(r.err, 100 * tol) << c.name << " " << method;
      EXPECT_LT(r.e_drift, 100 * tol) << c.name << " " << method;
    }
  }
}

// Mass ratio 1e15: the tip's pivot of M is below 1e-13 of the largest
// (docs/singular.md), the solver returns status 1 naming the joint, and the
// run fails at t = 0 with that message instead of integrating noise.
TEST(ExtremeTime, MassRatio1e15IsANamedFailure) {
  const Case c = light_tip_1e15();
  const Vec ref(2, 0.0);
  const Result r = checked(c, "auto", 1e-7, ref);
  ASSERT_FALSE(r.ok);
  EXPECT_NE(r.failure.find("at t = 0: forward dynamics status 1"), std::string::npos) << r.failure;
  EXPECT_NE(r.failure.find("joint 'elbow'"), std::string::npos) << r.failure;
}

// 1 kg on 1e9 N/m, 10 periods against x0 cos(w t): every method within
// 100 tol of x0 (table: 0.02-30 tol).
TEST(ExtremeTime, JointSpring1e9AgainstTheExactSolution) {
  const Case c = spring_1e9();
  const double tol = 1e-7;
  for (const char* method : {"dopri5", "radau5", "sdirk4", "auto"}) {
    const Result r = checked(c, method, tol, {});
    ASSERT_TRUE(r.ok) << r.failure;
    EXPECT_LT(r.err, 100 * tol) << method;
    EXPECT_LT(r.e_drift, 100 * tol) << method;
  }
}

// rk4 with a step 30 x beyond its stability limit on the 1e9 N/m spring
// (h w = 31.6): the state grows by ~1e4 a step until it overflows; the run
// ends with a named failure, never with NaN rows.
TEST(ExtremeTime, UnstableFixedStepIsANamedFailure) {
  const Case c = spring_1e9();
  const sim::Mechanism m(c.sys);
  Vec y = m.initial_state(c.q0.data(), c.v0.data());
  sim::Settings s;
  s.method = "rk4";
  s.dt = 1e-3;
  bool nonfinite = false;
  try {
    m.run(0.0, 1.0, y, s, [&](double, const double* yy) { nonfinite |= !std::isfinite(yy[0]) || !std::isfinite(yy[1]); });
    ADD_FAILURE() << "no failure; x(1) = " << y[0];
  } catch (const sim::Failure& f) {
    std::printf("rk4 dt 1e-3 on 1e9 N/m: %s\n", f.what());
    EXPECT_NE(std::string(f.what()).find("joint 'slide'"), std::string::npos) << f.what();
  }
  EXPECT_FALSE(nonfinite);
}

// The 1e9 N/m elastic pendulum: stiff only where the tolerance lets the
// spring's 3e4 1/s mode (amplitude m g / k = 1e-8 m, 3e-4 m/s) go.  At 1e-4
// auto switches to radau5 and needs several times fewer forward-dynamics
// calls than dopri5 (table: 11.6 x; asserted 5 x); at 1e-10 the mode is
// above the tolerance, must be resolved, and auto stays with dopri5.
TEST(ExtremeTime, PointSpring1e9StiffOnlyAtLooseTolerance) {
  const Case c = point_spring_1e9();
  const Vec ref = reference(c);
  const Result a = checked(c, "auto", 1e-4, ref), d = checked(c, "dopri5", 1e-4, ref);
  ASSERT_TRUE(a.ok && d.ok);
  EXPECT_EQ(a.st.switches, 1);
  EXPECT_LT(5 * a.st.f_calls, d.st.f_calls);
  EXPECT_LT(a.err, 100 * 1e-4);
  const Result t = checked(c, "auto", 1e-10, ref);
  ASSERT_TRUE(t.ok);
  EXPECT_EQ(t.st.switches, 0);
  EXPECT_LT(t.err, 100 * 1e-10);
}

// The 50-link rope released straight at `angle` rad from the vertical keeps the
// tolerance at t_end, against its CVODE reference (the ExtremeTime.Rope50* tests).
void expect_rope_keeps_the_tolerance(double angle) {
  const Case c = rope50(angle);
  const Vec ref = reference(c);
  for (const auto& [method, tol] : {std::pair{"auto", 1e-7}, std::pair{"radau5", 1e-4}}) {
    const Result r = checked(c, method, tol, ref);
    ASSERT_TRUE(r.ok) << r.failure;
    EXPECT_LT(r.err, 100 * tol) << method;
    EXPECT_LT(r.e_drift, 100 * tol) << method;
  }
}

// 50-link rope at 1 rad: tolerance kept (table: 0.4 tol auto, 0.02 tol radau5).
TEST(ExtremeTime, Rope50KeepsTheTolerance) { expect_rope_keeps_the_tolerance(1.0); }

// The same rope released horizontal (the tip whips: 20 % more steps), against CVODE's
// run of the independent dynamics (tests/simulate/extreme/reference/rope50_horizontal.tsv,
// docs/testing.md "References").  Table: 0.65 tol auto at 1e-7, 0.04 tol radau5 at 1e-4.
TEST(ExtremeTime, Rope50ReleasedHorizontalKeepsTheTolerance) { expect_rope_keeps_the_tolerance(M_PI / 2); }

// The parallelogram swinging through its change points (theta = pi/2 at
// t = 0.50, 3 pi/2 at 1.02), against its reduced pendulum equation.
// auto and radau5 make exactly the error they make on the reduced 2-state
// ODE at the same tolerance (to 10 %; measured: equal to 2 digits): passing
// the change points costs no digit.  Their stages never land within the
// ~1e-7 rad where the solver's digit test fails, so the --singular proximal
// solver gives bitwise the same run.  sdirk4's finite-difference Jacobian
// does land there: with the default MechanismSettings::singular_damping
// (docs/simulation.md, "Near a rank loss") it gets the damped answer and
// passes, but 60 x further off than sdirk4 on the reduced equation alone
// (measured 5.9e-5 against 9.7e-7 at tol 1e-7; auto, radau5: equal).  Not
// explained yet; asserted: it passes, below 1e-3 (17 x the measurement).  With the damping off (0): status 2
// naming the loop, at the change point.
Case damping_off(Case c) {
  c.ms.singular_damping = 0.0;
  c.name += ", singular_damping 0";
  return c;
}

TEST(ExtremeTime, ParallelogramThroughItsChangePoints) {
  const double tol = 1e-7;
  const Case c = parallelogram(false), cp = parallelogram(true);
  for (const char* method : {"auto", "radau5"}) {
    const double reduced = std::abs(parallelogram_theta(0.3, 1.0, c.t_end, method, tol) - c.q_exact[0]);
    const Result r = checked(c, method, tol, {}), p = checked(cp, method, tol, {});
    ASSERT_TRUE(r.ok && p.ok) << r.failure << p.failure;
    std::printf("  reduced equation alone: error %.2e\n", reduced);
    EXPECT_NEAR(r.err, reduced, 0.1 * reduced) << method;
    EXPECT_LE(r.phi, 1e-12);
    EXPECT_EQ(r.y, p.y) << method;  // bitwise
  }
  const double reduced = std::abs(parallelogram_theta(0.3, 1.0, c.t_end, "sdirk4", tol) - c.q_exact[0]);
  const Result d = checked(c, "sdirk4", tol, {});
  ASSERT_TRUE(d.ok) << d.failure;
  std::printf("  reduced equation alone: error %.2e; near_singular %ld\n", reduced, d.st.near_singular);
  EXPECT_LT(d.err, 1e-3);
  EXPECT_GT(d.st.near_singular, 0);
  const Result s = checked(damping_off(c), "sdirk4", tol, {});
  ASSERT_FALSE(s.ok);
  EXPECT_NE(s.failure.find("status 2"), std::string::npos) << s.failure;
  EXPECT_NE(s.failure.find("loop joint 'pin'"), std::string::npos) << s.failure;
  // theta(t_fail) on the reduced equation: the first change point, to the
  // 1e-7 rad band of the digit test and a step's stage offset (1e-4 rad).
  EXPECT_NEAR(parallelogram_theta(0.3, 1.0, s.t_fail), M_PI / 2, 1e-4) << s.failure;
}

// With --singular proximal the same sdirk4 run got status 0 in the band and
// ended 0.46 rad off without an error.  The Mechanism now sees
// last_solve_regularized() (JRGEN_SIM_SYSTEM finds it from inside this
// namespace too) and rejects a step whose stage was regularized: the run ends
// in a named step size underflow at the change point, naming the loop's joints.
// (With the damping off: by default the damped answer replaces the regularized
// one, ParallelogramThroughItsChangePoints.)
TEST(ExtremeTime, RegularizedStagesAreNotIntegratedSilently) {
  EXPECT_NE(parallelogram(true).sys.last_solve_regularized, nullptr);
  EXPECT_EQ(parallelogram(false).sys.last_solve_regularized, nullptr);
  const Result s = checked(damping_off(parallelogram(true)), "sdirk4", 1e-7, {});
  ASSERT_FALSE(s.ok) << "error " << s.err;
  EXPECT_NE(s.failure.find("forward dynamics regularized"), std::string::npos) << s.failure;
  EXPECT_NE(s.failure.find("the loop through joints 'crank_joint'"), std::string::npos) << s.failure;
  EXPECT_NEAR(parallelogram_theta(0.3, 1.0, s.t_fail), M_PI / 2, 1e-4) << s.failure;
}

// Released at the change point itself.  With the default singular_damping,
// both solvers pass with auto at 1e-7 (within 100 tol of the reduced
// equation), the start's solves damped.  With the damping off: without
// --singular proximal the velocity projection of the start fails: status 2
// naming the loop, t = 0.  With it, auto at 1e-7 follows the reduced
// equation (table: 0.8 tol).  radau5 at 1e-10 stays in the regularized band
// and ends in a named step size underflow.
TEST(ExtremeTime, ParallelogramStartedAtItsChangePoint) {
  for (const bool proximal : {false, true}) {
    const Result g = checked(parallelogram(proximal, true), "auto", 1e-7, {});
    ASSERT_TRUE(g.ok) << g.failure;
    EXPECT_LT(g.err, 100 * 1e-7);
    EXPECT_GT(g.st.near_singular, 0);
    EXPECT_EQ(g.st.regularized_used, 0);
  }
  const Result d = checked(damping_off(parallelogram(false, true)), "auto", 1e-7, {});
  ASSERT_FALSE(d.ok);
  EXPECT_EQ(d.t_fail, 0.0);
  EXPECT_NE(d.failure.find("projection onto Phiq v = 0: solver status 2"), std::string::npos) << d.failure;
  EXPECT_NE(d.failure.find("loop joint 'pin'"), std::string::npos) << d.failure;
  const Result p = checked(damping_off(parallelogram(true, true)), "auto", 1e-7, {});
  ASSERT_TRUE(p.ok) << p.failure;
  EXPECT_LT(p.err, 100 * 1e-7);
  // The start is on the change point: its regularized answer is used, once, and said.
  EXPECT_EQ(p.st.regularized_used, 1);
  EXPECT_NE(p.st.regularized_note.find("at t = 0: forward dynamics regularized"), std::string::npos)
      << p.st.regularized_note;
  // dopri5 at 1e-10 took many short steps inside the band and ended 1.9e-3
  // off without an error; now its regularized stages are rejected: named.
  const Result t = checked(damping_off(parallelogram(true, true)), "dopri5", 1e-10, {});
  if (t.ok) EXPECT_LT(t.err, 100 * 1e-10);
  else EXPECT_NE(t.failure.find("forward dynamics regularized"), std::string::npos) << t.failure;
  const Result u = checked(damping_off(parallelogram(true, true)), "radau5", 1e-10, {});
  ASSERT_FALSE(u.ok);
  EXPECT_NE(u.failure.find("step size underflow"), std::string::npos) << u.failure;
}

// 1e-3 from the change point (rocker 1.001 m), swinging in its plane of
// gravity past its near-flat configurations: the tolerance is kept (table:
// 7 tol with auto) and so are the constraints (projection, 1e-12).
TEST(ExtremeTime, NearChangePointKeepsTheTolerance) {
  const Case c = near_toggle();
  const Vec ref = reference(c);
  const Result r = checked(c, "auto", 1e-7, ref);
  ASSERT_TRUE(r.ok) << r.failure;
  EXPECT_LT(r.err, 100 * 1e-7);
  EXPECT_LE(r.phi, 1e-12);
}

// The top at 100 and 1000 rad/s: the error of q is a phase error that
// grows with the number of turns, bounded by tol x spin x T (table: 0.03
// and 0.07 of it); the energy and the world-vertical angular momentum are
// kept to 100 tol of their scales.
TEST(ExtremeTime, FastTopKeepsEnergyAndAngularMomentum) {
  const double tol = 1e-7;
  for (double spin : {100.0, 1000.0}) {
    const Case c = top(spin);
    const Vec ref = reference(c);
    const Result r = checked(c, "auto", tol, ref);
    ASSERT_TRUE(r.ok) << r.failure;
    EXPECT_LT(r.err, tol * spin * c.t_end) << spin;
    EXPECT_LT(r.e_drift, 100 * tol) << spin;
    EXPECT_LT(r.inv_drift, 100 * tol) << spin;
  }
}

}  // namespace
}  // namespace jrgen::extreme
