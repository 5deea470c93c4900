// Work-precision of the simulation layer on the five published problems (issue 21 item 3;
// docs/simulation.md, "Work-precision"): for each problem, each integrator (dopri5, radau5,
// sdirk4, auto; rk4 at fixed steps) over a sweep of tolerances (rtol = atol = tol), one TSV
// row per run: error at t_end against the problem's reference, median CPU time, calls of
// forward_dynamics, and the drifts over the run (energy, |Phi|, |Phiq v|, at every accepted
// step of one more run with an observer).  Drawn by scripts/simulation_report.sh.
//
//   published_work_precision [--quick] [--check] [-o runs.tsv] [--series drift.tsv] [--only NAME]
//                            [--method M1,M2,...] [--tols T1,T2,...] [--budget S] [--no-drift]
//
// --method: the integrators to sweep (default dopri5,radau5,sdirk4,auto; rk4 rows come with
// the full sweep unless --method names others only); --tols: the tolerances (loosest first);
// --budget: stop a method's sweep after a run above S CPU seconds (default 20, --quick 5);
// --no-drift: skip the observed run of each row (its drift columns are nan), which doubles
// the time of a sweep.  The columns near_singular and singular_checks are Stats' counts of
// MechanismSettings::singular_damping (damped answers near a rank loss, dense checks).
//
// --quick: three tolerances, short spans (the ctest); --check: exit 1 unless, for every
// method and problem, the error falls as tol tightens (see check_runs) and auto ends within
// 100 x tol of the reference.  References (reference_note() prints each):
//   A01: the exact solution, sin(theta/2) = k sn(K - sqrt(g/L) t, k), theta = q + pi/2,
//        k = sin(pi/4) (the pendulum released horizontally; published_test's half period);
//   A02: the parallelogram's one-pendulum equation th'' = c sin th (IftommA02.
//        ParallelogramIsAPendulum) as a scalar ODE: over the published 20 s, integrated by
//        SUNDIALS CVODE at 1e-14 (tests/published/reference/a02_reduced.tsv); for --quick's
//        span (not a row of that file) by jrgen's dopri5 at 1e-14, checked against RK4 with
//        2e5 steps;
//   A03: the Test Set for IVP Solvers' values at t = 0.03 (andrews_reference.hpp);
//   A04, A05: SUNDIALS CVODE at 1e-14 on the independent dynamics of tests/reference/
//        (tests/published/reference/a04.tsv, a05.tsv; trajectory_reference_test compares
//        the simulation layer's tight runs with them over the whole span).
#include <jrgen/simulate.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "andrews_reference.hpp"
#include "published_a01.hpp"
#include "published_a02.hpp"
#include "published_a02_proximal.hpp"
#include "published_a04.hpp"
#include "published_a05.hpp"
#include "published_andrews.hpp"
#include "reference/reference_files.hpp"

