// Measurement behind the library decision of docs/simulation.md: Boost.Odeint's
// runge_kutta_dopri5 and rosenbrock4 (dense output, error control) against
// jrgen::sim's dopri5, sdirk4 and auto on Robertson's problem and on the stiff
// damped pendulum (tests/simulate/stiff_damped_pendulum.urdf), counting
// evaluations of f (forward-dynamics calls) and CPU time, error against a
// tight sdirk4 reference.  Not part of the build (Boost is not a jrgen
// dependency); build it by hand from a configured build tree:
//
//   g++ -O2 -std=c++17 -I runtime/include -I build/tests/jrgen/sim_stiff_damped \
//       -I /usr/include/eigen3 tests/simulate/odeint_compare.cpp \
//       build/tests/libsim_stiff_damped.a build/runtime/libjrgen_runtime.a -o odeint_compare
#include <boost/numeric/odeint.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <jrgen/simulate.hpp>
#include <string>
#include <vector>

#include "sim_stiff_damped.hpp"

namespace odeint = boost::numeric::odeint;
using uvec = boost::numeric::ublas::vector<double>;
using umat = boost::numeric::ublas::matrix<double>;

struct Problem {
  std::string name;
  int n;
  std::function<void(const double* y, double* dy)> f;
  std::vector<double> y0;
  double t_end;
  double floor;  // error_i = |y_i - ref_i| / (floor + |ref_i|)
};
const Problem* g_problem = nullptr;

long g_calls = 0;

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double error(const std::vector<double>& y, const std::vector<double>& ref) {
  double e = 0.0;
  for (std::size_t i = 0; i < y.size(); ++i)
    e = std::max(e, std::abs(y[i] - ref[i]) / (g_problem->floor + std::abs(ref[i])));
  return e;
}

void report(const char* who, const Problem& p, double tol, long steps, long calls, double cpu, double err) {
  std::printf("| %s | %s | %.0e | %ld | %ld | %.2e | %.2e |\n", p.name.c_str(), who, tol, steps, calls, err, cpu);
}

jrgen::sim::OdeProblem as_ode(const Problem& p) {
  jrgen::sim::OdeProblem o;
  o.n = p.n;
  o.rhs = [&p](double, const double* y, double* d, std::string&) {
    p.f(y, d);
    return 0;
  };
  return o;
}

void run_jrgen(const Problem& p, const char* method, double tol, const std::vector<double>& ref) {
  jrgen::sim::Settings s;
  s.method = method;
  s.rtol = s.atol = tol;
  std::vector<double> y = p.y0;
  const auto t0 = std::chrono::steady_clock::now();
  const jrgen::sim::Stats st = jrgen::sim::integrate(as_ode(p), 0.0, p.t_end, y, s);
  report((std::string("jrgen ") + method).c_str(), p, tol, st.steps, st.f_calls, seconds_since(t0), error(y, ref));
}

void run_odeint_dopri5(const Problem& p, double tol, const std::vector<double>& ref) {
  std::vector<double> y = p.y0;
  g_calls = 0;
  auto sys = [&p](const std::vector<double>& x, std::vector<double>& dx, double) {
    ++g_calls;
    p.f(x.data(), dx.data());
  };
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t steps = odeint::integrate_adaptive(
      odeint::make_dense_output(tol, tol, odeint::runge_kutta_dopri5<std::vector<double>>()), sys, y, 0.0, p.t_end,
      1e-6);
  report("odeint runge_kutta_dopri5", p, tol, static_cast<long>(steps), g_calls, seconds_since(t0), error(y, ref));
}

// rosenbrock4 needs J (and df/dt = 0 here) at every step: forward differences, n calls.
void run_odeint_rosenbrock4(const Problem& p, double tol, const std::vector<double>& ref) {
  const int n = p.n;
  uvec y(n);
  for (int i = 0; i < n; ++i) y[i] = p.y0[i];
  g_calls = 0;
  auto sys = [&p](const uvec& x, uvec& dx, double) {
    ++g_calls;
    p.f(&x[0], &dx[0]);
  };
  auto jac = [&p, n](const uvec& x, umat& J, double, uvec& dfdt) {
    std::vector<double> f0(n), f1(n), xp(x.begin(), x.end());
    ++g_calls;
    p.f(xp.data(), f0.data());
    for (int j = 0; j < n; ++j) {
      const double d = std::sqrt(2.2e-16 * std::max(1e-5, std::abs(xp[j])));
      xp[j] += d;
      ++g_calls;
      p.f(xp.data(), f1.data());
      for (int i = 0; i < n; ++i) J(i, j) = (f1[i] - f0[i]) / d;
      xp[j] = x[j];
    }
    for (int i = 0; i < n; ++i) dfdt[i] = 0.0;
  };
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t steps = odeint::integrate_adaptive(
      odeint::make_dense_output(tol, tol, odeint::rosenbrock4<double>()), std::make_pair(sys, jac), y, 0.0, p.t_end,
      1e-6);
  std::vector<double> yv(y.begin(), y.end());
  report("odeint rosenbrock4 (FD Jacobian)", p, tol, static_cast<long>(steps), g_calls, seconds_since(t0),
         error(yv, ref));
}

int main() {
  const jrgen::sim::Mechanism mech(JRGEN_SIM_SYSTEM(sim_sd));
  const double q0[2] = {1.0, 0.5};
  const jrgen::sim::OdeProblem mp = mech.problem();
  std::vector<Problem> problems = {
      {"Robertson [0, 40]", 3,
       [](const double* y, double* d) {
         d[0] = -0.04 * y[0] + 1e4 * y[1] * y[2];
         d[2] = 3e7 * y[1] * y[1];
         d[1] = -d[0] - d[2];
       },
       {1.0, 0.0, 0.0}, 40.0, 1e-6},
      {"stiff damped pendulum [0, 3]", 4,
       [&mp](const double* y, double* d) {
         std::string e;
         mp.rhs(0.0, y, d, e);
       },
       mech.initial_state(q0, nullptr), 3.0, 1.0}};
  std::printf("| problem | integrator | rtol = atol | steps | f calls | max rel. error | CPU s |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  for (const Problem& p : problems) {
    g_problem = &p;
    std::vector<double> ref = p.y0;
    jrgen::sim::Settings s;
    s.method = "sdirk4";
    s.rtol = s.atol = 1e-12;
    jrgen::sim::integrate(as_ode(p), 0.0, p.t_end, ref, s);
    for (double tol : {1e-6, 1e-8}) {
      run_jrgen(p, "auto", tol, ref);
      run_jrgen(p, "sdirk4", tol, ref);
      run_jrgen(p, "radau5", tol, ref);
      run_jrgen(p, "dopri5", tol, ref);
      run_odeint_rosenbrock4(p, tol, ref);
      run_odeint_dopri5(p, tol, ref);
    }
  }
}
