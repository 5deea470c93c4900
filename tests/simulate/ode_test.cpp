// The integrators of jrgen/simulate.hpp on ODEs with known solutions.
//
// Accuracy asserts: an error-controlled method keeps the local error per
// step below the tolerance; the global error over a run is the sum of the
// propagated local errors, a small multiple of the tolerance for the
// non-growing problems below (harmonic oscillator: errors neither grow nor
// decay; Prothero-Robinson: errors decay).  The factors asserted (10 to 100 x
// the tolerance) are a few times what was measured, printed by each test.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <jrgen/simulate.hpp>
#include <vector>

namespace {

using jrgen::sim::OdeProblem;
using jrgen::sim::Settings;

// y'' = -y as y = (x, v): x = cos t, v = -sin t from (1, 0).
OdeProblem oscillator() {
  OdeProblem p;
  p.n = 2;
  p.rhs = [](double, const double* y, double* d, std::string&) {
    d[0] = y[1];
    d[1] = -y[0];
    return 0;
  };
  return p;
}

double oscillator_error(double t, const double* y) {
  return std::max(std::abs(y[0] - std::cos(t)), std::abs(y[1] + std::sin(t)));
}

class Oscillator : public ::testing::TestWithParam<const char*> {};

TEST_P(Oscillator, GlobalErrorFollowsTolerance) {
  for (double tol : {1e-6, 1e-9}) {
    Settings s;
    s.method = GetParam();
    s.rtol = tol;
    s.atol = tol;
    std::vector<double> y = {1.0, 0.0};
    double worst = 0.0;
    const auto st = jrgen::sim::integrate(oscillator(), 0.0, 10.0, y, s,
                                          [&](double t, const double* yy) { worst = std::max(worst, oscillator_error(t, yy)); });
    std::printf("%s tol %g: steps %ld rejected %ld f %ld, max error %.2e\n", s.method.c_str(), tol, st.steps,
                st.rejected, st.f_calls, worst);
    // 10 / (2 pi) periods: measured 0.3-3 x tol; asserted 30 x tol.
    EXPECT_LT(worst, 30 * tol);
    EXPECT_GT(st.steps, 5);
  }
}

INSTANTIATE_TEST_SUITE_P(Methods, Oscillator, ::testing::Values("auto", "dopri5", "sdirk4", "radau5"));

// Dense output: rows every 0.01 between the steps, each as accurate as the
// steps (dopri5's interpolant is of order 4: HNW I, II.6).
TEST(Dense, Dopri5EveryIsAccurateBetweenSteps) {
  Settings s;
  s.method = "dopri5";
  s.rtol = s.atol = 1e-9;
  s.every = 0.01;
  std::vector<double> y = {1.0, 0.0};
  int rows = 0;
  double worst = 0.0, last_t = -1.0;
  const auto st = jrgen::sim::integrate(oscillator(), 0.0, 3.0, y, s, [&](double t, const double* yy) {
    ++rows;
    EXPECT_GT(t, last_t);
    last_t = t;
    worst = std::max(worst, oscillator_error(t, yy));
  });
  std::printf("dense: %d rows from %ld steps, max error %.2e\n", rows, st.steps, worst);
  EXPECT_EQ(rows, 301);  // t = 0, 0.01, ..., 3
  EXPECT_EQ(last_t, 3.0);
  EXPECT_LT(st.steps, 100);
  // Measured 1.2e-9, as at the step ends; asserted 5e-9.
  EXPECT_LT(worst, 5e-9);
}

// Dense output of the implicit methods: radau5's collocation polynomial
// (order 3 between the step ends, HW II, IV.5) and sdirk4's cubic Hermite
// (order 3).  At tol 1e-9 with rows every 0.01: measured 4.5e-10 and
// 5.8e-10 (the steps are short enough for order 3 to keep up); asserted 10 x tol.
TEST(Dense, ImplicitMethodsBetweenSteps) {
  for (const char* method : {"radau5", "sdirk4"}) {
    Settings s;
    s.method = method;
    s.rtol = s.atol = 1e-9;
    s.every = 0.01;
    std::vector<double> y = {1.0, 0.0};
    int rows = 0;
    double worst = 0.0;
    const auto st = jrgen::sim::integrate(oscillator(), 0.0, 3.0, y, s, [&](double t, const double* yy) {
      ++rows;
      worst = std::max(worst, oscillator_error(t, yy));
    });
    std::printf("dense %s: %d rows from %ld steps, max error %.2e\n", method, rows, st.steps, worst);
    EXPECT_EQ(rows, 301);
    EXPECT_LT(worst, 10 * 1e-9);
  }
}

// Fixed-step RK4: error O(dt^4), halving dt divides it by about 16.
TEST(Rk4, FourthOrder) {
  double err[2];
  for (int k = 0; k < 2; ++k) {
    Settings s;
    s.method = "rk4";
    s.dt = 0.1 / (1 << k);
    std::vector<double> y = {1.0, 0.0};
    jrgen::sim::integrate(oscillator(), 0.0, 5.0, y, s);
    err[k] = oscillator_error(5.0, y.data());
  }
  std::printf("rk4: error %.3e -> %.3e, ratio %.2f\n", err[0], err[1], err[0] / err[1]);
  EXPECT_NEAR(err[0] / err[1], 16.0, 1.5);
}

// rk4's error estimate (Stats::err_est, the sum of h / 6 |k4 - f(y1)| over the steps): on the
// oscillator over 5 s, at or above the true error (the embedded formula is of order 3) and
// falling as dt^3 (the sum of n = T / dt local terms of order dt^4), so above the true
// error by a factor that grows as dt falls: measured, printed.  Asserted: at or above the
// true error, at most 1000 x it down to dt = 0.025, and the order: ratio 8 +- 1.5 per halving.
TEST(Rk4, ErrorEstimate) {
  double est[3], err[3];
  for (int k = 0; k < 3; ++k) {
    Settings s;
    s.method = "rk4";
    s.dt = 0.1 / (1 << k);
    std::vector<double> y = {1.0, 0.0};
    const auto st = jrgen::sim::integrate(oscillator(), 0.0, 5.0, y, s);
    err[k] = oscillator_error(5.0, y.data());
    est[k] = st.err_est;
    std::printf("rk4 dt %g: error %.3e, err_est %.3e, err_step_max %.3e\n", s.dt, err[k], est[k], st.err_step_max);
    EXPECT_GE(est[k], err[k]);
    EXPECT_LE(est[k], 1000 * err[k]);
    EXPECT_GT(st.err_step_max, 0.0);
    EXPECT_LE(st.err_step_max, est[k]);
  }
  EXPECT_NEAR(est[0] / est[1], 8.0, 1.5);
  EXPECT_NEAR(est[1] / est[2], 8.0, 1.5);
}

// Prothero-Robinson, y' = lambda (y - sin t) + cos t, lambda = -1e6, y(0) = 0:
// y = sin t.  Stiff: an explicit method is stable only for h <= 3.3e-6
// (dopri5's stability boundary on the negative axis), ~3e6 steps over [0, 10].
OdeProblem prothero_robinson(double lambda) {
  OdeProblem p;
  p.n = 1;
  p.rhs = [lambda](double t, const double* y, double* d, std::string&) {
    d[0] = lambda * (y[0] - std::sin(t)) + std::cos(t);
    return 0;
  };
  return p;
}

TEST(Stiff, ProtheroRobinsonSdirk4AndAuto) {
  for (const char* method : {"sdirk4", "radau5", "auto"}) {
    Settings s;
    s.method = method;
    s.rtol = s.atol = 1e-8;
    std::vector<double> y = {0.0};
    double worst = 0.0;
    const auto st = jrgen::sim::integrate(prothero_robinson(-1e6), 0.0, 10.0, y, s, [&](double t, const double* yy) {
      worst = std::max(worst, std::abs(yy[0] - std::sin(t)));
    });
    std::printf("PR %s: steps %ld rejected %ld f %ld jac %ld lu %ld switches %ld, max error %.2e\n", method, st.steps,
                st.rejected, st.f_calls, st.jacobians, st.factorizations, st.switches, worst);
    EXPECT_LT(st.steps, 2000);  // measured: about 400 (sdirk4), 15 (radau5), 42 (auto)
    EXPECT_LT(worst, 10 * 1e-8);
    EXPECT_EQ(st.switches, std::string(method) == "auto" ? 1 : 0);
  }
}

TEST(Stiff, AutoStaysExplicitOnANonStiffProblem) {
  Settings s;  // auto
  std::vector<double> y = {1.0, 0.0};
  const auto st = jrgen::sim::integrate(oscillator(), 0.0, 10.0, y, s);
  EXPECT_EQ(st.switches, 0);
  EXPECT_EQ(st.jacobians, 0);
}

TEST(Stiff, Dopri5IsBoundByStability) {
  Settings s;
  s.method = "dopri5";
  s.rtol = s.atol = 1e-6;
  std::vector<double> y = {0.0};
  const auto st = jrgen::sim::integrate(prothero_robinson(-1e4), 0.0, 1.0, y, s);
  std::printf("PR dopri5 (lambda -1e4): steps %ld rejected %ld\n", st.steps, st.rejected);
  // h <= 3.3 / 1e4 on average: at least 1e4 / 3.3 ~ 3000 steps over [0, 1].
  EXPECT_GT(st.steps + st.rejected, 2500);
  EXPECT_NEAR(y[0], std::sin(1.0), 1e-5);
}

// Robertson's chemical kinetics (HW II, IV.1 (1.3)): stiff and with a
// conserved sum.  Reference at t = 40 (the value of SUNDIALS' cvRoberts_dns
// example and the Test Set for IVP Solvers, rounded to 10 digits):
// y = (0.7158270687, 9.185534764e-6, 0.2841637458).
TEST(Stiff, RobertsonAgainstReference) {
  OdeProblem p;
  p.n = 3;
  p.rhs = [](double, const double* y, double* d, std::string&) {
    d[0] = -0.04 * y[0] + 1e4 * y[1] * y[2];
    d[2] = 3e7 * y[1] * y[1];
    d[1] = -d[0] - d[2];
    return 0;
  };
  const double ref[3] = {0.7158270687, 9.185534764e-6, 0.2841637458};
  // Default integrator (auto: switches to radau5).
  // (a) every component to rtol 1e-8 (atol 1e-14 is below y2 ~ 1e-5 x rtol):
  // measured max relative error 1.2e-10 in 3434 steps; asserted 1e-7.
  // (b) the usual atol 1e-10: y2 then only to ~atol, and its error feeds
  // y1' through 1e4 y3 y2: 1e4 x 0.28 x 1e-10 x 40 = 1.1e-5 over the run at
  // worst.  Measured 168 steps, errors 1.1e-8 (y1, y3 relative) and 1.2e-13
  // (y2); asserted 5e-5 and 10 atol.  (sdirk4 there: 290 steps, 5.5e-6.)
  for (const double atol : {1e-14, 1e-10}) {
    Settings s;
    s.rtol = 1e-8;
    s.atol = atol;
    std::vector<double> y = {1.0, 0.0, 0.0};
    const auto st = jrgen::sim::integrate(p, 0.0, 40.0, y, s);
    const double rel = std::max(std::abs(y[0] - ref[0]) / ref[0], std::abs(y[2] - ref[2]) / ref[2]);
    const double e2 = std::abs(y[1] - ref[1]);
    EXPECT_EQ(st.switches, 1);
    std::printf("Robertson auto atol %g: steps %ld rejected %ld f %ld jac %ld, y1/y3 rel error %.2e, y2 error %.2e\n",
                atol, st.steps, st.rejected, st.f_calls, st.jacobians, rel, e2);
    EXPECT_LT(rel, atol == 1e-14 ? 1e-7 : 5e-5);
    EXPECT_LT(e2, atol == 1e-14 ? 1e-7 * ref[1] : 10 * atol);
    if (atol == 1e-10) EXPECT_LT(st.steps, 1000);
  }
}

TEST(Failures, StepSizeUnderflowIsNamed) {
  // y' = y^2 from 1 blows up at t = 1: no step gets past it.
  OdeProblem p;
  p.n = 1;
  p.rhs = [](double, const double* y, double* d, std::string&) {
    d[0] = y[0] * y[0];
    return 0;
  };
  for (const char* m : {"dopri5", "sdirk4", "radau5"}) {
    Settings s;
    s.method = m;
    std::vector<double> y = {1.0};
    try {
      jrgen::sim::integrate(p, 0.0, 2.0, y, s);
      ADD_FAILURE() << m << ": no failure";
    } catch (const jrgen::sim::Failure& f) {
      std::printf("%s: %s\n", m, f.what());
      EXPECT_NEAR(f.t, 1.0, 1e-2);
      EXPECT_NE(std::string(f.what()).find("at t = "), std::string::npos);
    }
  }
}

TEST(Failures, RhsFailureIsRetriedThenNamed) {
  // f fails for y > 2 (a solver status): steps that reach it are shortened;
  // y' = 1 from 0 reaches 2 at t = 2, and the run must then fail there.
  OdeProblem p;
  p.n = 1;
  p.rhs = [](double, const double* y, double* d, std::string& e) {
    if (y[0] > 2.0) {
      e = "joint 'j' out of its domain";
      return 2;
    }
    d[0] = 1.0;
    return 0;
  };
  Settings s;
  s.method = "dopri5";
  std::vector<double> y = {0.0};
  try {
    jrgen::sim::integrate(p, 0.0, 5.0, y, s);
    ADD_FAILURE() << "no failure";
  } catch (const jrgen::sim::Failure& f) {
    std::printf("%s\n", f.what());
    EXPECT_NEAR(f.t, 2.0, 1e-6);
    EXPECT_NE(std::string(f.what()).find("joint 'j'"), std::string::npos);
  }
}

}  // namespace