namespace {

using jrgen::sim::Mechanism;
using jrgen::sim::Settings;
using jrgen::sim::Stats;
using Vec = std::vector<double>;

constexpr double kG = 9.81;

// ---- references -------------------------------------------------------------------

// The arithmetic-geometric mean's sequences (A&S 17.6): K(k) = pi / (2 a_N).
double complete_k(double k) {
  double a = 1, b = std::sqrt(1 - k * k);
  for (int i = 0; i < 30 && std::abs(a - b) > 1e-17 * a; ++i) {
    const double m = 0.5 * (a + b);
    b = std::sqrt(a * b);
    a = m;
  }
  return M_PI / (2 * a);
}

// Jacobi's sn(u, k) by the descending Landen / AGM scheme (A&S 16.4.3): phi_N = 2^N a_N u,
// phi_{n-1} = (phi_n + asin(c_n / a_n sin phi_n)) / 2, sn = sin phi_0.
double jacobi_sn(double u, double k) {
  double a[32], c[32];
  a[0] = 1;
  double b = std::sqrt(1 - k * k);
  c[0] = k;
  int n = 0;
  while (n < 30 && std::abs(c[n]) > 1e-17) {
    a[n + 1] = 0.5 * (a[n] + b);
    c[n + 1] = 0.5 * (a[n] - b);
    b = std::sqrt(a[n] * b);
    ++n;
  }
  double phi = std::ldexp(a[n] * u, n);
  for (int i = n; i > 0; --i) phi = 0.5 * (phi + std::asin(c[i] / a[i] * std::sin(phi)));
  return std::sin(phi);
}

// A01: q(t) of the pendulum (L = 1, released at q = 0 from rest; q'' = -g cos q).
double a01_exact_q(double t) {
  const double k = std::sin(M_PI / 4);
  const double theta = 2 * std::asin(k * jacobi_sn(complete_k(k) - std::sqrt(kG) * t, k));
  return theta - M_PI / 2;
}

double a01_period() { return 4 * complete_k(std::sin(M_PI / 4)) / std::sqrt(kG); }

// A02 (N = 40) on its parallelogram: th'' = c sin th, the cranks at th, the couplers at -th.
constexpr int kN = 40;
const double kA02c = kG * (0.5 * (kN + 1) + kN) / ((kN + 1) / 3.0 + kN);

void a02_state(double th, double thd, double* q, double* v) {
  for (int i = 0; i < 2 * kN + 1; ++i) {
    q[i] = (i % 2 == 0) ? th : -th;
    v[i] = (i % 2 == 0) ? thd : -thd;
  }
}

jrgen::sim::OdeProblem a02_scalar() {
  jrgen::sim::OdeProblem p;
  p.n = 2;
  p.rhs = [](double, const double* y, double* d, std::string&) {
    d[0] = y[1];
    d[1] = kA02c * std::sin(y[0]);
    return 0;
  };
  return p;
}

// th(t_end), th'(t_end) by dopri5 at 1e-14; `rk4_diff` = |th - th_rk4| (2e5 fixed steps).
Vec a02_reference(double t_end, double* rk4_diff) {
  Vec y = {0.0, -1.0};
  Settings s;
  s.method = "dopri5";
  s.rtol = s.atol = 1e-14;
  jrgen::sim::integrate(a02_scalar(), 0, t_end, y, s);
  Vec z = {0.0, -1.0};
  s.method = "rk4";
  s.dt = t_end / 200000;
  jrgen::sim::integrate(a02_scalar(), 0, t_end, z, s);
  *rk4_diff = std::abs(y[0] - z[0]);
  return y;
}

// The first time the cranks are flat (th = -pi/2), by bisection on the dense output.
double a02_time_flat() {
  double t_lo = 0, t_hi = 2;
  for (int i = 0; i < 60; ++i) {
    const double t = 0.5 * (t_lo + t_hi);
    double d;
    (a02_reference(t, &d)[0] > -M_PI / 2 ? t_lo : t_hi) = t;
    if (t_hi - t_lo < 1e-9) break;
  }
  return 0.5 * (t_lo + t_hi);
}

// ---- the problems -----------------------------------------------------------------

struct Problem {
  Problem(std::string n, const jrgen::sim::System& s, Vec q, Vec v)
      : name(std::move(n)), sys(s), q0(std::move(q)), v0(std::move(v)) {}
  std::string name;
  jrgen::sim::System sys;
  Vec q0, v0;
  double t_end = 0;
  std::string span_note;  ///< why this span
  Vec q_ref;              ///< reference q at t_end (filled by prepare())
  std::string ref_note;
  bool relative = false;  ///< error relative to max |q_ref| (A03, as the test set's scd)
  std::function<double(const double* y)> work;  ///< external work since t = 0 (A03's motor)
  bool dampers = false;  ///< A05: the dissipated work is integrated with the run (damper_power)
  std::vector<double> rk4_dt;
  std::vector<std::string> methods = {"dopri5", "radau5", "sdirk4", "auto"};
  std::function<double(const double* y)> defect;  ///< A02: distance from the parallelogram
};

Problem a01(bool quick) {
  Problem p("A01", JRGEN_SIM_SYSTEM(published_a01), {0.0}, {0.0});
  p.t_end = quick ? 10 * a01_period() : 2000;
  p.span_note = quick ? "10 periods" : "the published 2000 s (845 periods)";
  p.q_ref = {a01_exact_q(p.t_end)};
  p.ref_note = "exact: 2 asin(k sn(K - sqrt(g) t, k)) - pi/2, k = sin(pi/4)";
  p.rk4_dt = {1e-2, 3e-3, 1e-3};
  return p;
}

// A02: the published 20 s, through the flat (singular) configurations th = -pi/2 (mod pi);
// --quick stops before the first one.  `solver` is the default or the proximal one.
Problem a02_with(bool quick, const jrgen::sim::System& sys, const std::string& name) {
  Problem p(name, sys, Vec(sys.nq), Vec(sys.nv));
  a02_state(0, -1, p.q0.data(), p.v0.data());
  const double t_flat = a02_time_flat();
  p.t_end = quick ? 0.95 * t_flat : 20;
  char buf[200];
  std::snprintf(buf, sizeof buf, "%s; the first flat (singular) configuration at t = %.6f s",
                quick ? "0.95 x the first flat configuration" : "the published 20 s", t_flat);
  p.span_note = buf;
  double d;
  Vec th = a02_reference(p.t_end, &d);
  Vec v(p.q0.size());
  p.q_ref.resize(p.q0.size());
  if (!quick) {  // the published 20 s: the independent reference (SUNDIALS CVODE at 1e-14)
    const auto f = jrgen::reference::read_reference_file(std::string(JRGEN_SOURCE_DIR) +
                                                         "/tests/published/reference/a02_reduced.tsv");
    const double th_file = f.row_at(p.t_end)[f.column("th")];
    std::snprintf(buf, sizeof buf, "th'' = %.6f sin th by SUNDIALS CVODE at 1e-14 (tests/published/reference/"
                  "a02_reduced.tsv; jrgen's dopri5 at 1e-14: %.1e apart), th(t_end) = %.6f", kA02c,
                  std::abs(th_file - th[0]), th_file);
    th[0] = th_file;
  } else {
    std::snprintf(buf, sizeof buf, "th'' = %.6f sin th by jrgen's dopri5 at 1e-14 (RK4, 2e5 steps: %.1e apart), "
                  "th(t_end) = %.6f", kA02c, d, th[0]);
  }
  a02_state(th[0], th[1], p.q_ref.data(), v.data());
  p.ref_note = buf;
  p.rk4_dt = {1e-2, 3e-3, 1e-3};
  p.defect = [](const double* y) {  // max |q_i -+ q_0|: 0 on the parallelogram
    double e = 0;
    for (int i = 1; i < 2 * kN + 1; ++i) e = std::max(e, std::abs(y[i] - ((i % 2 == 0) ? y[0] : -y[0])));
    return e;
  };
  return p;
}

Problem a02(bool quick) { return a02_with(quick, JRGEN_SIM_SYSTEM(published_a02), "A02"); }

// The same with the regularized solver (--singular proximal, docs/singular.md).
Problem a02_proximal() {
  Problem p = a02_with(false, JRGEN_SIM_SYSTEM(published_a02_proximal), "A02-proximal");
  p.rk4_dt = {1e-3};
  return p;
}

Problem a03(bool) {
  Problem p("A03", JRGEN_SIM_SYSTEM(published_andrews), Vec(7), Vec(7, 0.0));
  for (int i = 0; i < 7; ++i) p.q0[i] = andrews_ref::q0[andrews_ref::perm[i]];
  p.t_end = andrews_ref::t_end;
  p.span_note = "the published 0.03 s";
  p.q_ref.resize(7);
  for (int i = 0; i < 7; ++i) p.q_ref[i] = andrews_ref::q_end[andrews_ref::perm[i]];
  p.ref_note = "Test Set for IVP Solvers, andsoln (PSIDE, tol 1e-14)";
  p.relative = true;
  const double beta0 = p.q0[0];  // the motor's constant torque mom on beta (jrgen's q[0])
  p.work = [beta0](const double* y) { return andrews_ref::mom * (y[0] - beta0); };
  p.rk4_dt = {1e-5, 3e-6, 1e-6};
  return p;
}

Problem a04(bool quick) {
  Problem p("A04", JRGEN_SIM_SYSTEM(published_a04), Vec(5, 0.0), Vec(5, 0.0));
  p.t_end = quick ? 2 : 10;
  p.span_note = quick ? "2 s" : "the published 10 s";
  p.rk4_dt = {1e-2, 3e-3, 1e-3};
  return p;
}

Problem a05(bool quick) {
  Problem p("A05", JRGEN_SIM_SYSTEM(published_a05), {0, 0.5, M_PI / 6, M_PI / 6}, {2 * M_PI, 0, 0, 0});
  p.t_end = quick ? 1 : 10;
  p.span_note = quick ? "1 s" : "the published 10 s";
  p.dampers = true;  // 4e4 N s/m: the energy balance includes the dissipated work
  p.rk4_dt = {2e-5, 1e-5};
  return p;
}

// ---- runs ---------------------------------------------------------------------------

double cpu_seconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

double error_of(const Problem& p, const double* y) {
  double e = 0, scale = 0;
  for (std::size_t i = 0; i < p.q_ref.size(); ++i) {
    e = std::max(e, std::abs(y[i] - p.q_ref[i]));
    scale = std::max(scale, std::abs(p.q_ref[i]));
  }
  return p.relative ? e / scale : e;
}

struct Drift {
  double energy = 0, ke_max = 0, phi = 0, phiqv = 0;
};

// One observed run: max |E - W - E0| / max kinetic energy, max |Phi|, max |Phiq v| over
// the accepted steps; `series` (when given) receives (t, energy drift, |Phi|, |Phiq v|).
// The power the dampers dissipate, v^T D(q) v: h(q, v) = C(q)[v, v] + D(q) v + g(q) (Coriolis
// quadratic, dampers linear, gravity and springs independent of v), so
// h(q, v) - h(q, -v) = 2 D(q) v exactly.  With no external forces and ideal constraints,
// dE/dt = -v^T D v.
double damper_power(const jrgen::sim::System& sys, const double* y) {
  thread_local Vec h1, h2, vn;
  h1.resize(sys.nv);
  h2.resize(sys.nv);
  vn.assign(y + sys.nq, y + sys.nq + sys.nv);
  for (double& x : vn) x = -x;
  sys.bias_forces(y, y + sys.nq, h1.data());
  sys.bias_forces(y, vn.data(), h2.data());
  double p = 0;
  for (int i = 0; i < sys.nv; ++i) p += 0.5 * y[sys.nq + i] * (h1[i] - h2[i]);
  return p;
}

// Runs the mechanism; with dampers, the dissipated work D = int v^T D v dt is one more state
// (y[n]), integrated with the run (its error joins the step control: this observed run's
// steps differ slightly from the timed run's).
void run_with_work(const Problem& p, const Mechanism& m, const Settings& s, Vec& y,
                   const jrgen::sim::Observer& observe) {
  if (!p.dampers) {
    m.run(0, p.t_end, y, s, observe);
    return;
  }
  const jrgen::sim::OdeProblem base = m.problem();
  jrgen::sim::OdeProblem aug;
  aug.n = base.n + 1;
  aug.rhs = [&](double t, const double* yy, double* dy, std::string& err) {
    const int rc = base.rhs(t, yy, dy, err);
    if (rc == 0) dy[base.n] = damper_power(p.sys, yy);
    return rc;
  };
  aug.after_step = base.after_step;
  y.push_back(0.0);
  jrgen::sim::integrate(aug, 0, p.t_end, y, s, observe);
}

Drift observed_run(const Problem& p, const Mechanism& m, const Settings& s, std::vector<Vec>* series) {
  Vec y = m.initial_state(p.q0.data(), p.v0.data());
  const double e0 = m.energy(y.data());
  const int n = m.size();
  Drift d;
  std::vector<Vec> local;
  std::vector<Vec>& rows = series ? *series : local;
  run_with_work(p, m, s, y, [&](double t, const double* yy) {
    const double e = m.energy(yy), ke = e - p.sys.potential_energy(yy);
    const double dissipated = p.dampers ? yy[n] : 0.0;
    const double de = std::abs(e + dissipated - (p.work ? p.work(yy) : 0.0) - e0);
    d.energy = std::max(d.energy, de);
    d.ke_max = std::max(d.ke_max, ke);
    const double phi = m.phi_norm(yy), phiqv = m.phiqv_norm(yy);
    d.phi = std::max(d.phi, phi);
    d.phiqv = std::max(d.phiqv, phiqv);
    if (series) rows.push_back({t, de, phi, phiqv, ke});
  });
  d.energy /= d.ke_max;
  return d;
}

struct Row {
  explicit Row(const Settings& s)
      : method(s.method), tol(s.method == "rk4" ? 0.0 : s.rtol), dt(s.method == "rk4" ? s.dt : 0.0) {}
  std::string method;
  double tol = 0, dt = 0, error = NAN, cpu = NAN;
  int reps = 0;
  Stats st;
  Drift drift;
  std::string status = "ok";
};

bool g_no_drift = false;  // --no-drift

// Timed runs (no observer): 7 repetitions below 20 ms, 3 below 0.5 s, else 1; the median.
Row timed_run(const Problem& p, const Mechanism& m, const Settings& s) {
  Row r(s);
  std::vector<double> times;
  int reps = 1;
  for (int i = 0; i < reps; ++i) {
    Vec y = m.initial_state(p.q0.data(), p.v0.data());
    const double c0 = cpu_seconds();
    r.st = m.run(0, p.t_end, y, s);
    times.push_back(cpu_seconds() - c0);
    if (i == 0) {
      reps = times[0] < 0.02 ? 7 : times[0] < 0.5 ? 3 : 1;
      r.error = error_of(p, y.data());
      if (p.defect && r.error > 1e-2)
        std::fprintf(stderr, "%s %s tol %.0e dt %.0e: error %.2e, distance from the parallelogram %.2e\n",
                     p.name.c_str(), s.method.c_str(), r.tol, r.dt, r.error, p.defect(y.data()));
    }
  }
  std::sort(times.begin(), times.end());
  r.cpu = times[times.size() / 2];
  r.reps = reps;
  if (g_no_drift) r.drift.energy = r.drift.phi = r.drift.phiqv = NAN;
  else r.drift = observed_run(p, m, s, nullptr);
  return r;
}

Row one_run(const Problem& p, const Mechanism& m, const Settings& s) {
  try {
    return timed_run(p, m, s);
  } catch (const std::exception& e) {
    Row r(s);
    r.status = std::string("failed: ") + e.what();
    return r;
  }
}

// A04, A05: the reference is the independent trajectory of tests/published/reference/
// (SUNDIALS CVODE at rtol = atol = 1e-14 on the dynamics of tests/reference/, made by
// tests/reference/trajectory_reference.cpp; docs/testing.md, "References"), its row at t_end.
void file_reference(Problem& p, const std::string& file) {
  const auto f = jrgen::reference::read_reference_file(std::string(JRGEN_SOURCE_DIR) + "/tests/published/reference/" +
                                                       file);
  const Vec& row = f.row_at(p.t_end);
  p.q_ref.resize(p.sys.nq);
  for (int i = 0; i < p.sys.nq; ++i) p.q_ref[i] = row[f.column("q" + std::to_string(i))];
  p.ref_note = "SUNDIALS CVODE at 1e-14 on tests/reference/'s dynamics (tests/published/reference/" + file + ")";
}

const char* kHeader =
    "problem\tmethod\ttol\tdt\terror\tcpu_s\treps\tfd_calls\tsteps\trejected\tswitched\t"
    "energy_drift\tphi_max\tphiqv_max\tnear_singular\tsingular_checks\tstatus\n";

void write_row(FILE* f, const Problem& p, const Row& r) {
  std::fprintf(f, "%s\t%s\t%.0e\t%.0e\t%.3e\t%.4e\t%d\t%ld\t%ld\t%ld\t%ld\t", p.name.c_str(), r.method.c_str(), r.tol,
               r.dt, r.error, r.cpu, r.reps, r.st.f_calls, r.st.steps, r.st.rejected, r.st.switches);
  std::fprintf(f, "%.3e\t", r.drift.energy);
  if (p.sys.nc > 0)
    std::fprintf(f, "%.3e\t%.3e\t", r.drift.phi, r.drift.phiqv);
  else
    std::fprintf(f, "n/a\tn/a\t");
  std::fprintf(f, "%ld\t%ld\t%s\n", r.st.near_singular, r.st.singular_checks, r.status.c_str());
  std::fflush(f);
}

// The sweep of one problem: each method over `tols` (tightest last), stopping a method's
// sweep once one run took more than `budget` CPU seconds; rk4 at its fixed steps.
std::vector<Row> sweep(const Problem& p, const Mechanism& m, const std::vector<double>& tols, bool quick,
                       double budget, FILE* out, bool rk4 = true) {
  std::vector<Row> rows;
  for (const std::string& method : p.methods) {
    for (double tol : tols) {
      Settings s;
      s.method = method;
      s.rtol = s.atol = tol;
      rows.push_back(one_run(p, m, s));
      write_row(out, p, rows.back());
      if (!(rows.back().cpu <= budget)) break;
    }
  }
  if (quick || !rk4) return rows;
  for (double dt : p.rk4_dt) {
    Settings s;
    s.method = "rk4";
    s.dt = dt;
    rows.push_back(one_run(p, m, s));
    write_row(out, p, rows.back());
  }
  return rows;
}

// The drift series: auto at tol 1e-6 with projection and without stabilization, thinned to
// at most 1500 rows each (every k-th accepted step).
void write_series(FILE* f, const Problem& p) {
  for (const auto stab : {jrgen::sim::Stabilization::kProjection, jrgen::sim::Stabilization::kNone}) {
    if (stab == jrgen::sim::Stabilization::kNone && p.sys.nc == 0) continue;
    jrgen::sim::MechanismSettings ms;
    ms.stabilization = stab;
    const Mechanism m(p.sys, ms);
    Settings s;
    s.rtol = s.atol = 1e-6;
    std::vector<Vec> rows;
    const char* label = stab == jrgen::sim::Stabilization::kNone ? "none" : "projection";
    try {
      observed_run(p, m, s, &rows);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "%s drift series (%s): %s\n", p.name.c_str(), label, e.what());
    }
    double ke_max = 0;  // the energy drift's scale: the largest kinetic energy of the rows
    for (const Vec& r : rows) ke_max = std::max(ke_max, r[4]);
    const std::size_t k = std::max<std::size_t>(1, rows.size() / 1500);
    for (std::size_t i = 0; i < rows.size(); ++i)
      if (i % k == 0 || i + 1 == rows.size())
        std::fprintf(f, "%s\t%s\t%.6e\t%.3e\t%.3e\t%.3e\n", p.name.c_str(), label, rows[i][0],
                     rows[i][1] / ke_max, rows[i][2], rows[i][3]);
  }
}

// ---- checks (--check) ----------------------------------------------------------------

// Per problem and method, over the tolerances in order (loosest first): the error at the
// tightest is at least 10 x below the loosest's (four decades of tol apart in --quick),
// and no tightening raises it by more than 3 x (noise of the step sequence, tolerance
// proportionality is not exact); auto ends within 100 x tol of the reference.
int check_runs(const Problem& p, const std::vector<Row>& rows) {
  int fails = 0;
  auto fail = [&](const std::string& what) {
    std::fprintf(stderr, "CHECK FAILED: %s: %s\n", p.name.c_str(), what.c_str());
    ++fails;
  };
  for (const std::string& method : p.methods) {
    std::vector<const Row*> mr;
    for (const Row& r : rows)
      if (r.method == method) mr.push_back(&r);
    char buf[200];
    for (std::size_t i = 0; i < mr.size(); ++i) {
      const Row& r = *mr[i];
      if (r.status != "ok" || !(r.error >= 0)) {
        fail(method + " tol " + std::to_string(r.tol) + ": " + r.status);
        continue;
      }
      if (i > 0 && !(r.error <= 3 * mr[i - 1]->error)) {
        std::snprintf(buf, sizeof buf, "%s: error %.2e at tol %.0e, above 3 x %.2e at tol %.0e", method.c_str(),
                      r.error, r.tol, mr[i - 1]->error, mr[i - 1]->tol);
        fail(buf);
      }
      if (method == "auto" && !(r.error <= 100 * r.tol)) {
        std::snprintf(buf, sizeof buf, "auto: error %.2e at tol %.0e, above 100 x tol", r.error, r.tol);
        fail(buf);
      }
    }
    if (mr.size() >= 2 && !(mr.back()->error <= 0.1 * mr.front()->error)) {
      std::snprintf(buf, sizeof buf, "%s: error %.2e at tol %.0e not 10 x below %.2e at tol %.0e", method.c_str(),
                    mr.back()->error, mr.back()->tol, mr.front()->error, mr.front()->tol);
      fail(buf);
    }
  }
  return fails;
}

struct Options {
  bool quick = false, check = false;
  std::string out, series, only;
  std::vector<std::string> methods;  // --method (empty: each problem's)
  std::vector<double> tols;          // --tols (empty: the default sweep)
  double budget = NAN;               // --budget (NaN: 20 s, --quick 5 s)
};

std::vector<std::string> split(const std::string& text) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = text.find(',', start);
    out.push_back(text.substr(start, comma - start));
    if (comma == std::string::npos) return out;
    start = comma + 1;
  }
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::runtime_error("option " + a + " needs a value");
      return argv[++i];
    };
    if (a == "--quick") o.quick = true;
    else if (a == "--check") o.check = true;
    else if (a == "-o") o.out = value();
    else if (a == "--series") o.series = value();
    else if (a == "--only") o.only = value();
    else if (a == "--method") o.methods = split(value());
    else if (a == "--tols")
      for (const std::string& t : split(value())) o.tols.push_back(std::stod(t));
    else if (a == "--budget") o.budget = std::stod(value());
    else if (a == "--no-drift") g_no_drift = true;
    else throw std::runtime_error("unknown option '" + a + "' (use --quick, --check, -o FILE, --series FILE, --only NAME, "
                                  "--method M1,M2, --tols T1,T2, --budget S, --no-drift)");
  }
  return o;
}

FILE* open_or_stdout(const std::string& path) {
  if (path.empty()) return stdout;
  FILE* f = std::fopen(path.c_str(), "w");
  if (!f) throw std::runtime_error("cannot write '" + path + "': " + std::strerror(errno));
  return f;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const Options o = parse(argc, argv);
    FILE* out = open_or_stdout(o.out);
    FILE* ser = o.series.empty() ? nullptr : open_or_stdout(o.series);
    std::fputs(kHeader, out);
    if (ser) std::fputs("problem\tstabilization\tt\tenergy_drift\tphi\tphiqv\n", ser);
    const std::vector<double> tols = !o.tols.empty() ? o.tols
                                     : o.quick      ? std::vector<double>{1e-4, 1e-6, 1e-8}
                                                    : std::vector<double>{1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10};
    const double budget = !std::isnan(o.budget) ? o.budget : o.quick ? 5.0 : 20.0;
    bool rk4 = true;  // --method without rk4: no fixed-step rows
    if (!o.methods.empty()) rk4 = std::find(o.methods.begin(), o.methods.end(), "rk4") != o.methods.end();
    int fails = 0;
    for (auto make : {a01, a02, a03, a04, a05}) {
      Problem p = make(o.quick);
      if (!o.only.empty() && p.name != o.only) continue;
      if (!o.methods.empty()) {
        p.methods.clear();
        for (const std::string& mth : o.methods)
          if (mth != "rk4") p.methods.push_back(mth);
      }
      const Mechanism m(p.sys);
      if (p.name == "A04") file_reference(p, "a04.tsv");
      if (p.name == "A05") file_reference(p, "a05.tsv");
      std::fprintf(stderr, "%s: t_end = %g s (%s); reference: %s\n", p.name.c_str(), p.t_end, p.span_note.c_str(),
                   p.ref_note.c_str());
      const std::vector<Row> rows = sweep(p, m, tols, o.quick, budget, out, rk4);
      if (ser) write_series(ser, p);
      if (o.check) fails += check_runs(p, rows);
    }
    if (!o.quick && (o.only.empty() || o.only == "A02") && o.methods.empty() && o.tols.empty())
      {
        const Problem p = a02_proximal();
        std::fprintf(stderr, "%s: t_end = %g s (%s); reference: %s\n", p.name.c_str(), p.t_end, p.span_note.c_str(),
                     p.ref_note.c_str());
        sweep(p, Mechanism(p.sys), {1e-3, 1e-5, 1e-7, 1e-9}, false, 3.0, out);  // radau5, sdirk4: 5-30 s at 1e-7
      }
    if (out != stdout) std::fclose(out);
    if (ser && ser != stdout) std::fclose(ser);
    if (fails) std::fprintf(stderr, "%d check(s) failed\n", fails);
    return fails ? 1 : 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "published_work_precision: error: %s\n", e.what());
    return 2;
  }
}
