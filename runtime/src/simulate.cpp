// Time integration (jrgen/simulate.hpp, docs/simulation.md).
//
// References: HNW I = Hairer, Norsett & Wanner, Solving ODEs I (2nd ed.);
// HW II = Hairer & Wanner, Solving ODEs II (2nd ed.).
#include "jrgen/simulate.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace jrgen::sim {

namespace {

std::string fmt_time(double t) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "at t = %.17g", t);
  return buf;
}

std::string fmt_g(double x) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3g", x);
  return buf;
}

using Vec = Eigen::VectorXd;

// Weighted RMS norm of HNW I, II.4 (4.11): sc_i = atol + rtol max(|a_i|, |b_i|).
double wrms(const Vec& e, const Vec& a, const Vec& b, double rtol, double atol) {
  double s = 0.0;
  for (Eigen::Index i = 0; i < e.size(); ++i) {
    const double sc = atol + rtol * std::max(std::abs(a[i]), std::abs(b[i]));
    s += (e[i] / sc) * (e[i] / sc);
  }
  return e.size() ? std::sqrt(s / static_cast<double>(e.size())) : 0.0;
}

// Everything one integrate() call shares: the problem, settings, counters,
// the output schedule and the step-size underflow test.
struct Run {
  const OdeProblem& p;
  const Settings& s;
  const Observer& observe;
  double t0, t_end;
  Stats st;
  std::string last_rhs_error;  // the latest failure of f, for messages
  double t_next_out = 0.0;
  long k_out = 0;
  double t_now = 0.0;   // time reached
  double h_next = 0.0;  // step to continue with (0: choose one)
  int last_rhs_status = 0;  // the status of last_rhs_error

  // f at a stage: non-zero (a failure, or kRhsRegularized) rejects the step.
  int f(double t, const Vec& y, Vec& dy) {
    ++st.f_calls;
    std::string err;
    const int status = p.rhs(t, y.data(), dy.data(), err);
    if ((status == 0 || status == kRhsRegularized) && !dy.allFinite()) {
      last_rhs_error = "f(t, y) is not finite";
      return 3;
    }
    if (status == kRhsRegularized) ++st.regularized;
    if (status != 0) {
      last_rhs_error = err;
      last_rhs_status = status;
    }
    return status;
  }
  // f at an accepted state: a failure there ends the run; a regularized
  // answer there (the state is on the singular configuration) is used and
  // counted, the first one described.
  void f_accepted(double t, const Vec& y, Vec& dy) {
    const int status = f(t, y, dy);
    if (status == kRhsRegularized) {
      if (st.regularized_used++ == 0) st.regularized_note = fmt_time(t) + ": " + last_rhs_error;
      return;
    }
    if (status != 0) throw Failure(t, last_rhs_error);
  }
  // An accepted step's local error estimate (the vector whose norm the step-size control
  // used): into Stats::err_est and err_step_max (max norm, the state's units).
  void note_error(const Vec& err) {
    const double e = err.cwiseAbs().maxCoeff();
    st.err_est += e;
    st.err_step_max = std::max(st.err_step_max, e);
  }
  void accept(double t, Vec& y) {
    if (p.after_step) p.after_step(t, y.data());
  }
  // Outputs after an accepted step [ta, tb]; interp(t, out) gives y(t) inside.
  template <class Interp>
  void output(double tb, const Vec& yb, Interp interp) {
    if (!observe) return;
    if (s.every > 0.0) {
      Vec yo(yb.size());
      // Output times in (ta, tb]: every earlier one was written by an earlier step.
      while (t_next_out <= tb && t_next_out < t_end) {
        interp(t_next_out, yo);
        if (p.after_step) p.after_step(t_next_out, yo.data());
        observe(t_next_out, yo.data());
        t_next_out = t0 + static_cast<double>(++k_out) * s.every;
      }
      if (tb == t_end) observe(tb, yb.data());
    } else {
      observe(tb, yb.data());
    }
  }
  // Step size underflow (HNW I, II.4: h below 16 eps |t|): a named failure.
  void check_h(double t, double h) {
    if (h < 16.0 * std::numeric_limits<double>::epsilon() * std::max(std::abs(t), 1e-300) || !(h > 0.0)) {
      std::string why = "step size underflow (h = " + fmt_g(h) + ")";
      if (last_rhs_error.empty()) why += "; the problem may be stiff here: try --integrator radau5";
      else why += "; last failure of the dynamics: " + last_rhs_error;
      if (last_rhs_status == kRhsRegularized)
        why += "; the steps did not jump the singular configuration: loosen --rtol/--atol (docs/simulation.md, "
               "\"Failures\")";
      throw Failure(t, why);
    }
    if (st.steps + st.rejected >= s.max_steps)
      throw Failure(t, "more than " + std::to_string(s.max_steps) +
                           " steps; loosen --rtol/--atol, or use --integrator radau5 if the problem is stiff");
  }
  // The last step lands on t_end exactly.
  double clip(double t, double h) const {
    if (t + 1.01 * h >= t_end) return t_end - t;
    return h;
  }
  double h_max() const { return s.h_max > 0.0 ? s.h_max : std::abs(t_end - t0); }
};

// Starting step size, HNW I, II.4 (p. 169), for a method of order p.
double initial_step(Run& r, double t, const Vec& y, const Vec& f0, int p) {
  if (r.s.dt > 0.0) return std::min(r.s.dt, r.h_max());
  const Vec zero = Vec::Zero(y.size());
  const double d0 = wrms(y, y, y, r.s.rtol, r.s.atol), d1 = wrms(f0, y, y, r.s.rtol, r.s.atol);
  double h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
  h0 = std::min(h0, r.h_max());
  Vec y1 = y + h0 * f0, f1(y.size());
  if (r.f(t + h0, y1, f1) != 0) return h0;
  const double d2 = wrms(f1 - f0, y, y, r.s.rtol, r.s.atol) / h0;
  const double dm = std::max(d1, d2);
  const double h1 = dm <= 1e-15 ? std::max(1e-6, h0 * 1e-3) : std::pow(0.01 / dm, 1.0 / (p + 1));
  return std::min({100.0 * h0, h1, r.h_max()});
}

// Cubic Hermite interpolation between (ta, ya, fa) and (tb, yb, fb).
void hermite(double ta, double tb, const Vec& ya, const Vec& fa, const Vec& yb, const Vec& fb, double t, Vec& out) {
  const double h = tb - ta, th = (t - ta) / h;
  const double h00 = (1 + 2 * th) * (1 - th) * (1 - th), h10 = th * (1 - th) * (1 - th);
  const double h01 = th * th * (3 - 2 * th), h11 = th * th * (th - 1);
  out = h00 * ya + h10 * h * fa + h01 * yb + h11 * h * fb;
}

// ---- Dormand-Prince 5(4), HNW I, II.5 Table 5.2; dense output II.6 (6.12) -----
// Integrates from r.t_now (with r.h_next if set); with `detect`, returns early when the
// problem looks stiff: h |lambda| estimated as h |k7 - k6| / |y1 - y6| above
// 3.25 (dopri5's stability boundary) on 15 accepted steps without 6
// non-stiff steps in between (HNW I, II.10, as in Hairer's DOPRI5).
void dopri5(Run& r, Vec& y, bool detect) {
  static constexpr double c2 = 1. / 5, c3 = 3. / 10, c4 = 4. / 5, c5 = 8. / 9;
  static constexpr double a21 = 1. / 5, a31 = 3. / 40, a32 = 9. / 40, a41 = 44. / 45, a42 = -56. / 15,
                          a43 = 32. / 9, a51 = 19372. / 6561, a52 = -25360. / 2187, a53 = 64448. / 6561,
                          a54 = -212. / 729, a61 = 9017. / 3168, a62 = -355. / 33, a63 = 46732. / 5247,
                          a64 = 49. / 176, a65 = -5103. / 18656, a71 = 35. / 384, a73 = 500. / 1113,
                          a74 = 125. / 192, a75 = -2187. / 6784, a76 = 11. / 84;
  static constexpr double e1 = 71. / 57600, e3 = -71. / 16695, e4 = 71. / 1920, e5 = -17253. / 339200,
                          e6 = 22. / 525, e7 = -1. / 40;
  static constexpr double d1 = -12715105075. / 11282082432, d3 = 87487479700. / 32700410799,
                          d4 = -10690763975. / 1880347072, d5 = 701980252875. / 199316789632,
                          d6 = -1453857185. / 822651844, d7 = 69997945. / 29380423;
  const Eigen::Index n = y.size();
  Vec k1(n), k2(n), k3(n), k4(n), k5(n), k6(n), k7(n), yt(n), y1(n), err(n);
  Vec r1(n), r2(n), r3(n), r4(n), r5(n);
  double& t = r.t_now;
  r.f_accepted(t, y, k1);
  double h = r.h_next > 0.0 ? r.h_next : initial_step(r, t, y, k1, 5);
  bool rejected_last = false;
  int stiff = 0, nonstiff = 0;
  while (t < r.t_end) {
    h = r.clip(t, std::min(h, r.h_max()));
    r.check_h(t, h);
    int bad = 0;
    yt = y + h * a21 * k1;
    bad |= r.f(t + c2 * h, yt, k2);
    yt = y + h * (a31 * k1 + a32 * k2);
    bad |= bad ? 0 : r.f(t + c3 * h, yt, k3);
    yt = y + h * (a41 * k1 + a42 * k2 + a43 * k3);
    bad |= bad ? 0 : r.f(t + c4 * h, yt, k4);
    yt = y + h * (a51 * k1 + a52 * k2 + a53 * k3 + a54 * k4);
    bad |= bad ? 0 : r.f(t + c5 * h, yt, k5);
    yt = y + h * (a61 * k1 + a62 * k2 + a63 * k3 + a64 * k4 + a65 * k5);
    bad |= bad ? 0 : r.f(t + h, yt, k6);  // yt keeps the stage-6 state for the stiffness test
    y1 = y + h * (a71 * k1 + a73 * k3 + a74 * k4 + a75 * k5 + a76 * k6);
    bad |= bad ? 0 : r.f(t + h, y1, k7);
    if (bad) {  // a stage left the solver's domain: a shorter step
      ++r.st.rejected;
      h *= 0.25;
      rejected_last = true;
      continue;
    }
    err = h * (e1 * k1 + e3 * k3 + e4 * k4 + e5 * k5 + e6 * k6 + e7 * k7);
    const double E = wrms(err, y, y1, r.s.rtol, r.s.atol);
    // Step-size control, HNW I, II.4 (4.13): fac = 0.9, facmax = 10 (1 after a rejection).
    const double fac = std::clamp(0.9 * std::pow(std::max(E, 1e-10), -0.2), 0.2, rejected_last ? 1.0 : 10.0);
    if (E > 1.0) {
      ++r.st.rejected;
      h *= std::min(fac, 0.9);
      rejected_last = true;
      continue;
    }
    // Dense output coefficients (before y moves).
    r1 = y;
    r2 = y1 - y;
    r3 = h * k1 - r2;
    r4 = r2 - h * k7 - r3;
    r5 = h * (d1 * k1 + d3 * k3 + d4 * k4 + d5 * k5 + d6 * k6 + d7 * k7);
    r.note_error(err);
    const double ta = t;
    const double den = (y1 - yt).squaredNorm();
    const double h_lambda = den > 0.0 ? h * std::sqrt((k7 - k6).squaredNorm() / den) : 0.0;
    t = (h == r.t_end - t) ? r.t_end : t + h;
    ++r.st.steps;
    y = y1;
    r.accept(t, y);
    r.output(t, y, [&](double tt, Vec& out) {
      const double th = (tt - ta) / h, th1 = 1 - th;
      out = r1 + th * (r2 + th1 * (r3 + th * (r4 + th1 * r5)));
    });
    h *= fac;
    rejected_last = false;
    if (h_lambda > 3.25) {
      nonstiff = 0;
      if (++stiff == 15 && detect) {
        r.h_next = h;
        ++r.st.switches;
        return;
      }
    } else if (++nonstiff == 6) {
      stiff = 0;
    }
    if (y != y1) r.f_accepted(t, y, k1);  // y was moved by after_step: no FSAL
    else k1 = k7;
  }
}

// ---- SDIRK4, HW II, IV.6 Table 6.5 (gamma = 1/4, L-stable, stiffly accurate) ---
struct Sdirk4 {
  static constexpr int s = 5;
  static constexpr double g = 0.25;
  static constexpr double c[s] = {0.25, 0.75, 11. / 20, 0.5, 1.0};
  static constexpr double A[s][s] = {{0.25, 0, 0, 0, 0},
                                     {0.5, 0.25, 0, 0, 0},
                                     {17. / 50, -1. / 25, 0.25, 0, 0},
                                     {371. / 1360, -137. / 2720, 15. / 544, 0.25, 0},
                                     {25. / 24, -49. / 48, 125. / 16, -85. / 12, 0.25}};
  // b - bhat, bhat the embedded order-3 weights (59/48, -17/96, 225/32, -85/12, 0).
  static constexpr double e[s] = {25. / 24 - 59. / 48, -49. / 48 + 17. / 96, 125. / 16 - 225. / 32, 0.0, 0.25};
};

struct Newton {
  Eigen::MatrixXd J;
  Eigen::PartialPivLU<Eigen::MatrixXd> lu;
  bool have_J = false, J_fresh = false;
  double h_lu = 0.0;
};

// Forward-difference Jacobian of f at (t, y), one f call per column.  A
// regularized column (kRhsRegularized: y on, or delta into, a singular
// configuration) is kept: J only steers the Newton iterations, whose stage
// values decide what enters the result (and reject the step when regularized).
bool jacobian(Run& r, double t, const Vec& y, const Vec& f0, Eigen::MatrixXd& J) {
  const Eigen::Index n = y.size();
  J.resize(n, n);
  Vec yp = y, fp(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    // delta = sqrt(eps max(1e-5, |y_j|)) (HW II, RADAU5's choice).
    const double delta = std::sqrt(std::numeric_limits<double>::epsilon() * std::max(1e-5, std::abs(y[j])));
    yp[j] = y[j] + delta;
    const int status = r.f(t, yp, fp);
    if (status != 0 && status != kRhsRegularized) return false;
    J.col(j) = (fp - f0) / delta;
    yp[j] = y[j];
  }
  ++r.st.jacobians;
  return true;
}

// The convergence test shared by the simplified Newton iterations of sdirk4
// and radau5 (HW II, (8.10)-(8.12)): with the contraction theta of the last
// two increments, converged when the estimated remaining error
// theta / (1 - theta) |dZ| is below kappa tolerances (or |dZ| is already
// below 1e-3 kappa); diverged when theta >= 0.99 or the error predicted
// after the remaining iterations is above kappa.  radau5: kappa = kKappa
// (HW II's 0.05); sdirk4: per stage, sdirk4_kappa below.
struct NewtonTest {
  static constexpr int kMaxIt = 7;
  static constexpr double kKappa = 0.05;
  enum Verdict { kContinue, kConverged, kDiverged };
  double prev = 0.0;
  double& theta_max;
  double kappa = kKappa;

  Verdict judge(int it, double nrm) {
    if (nrm <= 1e-3 * kappa) return kConverged;  // the prediction was already exact
    if (it > 0) {
      const double theta = nrm / prev;
      theta_max = std::max(theta_max, theta);
      if (theta >= 0.99) return kDiverged;
      if (std::pow(theta, kMaxIt - 1 - it) / (1 - theta) * nrm > kappa) return kDiverged;
      if (theta / (1 - theta) * nrm <= kappa) return kConverged;
    }
    prev = nrm;
    return kContinue;
  }
};

// f in a Newton iteration: false on a failure; a regularized answer is
// used and flagged (newton_stage, radau_newton).
bool newton_f(Run& r, double t, const Vec& yz, Vec& fz, bool& regularized) {
  const int status = r.f(t, yz, fz);
  regularized |= status == kRhsRegularized;
  return status == 0 || status == kRhsRegularized;
}

// Stage i by simplified Newton (HW II, IV.8 (8.13)): Z = h sum_j a_ij k_j + h g f(y + Z),
// until NewtonTest says converged or diverged.  Unlike RADAU5, a first iterate is never taken
// on the previous stage's eta: with a Jacobian kept over many steps that
// let errors of 100 x the tolerance through (docs/simulation.md).  Returns
// false on divergence or predicted slow convergence.  A regularized f
// (kRhsRegularized) is taken in the iterations (the first starts at y, which
// may be on a singular configuration) but not in the last one, whose f
// determines the converged stage: that rejects the step (newton_f).
//
// The stopping tolerance of stage i (sdirk4_kappa): stage i's Newton error e_i enters
// y1 = Y_5 through the later stages as (a_5i / gamma) e_i, and is not in the error estimate
// (which sees only the converged k_i), so it must stay below the tolerance by itself:
// kappa_i = min(0.05, sqrt(rtol)) / max(1, |a_5i| / gamma) tolerances, not below the
// rounding floor eps / rtol.  With HW II's fixed 0.05 the errors at tight tolerances were not
// proportional to the tolerance (A02, docs/simulation.md "A02 in time").
double sdirk4_kappa(int i, double rtol) {
  const double k = std::min(NewtonTest::kKappa, std::sqrt(rtol)) /
                   std::max(1.0, std::abs(Sdirk4::A[Sdirk4::s - 1][i]) / Sdirk4::g);
  return std::max(k, std::numeric_limits<double>::epsilon() / rtol);
}

bool newton_stage(Run& r, Newton& nw, double t, double h, const Vec& y, const Vec& known, Vec& Z, double& theta_max,
                  double kappa) {
  const Eigen::Index n = y.size();
  Vec fz(n), res(n), dZ(n), yz(n);
  NewtonTest test{0.0, theta_max, kappa};
  for (int it = 0; it < NewtonTest::kMaxIt; ++it) {
    yz = y + Z;
    bool regularized = false;
    if (!newton_f(r, t, yz, fz, regularized)) return false;
    res = known + h * Sdirk4::g * fz - Z;
    dZ = nw.lu.solve(res);
    Z += dZ;
    const NewtonTest::Verdict verdict = test.judge(it, wrms(dZ, y, y, r.s.rtol, r.s.atol));
    if (verdict != NewtonTest::kContinue)
      return verdict == NewtonTest::kConverged && !regularized && Z.allFinite();
  }
  return false;
}

void sdirk4(Run& r, Vec& y) {
  const Eigen::Index n = y.size();
  Newton nw;
  Vec f0(n), k[Sdirk4::s], Z(n), Zprev(n), known(n), y1(n), err(n), fa(n), fb(n);
  for (auto& ki : k) ki.resize(n);
  double& t = r.t_now;
  r.f_accepted(t, y, f0);
  fa = f0;
  double h = r.h_next > 0.0 ? r.h_next : initial_step(r, t, y, f0, 4);
  bool rejected_last = false, f0_current = true;
  while (t < r.t_end) {
    h = r.clip(t, std::min(h, r.h_max()));
    r.check_h(t, h);
    if (!nw.have_J) {
      if (!f0_current) r.f_accepted(t, y, f0);
      if (!jacobian(r, t, y, f0, nw.J)) throw Failure(t, "finite-difference Jacobian: " + r.last_rhs_error);
      nw.have_J = nw.J_fresh = true;
      nw.h_lu = 0.0;
    }
    if (nw.h_lu != h) {
      nw.lu.compute(Eigen::MatrixXd::Identity(n, n) - h * Sdirk4::g * nw.J);
      nw.h_lu = h;
      ++r.st.factorizations;
    }
    bool ok = true;
    double theta_max = 0.0;
    for (int i = 0; i < Sdirk4::s && ok; ++i) {
      known.setZero();
      for (int j = 0; j < i; ++j) known += h * Sdirk4::A[i][j] * k[j];
      Z = i == 0 ? Vec(Vec::Zero(n)) : Vec(Zprev * (Sdirk4::c[i] / Sdirk4::c[i - 1]));
      ok = newton_stage(r, nw, t + Sdirk4::c[i] * h, h, y, known, Z, theta_max, sdirk4_kappa(i, r.s.rtol));
      if (ok) k[i] = (Z - known) / (h * Sdirk4::g);  // f(Y_i) consistent with the stage equation
      Zprev = Z;
    }
    if (!ok) {  // Newton failed: a fresh Jacobian first, then a shorter step
      ++r.st.rejected;
      ++r.st.newton_failures;
      if (!nw.J_fresh) nw.have_J = false;
      else h *= 0.5;
      rejected_last = true;
      continue;
    }
    y1 = y + Z;  // stiffly accurate: y1 = Y_s
    err.setZero();
    for (int i = 0; i < Sdirk4::s; ++i) err += h * Sdirk4::e[i] * k[i];
    err = nw.lu.solve(err);  // filtered estimate (HW II, IV.8 (8.20))
    const double E = wrms(err, y, y1, r.s.rtol, r.s.atol);
    double fac = std::clamp(0.9 * std::pow(std::max(E, 1e-10), -0.25), 0.2, rejected_last ? 1.0 : 5.0);
    if (E > 1.0) {
      ++r.st.rejected;
      h *= std::min(fac, 0.9);
      rejected_last = true;
      continue;
    }
    r.note_error(err);
    const double ta = t;
    t = (h == r.t_end - t) ? r.t_end : t + h;
    ++r.st.steps;
    const Vec ya = y;
    y = y1;
    fb = k[Sdirk4::s - 1];
    r.accept(t, y);
    r.output(t, y, [&](double tt, Vec& out) { hermite(ta, t, ya, fa, y1, fb, tt, out); });
    fa = fb;
    f0_current = false;
    nw.J_fresh = false;
    if (theta_max > 0.5) nw.have_J = false;  // slow convergence: a new Jacobian next step
    // Keep h (and the LU) when the change would be small (HW II, RADAU5: quot1 = 1, quot2 = 1.2).
    if (fac < 1.0 || fac > 1.2) h *= fac;
    rejected_last = false;
  }
}

// ---- Radau IIA of order 5 (HW II, IV.5 Table 5.6; IV.8 simplified Newton) ------
// Three-stage collocation, stiffly accurate, L-stable.  The simplified Newton
// system (I - h A (x) J) dZ = -Z + h (A (x) I) F(y + Z) is solved with one
// real LU of size 3n (RADAU5 transforms it into one real and one complex
// system of size n: a factor ~5 cheaper per factorization, which matters only
// when the LU dominates the forward-dynamics calls).  Error estimate of
// RADAU5 (HW II, IV.8 (8.19)-(8.20)): err = (I - h g0 J)^-1 h g0 (f(y0) +
// (dd1 Z1 + dd2 Z2 + dd3 Z3) / h), g0 = 1 / u1 the real eigenvalue of A.
struct Radau5 {
  static constexpr double s6 = 2.449489742783178098197284;  // sqrt(6)
  static constexpr double c[3] = {(4 - s6) / 10, (4 + s6) / 10, 1.0};
  static constexpr double A[3][3] = {{(88 - 7 * s6) / 360, (296 - 169 * s6) / 1800, (-2 + 3 * s6) / 225},
                                     {(296 + 169 * s6) / 1800, (88 + 7 * s6) / 360, (-2 - 3 * s6) / 225},
                                     {(16 - s6) / 36, (16 + s6) / 36, 1.0 / 9}};
  static constexpr double dd[3] = {-(13 + 7 * s6) / 3, (-13 + 7 * s6) / 3, -1.0 / 3};
};

// g0 = 1 / u1, u1 = 30 / (6 + 81^(1/3) - 9^(1/3)) the real eigenvalue of A^-1.
double radau_g0() { return (6.0 + std::cbrt(81.0) - std::cbrt(9.0)) / 30.0; }

struct RadauNewton {
  Eigen::MatrixXd J;
  Eigen::PartialPivLU<Eigen::MatrixXd> lu3;  // I - h A (x) J
  Eigen::PartialPivLU<Eigen::MatrixXd> lu1;  // I - h g0 J
  bool have_J = false, J_fresh = false;
  double h_lu = 0.0;
  void factor(double h, Eigen::Index n) {
    Eigen::MatrixXd K = Eigen::MatrixXd::Identity(3 * n, 3 * n);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) K.block(i * n, j * n, n, n) -= h * Radau5::A[i][j] * J;
    lu3.compute(K);
    lu1.compute(Eigen::MatrixXd::Identity(n, n) - h * radau_g0() * J);
    h_lu = h;
  }
};

// The collocation stages Z (3n) by simplified Newton; false on divergence.
bool radau_newton(Run& r, RadauNewton& nw, double t, double h, const Vec& y, Vec& Z, double& theta_max) {
  const Eigen::Index n = y.size();
  Vec F(3 * n), res(3 * n), dZ(3 * n), yz(n), fz(n);
  NewtonTest test{0.0, theta_max};
  for (int it = 0; it < NewtonTest::kMaxIt; ++it) {
    bool regularized = false;  // as in newton_stage
    for (int i = 0; i < 3; ++i) {
      yz = y + Z.segment(i * n, n);
      if (!newton_f(r, t + Radau5::c[i] * h, yz, fz, regularized)) return false;
      F.segment(i * n, n) = fz;
    }
    for (int i = 0; i < 3; ++i) {
      res.segment(i * n, n) = -Z.segment(i * n, n);
      for (int j = 0; j < 3; ++j) res.segment(i * n, n) += h * Radau5::A[i][j] * F.segment(j * n, n);
    }
    dZ = nw.lu3.solve(res);
    Z += dZ;
    const double nrm = wrms(dZ, Vec::Zero(3 * n), y.replicate(3, 1), r.s.rtol, r.s.atol);
    const NewtonTest::Verdict verdict = test.judge(it, nrm);
    if (verdict != NewtonTest::kContinue)
      return verdict == NewtonTest::kConverged && !regularized && Z.allFinite();
  }
  return false;
}

// y(t0 + s h) from the collocation polynomial through (0, y0), (c_i, y0 + Z_i).
void radau_dense(const Vec& y0, const Vec& Z, double s, Vec& out) {
  const Eigen::Index n = y0.size();
  const double c[4] = {0.0, Radau5::c[0], Radau5::c[1], Radau5::c[2]};
  out = y0;
  for (int i = 1; i < 4; ++i) {
    double l = 1.0;
    for (int j = 0; j < 4; ++j)
      if (j != i) l *= (s - c[j]) / (c[i] - c[j]);
    out += l * Z.segment((i - 1) * n, n);
  }
}

// No RADAU5 tolerance transform (rtol' = 0.1 rtol^(2/3)): with it the
// Prothero-Robinson test ended 60 x its tolerance off (the order-3 estimate
// is honest on stiff components); without, errors stay below the tolerance
// and non-stiff problems pay steps (auto leaves those to dopri5).
void radau5(Run& r, Vec& y) {
  const Eigen::Index n = y.size();
  const double g0 = radau_g0();
  RadauNewton nw;
  Vec f0(n), Z(3 * n), Zlast(3 * n), y1(n), err(n), e2(n), ye(n), ya(n), tmp(n);
  double& t = r.t_now;
  r.f_accepted(t, y, f0);
  double h = r.h_next > 0.0 ? r.h_next : initial_step(r, t, y, f0, 4);
  bool rejected_last = false, first = true, have_last = false;
  double h_last = 0.0;
  while (t < r.t_end) {
    h = r.clip(t, std::min(h, r.h_max()));
    r.check_h(t, h);
    if (!nw.have_J) {
      if (!jacobian(r, t, y, f0, nw.J)) throw Failure(t, "finite-difference Jacobian: " + r.last_rhs_error);
      nw.have_J = nw.J_fresh = true;
      nw.h_lu = 0.0;
    }
    if (nw.h_lu != h) {
      nw.factor(h, n);
      ++r.st.factorizations;
    }
    // Starting stages: the last step's collocation polynomial extrapolated (HW II, IV.8).
    Z.setZero();
    if (have_last) {
      for (int i = 0; i < 3; ++i) {
        radau_dense(ya, Zlast, 1.0 + Radau5::c[i] * h / h_last, tmp);
        Z.segment(i * n, n) = tmp - y;
      }
    }
    double theta_max = 0.0;
    if (!radau_newton(r, nw, t, h, y, Z, theta_max)) {
      ++r.st.rejected;
      ++r.st.newton_failures;
      if (!nw.J_fresh) nw.have_J = false;
      else h *= 0.5;
      rejected_last = true;
      have_last = false;
      continue;
    }
    y1 = y + Z.segment(2 * n, n);
    // Error estimate (RADAU5): err = (I - h g0 J)^-1 h g0 (f0 + sum dd_i Z_i / h).
    tmp = Radau5::dd[0] * Z.segment(0, n) + Radau5::dd[1] * Z.segment(n, n) + Radau5::dd[2] * Z.segment(2 * n, n);
    err = nw.lu1.solve(h * g0 * f0 + g0 * tmp);
    double E = wrms(err, y, y1, r.s.rtol, r.s.atol);
    if (E >= 1.0 && (first || rejected_last)) {  // RADAU5's second filter for stiff components
      e2 = y + err;
      if (r.f(t, e2, ye) == 0) {
        err = nw.lu1.solve(h * g0 * ye + g0 * tmp);
        E = wrms(err, y, y1, r.s.rtol, r.s.atol);
      }
    }
    const double fac = std::clamp(0.9 * std::pow(std::max(E, 1e-10), -0.25), 0.2, rejected_last ? 1.0 : 5.0);
    if (E > 1.0) {
      ++r.st.rejected;
      h *= std::min(fac, 0.9);
      rejected_last = true;
      continue;
    }
    r.note_error(err);
    const double ta = t, h_step = h;
    t = (h == r.t_end - t) ? r.t_end : t + h;
    ++r.st.steps;
    ya = y;
    Zlast = Z;
    y = y1;
    r.accept(t, y);
    r.output(t, y, [&](double tt, Vec& out) { radau_dense(ya, Zlast, (tt - ta) / h_step, out); });
    // The extrapolation starts from the unprojected polynomial: shift it onto
    // the projected y (a projection moves y by about the tolerance).
    Zlast.segment(2 * n, n) = y - ya;
    have_last = true;
    h_last = h_step;
    r.f_accepted(t, y, f0);
    first = false;
    nw.J_fresh = false;
    if (theta_max > 0.5) nw.have_J = false;
    if (fac < 1.0 || fac > 1.2) h *= fac;
    rejected_last = false;
  }
}

// ---- Classical Runge-Kutta, fixed step ----------------------------------------
// rk4's error estimate, free: with k5 = f(t + h, y1) (needed anyway for the next step and
// the dense output), the weights (1/6, 1/3, 1/3, 0, 1/6) on (k1, k2, k3, k4, k5) are an
// embedded formula of order 3 (its conditions: sum b = 1, sum b c = 1/2, sum b c^2 = 1/3,
// sum b a c = 1/6 hold with c5 = 1, a5j = b_j).  Their difference from RK4's y1 is
// h / 6 (k4 - k5): an estimate of the order-3 formula's local error, so an upper estimate of
// RK4's.  It also catches a step whose last stage differs from the state it led to, as when
// a stage near a singular configuration got an acceleration of the motion on another branch
// (docs/simulation.md, "Fixed steps: err_est").  f(y1) is at the stabilized y1: the
// projection's move is in it too.
void rk4_estimate(Run& r, double h, const Vec& k4, const Vec& k5) {
  const double e = h / 6 * (k4 - k5).cwiseAbs().maxCoeff();
  r.st.err_est += e;
  r.st.err_step_max = std::max(r.st.err_step_max, e);
}

void rk4(Run& r, Vec& y) {
  if (!(r.s.dt > 0.0)) throw Failure(r.t0, "rk4 needs a step: give --dt (Settings::dt)");
  const Eigen::Index n = y.size();
  Vec k1(n), k2(n), k3(n), k4(n), yt(n), ya(n);
  double& t = r.t_now;
  r.f_accepted(t, y, k1);
  while (t < r.t_end) {
    const double h = r.clip(t, r.s.dt);
    r.check_h(t, h);
    yt = y + 0.5 * h * k1;
    if (r.f(t + 0.5 * h, yt, k2) != 0) throw Failure(t, r.last_rhs_error);
    yt = y + 0.5 * h * k2;
    if (r.f(t + 0.5 * h, yt, k3) != 0) throw Failure(t, r.last_rhs_error);
    yt = y + h * k3;
    if (r.f(t + h, yt, k4) != 0) throw Failure(t, r.last_rhs_error);
    ya = y;
    const Vec fa = k1;
    y += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
    const double ta = t;
    t = (h == r.t_end - t) ? r.t_end : t + h;
    ++r.st.steps;
    r.accept(t, y);
    r.f_accepted(t, y, k1);
    rk4_estimate(r, h, k4, k1);
    r.output(t, y, [&](double tt, Vec& out) { hermite(ta, t, ya, fa, y, k1, tt, out); });
  }
}

}  // namespace

// What to do about a failed solve of status 3 in a simulation (the solvers'
// messages of status 1 and 2 name their fixes themselves; docs/status.md).
static std::string status_hint(int status) {
  return status == 3 ? "; a NaN or infinity in the state: check --q0 and --v0, or tighten --rtol/--atol (--dt for rk4)"
                     : "";
}

Failure::Failure(double time, const std::string& what) : std::runtime_error(fmt_time(time) + ": " + what), t(time) {}

const std::vector<std::string>& method_names() {
  static const std::vector<std::string> names = {"auto", "sdirk4", "radau5", "dopri5", "rk4"};
  return names;
}

Stats integrate(const OdeProblem& problem, double t0, double t_end, std::vector<double>& y, const Settings& settings,
                const Observer& observe) {
  if (static_cast<int>(y.size()) != problem.n) throw Failure(t0, "state of the wrong size");
  if (!(t_end > t0)) throw Failure(t0, "t_end must be greater than t0");
  Run r{problem, settings, observe, t0, t_end, {}, {}, t0 + settings.every, 1, t0, 0.0};
  Vec yv = Eigen::Map<const Vec>(y.data(), problem.n);
  if (observe) observe(t0, yv.data());
  if (settings.method == "auto") {
    dopri5(r, yv, true);
    if (r.t_now < t_end) radau5(r, yv);  // stiff from here on
  } else if (settings.method == "dopri5") {
    dopri5(r, yv, false);
  } else if (settings.method == "sdirk4") {
    sdirk4(r, yv);
  } else if (settings.method == "radau5") {
    radau5(r, yv);
  } else if (settings.method == "rk4") {
    rk4(r, yv);
  } else {
    throw Failure(t0, "unknown integrator '" + settings.method + "' (use auto, sdirk4, radau5, dopri5 or rk4)");
  }
  Stats st = r.st;
  st.t = r.t_now;
  Eigen::Map<Vec>(y.data(), problem.n) = yv;
  return st;
}

// ---- Mechanisms ----------------------------------------------------------------

namespace {

// Buffers of one Mechanism evaluation (a Mechanism is used by one thread at a time).
struct Work {
  std::vector<double> M, Phiq, phi, gamma, h, tau, qdd, lambda, zero_nv, dv;
  // MechanismSettings::singular_damping's counters of the current Mechanism::run.
  long near_singular = 0, singular_checks = 0;
  std::string near_singular_note;
  // The Mechanism whose last dense check found W within kNearExit tau of a rank loss: its
  // calls run the dense check until one finds W farther (the screen's hysteresis).
  const void* near_mode = nullptr;
};
thread_local Work g_work;

Work& work(const System& s) {
  Work& w = g_work;
  w.M.resize(static_cast<std::size_t>(s.nv) * s.nv);
  w.Phiq.resize(static_cast<std::size_t>(s.nc) * s.nv);
  w.phi.resize(s.nc);
  w.gamma.resize(s.nc);
  w.lambda.resize(std::max(s.nc, 1));
  w.h.resize(s.nv);
  w.tau.resize(s.nv);
  w.qdd.resize(s.nv);
  w.dv.resize(s.nv);
  w.zero_nv.assign(s.nv, 0.0);
  return w;
}

double max_abs(const std::vector<double>& x) {
  double m = 0.0;
  for (double e : x) m = std::max(m, std::abs(e));
  return m;
}

// p (x) (0, w) for the quaternion p = (w, x, y, z) and angular velocity w.
void quat_times_pure(const double* p, const double* w, double* out) {
  out[0] = -p[1] * w[0] - p[2] * w[1] - p[3] * w[2];
  out[1] = p[0] * w[0] + p[2] * w[2] - p[3] * w[1];
  out[2] = p[0] * w[1] + p[3] * w[0] - p[1] * w[2];
  out[3] = p[0] * w[2] + p[1] * w[1] - p[2] * w[0];
}

}  // namespace

Mechanism::Mechanism(const System& system, MechanismSettings settings) : sys_(system), set_(settings) {
  // Joints whose q has one more entry than v hold a quaternion (docs/interface.md
  // section 3): ball (4, 3) at its first entry, floating (7, 6) after x.
  for (int j = 0; j < sys_.njoints; ++j) {
    const int q0 = sys_.joint_q_index[j], v0 = sys_.joint_v_index[j];
    const int nqj = (j + 1 < sys_.njoints ? sys_.joint_q_index[j + 1] : sys_.nq) - q0;
    const int nvj = (j + 1 < sys_.njoints ? sys_.joint_v_index[j + 1] : sys_.nv) - v0;
    if (nqj == nvj + 1 && nvj == 3) {
      quat_.push_back(q0);
      quat_v_.push_back(v0);
    } else if (nqj == nvj + 1 && nvj == 6) {
      lin_.push_back(q0);
      lin_v_.push_back(v0);
      quat_.push_back(q0 + 3);
      quat_v_.push_back(v0 + 3);
    }
  }
}

void Mechanism::fail(double t, const char* what, int status) const {
  throw Failure(t, std::string(what) + ": solver status " + std::to_string(status) + ": " + sys_.last_error() +
                       status_hint(status));
}

void Mechanism::qdot(const double* q, const double* v, double* qd) const {
  // One-coordinate and planar joints: qdot = v, index by index.  The joint
  // tables are in user order, q and v run in step.
  int iq = 0, iv = 0;
  std::size_t kq = 0, kl = 0;
  while (iq < sys_.nq) {
    if (kl < lin_.size() && iq == lin_[kl]) {  // floating: x' = linear velocity
      for (int k = 0; k < 3; ++k) qd[iq + k] = v[iv + k];
      iq += 3;
      iv += 3;
      ++kl;
    } else if (kq < quat_.size() && iq == quat_[kq]) {  // quat' = 1/2 quat (x) (0, omega)
      quat_times_pure(q + iq, v + iv, qd + iq);
      for (int k = 0; k < 4; ++k) qd[iq + k] *= 0.5;
      iq += 4;
      iv += 3;
      ++kq;
    } else {
      qd[iq++] = v[iv++];
    }
  }
}

void Mechanism::retract(double* q, const double* dv) const {
  // q <- q (+) dv: additive except quaternions, rotated by exp(omega / 2).
  int iq = 0, iv = 0;
  std::size_t kq = 0, kl = 0;
  while (iq < sys_.nq) {
    if (kl < lin_.size() && iq == lin_[kl]) {
      for (int k = 0; k < 3; ++k) q[iq + k] += dv[iv + k];
      iq += 3;
      iv += 3;
      ++kl;
    } else if (kq < quat_.size() && iq == quat_[kq]) {
      const double* w = dv + iv;
      const double a = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
      const double sc = a > 1e-8 ? std::sin(0.5 * a) / a : 0.5 - a * a / 48.0;
      const double e[4] = {std::cos(0.5 * a), sc * w[0], sc * w[1], sc * w[2]};
      const double* p = q + iq;
      const double r[4] = {p[0] * e[0] - p[1] * e[1] - p[2] * e[2] - p[3] * e[3],
                           p[0] * e[1] + p[1] * e[0] + p[2] * e[3] - p[3] * e[2],
                           p[0] * e[2] + p[2] * e[0] + p[3] * e[1] - p[1] * e[3],
                           p[0] * e[3] + p[3] * e[0] + p[1] * e[2] - p[2] * e[1]};
      for (int k = 0; k < 4; ++k) q[iq + k] = r[k];
      iq += 4;
      iv += 3;
      ++kq;
    } else {
      q[iq++] += dv[iv++];
    }
  }
  normalize_quaternions(q);
}

void Mechanism::normalize_quaternions(double* q) const {
  for (int i : quat_) {
    const double n = std::sqrt(q[i] * q[i] + q[i + 1] * q[i + 1] + q[i + 2] * q[i + 2] + q[i + 3] * q[i + 3]);
    if (n > 0.0 && std::isfinite(n))
      for (int k = 0; k < 4; ++k) q[i + k] /= n;
  }
}

int Mechanism::rhs(double t, const double* y, double* dydt, std::string& error) const {
  const double* q = y;
  const double* v = y + sys_.nq;
  Work& w = work(sys_);
  qdot(q, v, dydt);
  if (tau_) tau_(t, q, v, w.tau.data());
  else std::fill(w.tau.begin(), w.tau.end(), 0.0);
  int status;
  if (set_.stabilization == Stabilization::kBaumgarte && sys_.nc > 0) {
    // Phiq qdd = gamma - 2 alpha Phiq v - beta^2 Phi (Baumgarte 1972).
    sys_.mass_matrix(q, w.M.data());
    sys_.bias_forces(q, v, w.h.data());
    sys_.constraints(q, w.phi.data());
    sys_.constraint_jacobian(q, w.Phiq.data());
    sys_.constraint_gamma(q, v, w.gamma.data());
    for (int i = 0; i < sys_.nv; ++i) w.h[i] = w.tau[i] - w.h[i];
    for (int r = 0; r < sys_.nc; ++r) {
      double pv = 0.0;
      for (int c = 0; c < sys_.nv; ++c) pv += w.Phiq[r + static_cast<std::size_t>(c) * sys_.nc] * v[c];
      w.gamma[r] -= 2.0 * set_.alpha * pv + set_.beta * set_.beta * w.phi[r];
    }
    status = sys_.solve_augmented(w.M.data(), w.h.data(), w.Phiq.data(), w.gamma.data(), dydt + sys_.nq,
                                  w.lambda.data());
  } else {
    status = sys_.forward_dynamics(q, v, w.tau.data(), dydt + sys_.nq, w.lambda.data());
    // MechanismSettings::singular_damping: the screen (free: the solve's status and flag,
    // and whether the last dense check found W within kNearExit tau of a rank loss), then
    // the dense check, which damps only near a rank loss (else the answer stands).
    if (set_.singular_damping > 0.0 && sys_.nc > 0 && (status == 0 || status == 2) && damping_screen(status)) {
      ++w.singular_checks;
      if (damped_solve(q, v, nullptr, false, dydt + sys_.nq)) {
        note_damped(t, q);
        return 0;
      }
    }
  }
  // A regularized answer (--singular proximal): status 0 at a state singular to working
  // precision, or status 2 with the answer written near, not at, it (without its digits,
  // docs/singular.md).  Either is kRhsRegularized: a stage with one rejects the step.
  if ((status == 0 || status == 2) && sys_.last_solve_regularized && sys_.last_solve_regularized()) {
    error = "forward dynamics regularized (--singular proximal: constraint rows dependent to working precision, "
            "docs/singular.md) at " + singular_rows(q);
    if (status != 0) error += std::string("; ") + sys_.last_error();
    return kRhsRegularized;
  }
  if (status != 0)
    error = "forward dynamics status " + std::to_string(status) + ": " + sys_.last_error() + status_hint(status);
  return status;
}

std::string Mechanism::singular_rows(const double* q) const {
  // The row of the smallest pivot of a pivoted LDL^T of T^T T = Phiq M^-1 Phiq^T
  // (the matrix whose digit test failed, docs/singular.md), and the joints it
  // couples: the loop.  Only on the regularized path.
  const int nv = sys_.nv, nc = sys_.nc;
  Eigen::MatrixXd M(nv, nv), Phiq(nc, nv);
  sys_.mass_matrix(q, M.data());
  sys_.constraint_jacobian(q, Phiq.data());
  const Eigen::MatrixXd W = Phiq * M.llt().solve(Phiq.transpose());
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(W);
  const Eigen::VectorXd d = ldlt.vectorD().cwiseAbs();
  Eigen::Index k = 0;
  d.minCoeff(&k);
  Eigen::VectorXi perm = Eigen::VectorXi::LinSpaced(nc, 0, nc - 1);
  perm = ldlt.transpositionsP() * perm;  // perm[k]: the row of pivot k
  const int row = perm[k];
  std::string joints;
  for (int j = 0; j < sys_.njoints; ++j) {
    const int v1 = j + 1 < sys_.njoints ? sys_.joint_v_index[j + 1] : nv;
    bool in_row = false;
    for (int c = sys_.joint_v_index[j]; c < v1; ++c) in_row |= Phiq(row, c) != 0.0;
    if (in_row) joints += std::string(joints.empty() ? "" : ", ") + "'" + sys_.joint_names[j] + "'";
  }
  return "constraint row " + std::to_string(row) + " (the loop through joints " + joints + "), pivot " +
         fmt_g(d[k] / std::max(d.maxCoeff(), 1e-300)) + " of the largest";
}

// A projection's solve near, not at, a singular configuration (--singular proximal): status 2
// with the regularized correction written (docs/singular.md), which relaxes the vanishing
// direction; the correction is used, as the minimum-norm one is at the singular state.
bool Mechanism::regularized_answer(int status) const {
  return status == 2 && sys_.last_solve_regularized && sys_.last_solve_regularized();
}

// MechanismSettings::singular_damping (docs/simulation.md, "A02 in time").  Near a
// configuration where the rows of Phiq lose rank, the exact acceleration of a state a
// rounding error off the branch is that of the neighbouring branch (the constraint force
// along the vanishing direction is divided by W's vanishing eigenvalue s); damping the
// components with s below tau s_max (Tikhonov) keeps that force out.  The damped force is
// M-orthogonal to null(Phiq), so the acceleration along the admissible motion is unchanged.
// With r: the projection's correction dv = -M^-1 Phiq^T W_damped^+ r.  Without: the
// acceleration M^-1 (tau - h) - M^-1 Phiq^T W_damped^+ (Phiq M^-1 (tau - h) - gamma),
// Returns whether W's smallest eigenvalue is below 1e3 tau s_max (near a rank loss); dv is
// written then, or always with `always`.
bool Mechanism::damped_solve(const double* q, const double* v, const double* r, bool always, double* dv) const {
  const int nv = sys_.nv, nc = sys_.nc;
  Work& w = work(sys_);
  sys_.mass_matrix(q, w.M.data());
  sys_.constraint_jacobian(q, w.Phiq.data());
  const Eigen::Map<const Eigen::MatrixXd> M(w.M.data(), nv, nv), Phiq(w.Phiq.data(), nc, nv);
  const Eigen::LLT<Eigen::MatrixXd> llt(M);
  const Eigen::MatrixXd Y = llt.solve(Phiq.transpose());
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(Phiq * Y);
  const Eigen::VectorXd& s = es.eigenvalues();
  const double tau = set_.singular_damping * s[nc - 1];
  const bool near = s[0] < 1e3 * tau;
  w.near_mode = s[0] < kNearExit * tau ? this : nullptr;  // the screen's hysteresis
  if (!always && !near) return false;
  Eigen::VectorXd z(nc), a0 = Eigen::VectorXd::Zero(nv);
  if (r) {
    z = Eigen::Map<const Eigen::VectorXd>(r, nc);
  } else {
    sys_.bias_forces(q, v, w.h.data());
    sys_.constraint_gamma(q, v, w.gamma.data());
    for (int i = 0; i < nv; ++i) w.h[i] = w.tau[i] - w.h[i];
    a0 = llt.solve(Eigen::Map<const Eigen::VectorXd>(w.h.data(), nv));
    z = Phiq * a0 - Eigen::Map<const Eigen::VectorXd>(w.gamma.data(), nc);
  }
  Eigen::VectorXd uz = es.eigenvectors().transpose() * z;
  for (int i = 0; i < nc; ++i) uz[i] *= s[i] / (s[i] * s[i] + tau * tau);
  const Eigen::VectorXd x = a0 - Y * (es.eigenvectors() * uz);
  for (int i = 0; i < nv; ++i) dv[i] = x[i];
  return near;
}

bool Mechanism::damping_screen(int status) const {
  return status == 2 || (sys_.last_solve_regularized && sys_.last_solve_regularized()) ||
         work(sys_).near_mode == this;
}

// The projection's free estimate of W's smallest eigenvalue: its solve gave lambda = W^-1 r
// (r = Phi or Phiq v, a rounding-size residual with components along every eigenvector),
// one step of inverse iteration, so r^T lambda / lambda^T lambda >= s_min, close to it
// when s_min is far below the others.  W's largest eigenvalue is at least W_ii >=
// Phiq_ij^2 / M_jj.  True when the ratio of the two is below kNearEnter (it is never below
// s_min / s_max: far from a rank loss it cannot fire).
bool Mechanism::rayleigh_small(const double* r) const {
  const int nv = sys_.nv, nc = sys_.nc;
  Work& w = work(sys_);
  double rl = 0.0, ll = 0.0;
  for (int i = 0; i < nc; ++i) {
    rl += r[i] * w.lambda[i];
    ll += w.lambda[i] * w.lambda[i];
  }
  if (!(ll > 0.0) || !(rl > 0.0)) return false;
  double smax = 0.0;
  for (int c = 0; c < nv; ++c) {
    const double m = w.M[c + static_cast<std::size_t>(c) * nv];
    if (!(m > 0.0)) continue;
    for (int i = 0; i < nc; ++i) {
      const double a = w.Phiq[i + static_cast<std::size_t>(c) * nc];
      smax = std::max(smax, a * a / m);
    }
  }
  return rl / ll < kNearEnter * smax;
}

void Mechanism::note_damped(double t, const double* q) const {
  Work& w = work(sys_);
  if (w.near_singular++ == 0) w.near_singular_note = fmt_time(t) + ": " + singular_rows(q);
}

// A projection's correction: the generated solve, screened (status 2, a regularized answer,
// the hysteresis of rhs, or rayleigh_small); where the screen fires, the damped correction
// (counted in near_singular only near a rank loss, 1e3 tau).
// false: the generated solve failed (status in `status`) and no damped answer was taken.
bool Mechanism::projection_solve(double t, const double* q, const double* r, int& status) const {
  Work& w = work(sys_);
  status = sys_.solve_augmented(w.M.data(), w.zero_nv.data(), w.Phiq.data(), w.gamma.data(), w.dv.data(),
                                w.lambda.data());
  if (set_.singular_damping > 0.0 && (status == 0 || status == 2)) {
    if (damping_screen(status) || rayleigh_small(r)) {
      ++w.singular_checks;
      std::vector<double> rr(r, r + sys_.nc);  // r may be w.phi, which damped_solve keeps
      if (damped_solve(q, nullptr, rr.data(), true, w.dv.data())) note_damped(t, q);
      return true;
    }
  }
  return status == 0 || regularized_answer(status);
}

void Mechanism::project_positions(double t, double* q) const {
  // Newton on Phi(q) = 0 with the minimum-norm correction in the mass metric:
  // solve_augmented(M, 0, Phiq, -Phi) gives dq = -M^-1 Phiq^T (Phiq M^-1 Phiq^T)^-1 Phi
  // (the Step 3 normal matrix T^T T = Phiq M^-1 Phiq^T).  M is kept from the
  // first iterate (simplified Newton), Phiq is re-evaluated.
  Work& w = work(sys_);
  sys_.constraints(q, w.phi.data());
  double r = max_abs(w.phi);
  if (r <= 0.01 * set_.phi_tol) return;
  sys_.mass_matrix(q, w.M.data());
  static constexpr int kMaxIt = 30;
  for (int it = 0; it < kMaxIt; ++it) {
    sys_.constraint_jacobian(q, w.Phiq.data());
    for (int i = 0; i < sys_.nc; ++i) w.gamma[i] = -w.phi[i];
    int status = 0;
    if (!projection_solve(t, q, w.phi.data(), status)) fail(t, "projection onto Phi(q) = 0", status);
    retract(q, w.dv.data());
    sys_.constraints(q, w.phi.data());
    const double r_new = max_abs(w.phi);
    // Newton converges quadratically: stop well below phi_tol, or at the
    // rounding floor (no halving any more) once below phi_tol.
    if (r_new <= 0.01 * set_.phi_tol || (r_new > 0.5 * r && r_new <= set_.phi_tol)) return;
    r = r_new;
  }
  int row = 0;
  for (int i = 0; i < sys_.nc; ++i)
    if (std::abs(w.phi[i]) > std::abs(w.phi[row])) row = i;
  throw Failure(t, "projection onto Phi(q) = 0 did not converge in " + std::to_string(kMaxIt) +
                       " Newton steps: max |Phi| = " + fmt_g(r) + " at constraint row " + std::to_string(row) +
                       " (a configuration far from closing the loops, or a singular one); start from a --q0 "
                       "nearer an assembled configuration");
}

void Mechanism::project_velocities(double t, const double* q, double* v) const {
  // dv = -M^-1 Phiq^T (Phiq M^-1 Phiq^T)^-1 Phiq v: exact in one solve.
  Work& w = work(sys_);
  sys_.mass_matrix(q, w.M.data());
  sys_.constraint_jacobian(q, w.Phiq.data());
  for (int r = 0; r < sys_.nc; ++r) {
    double pv = 0.0;
    for (int c = 0; c < sys_.nv; ++c) pv += w.Phiq[r + static_cast<std::size_t>(c) * sys_.nc] * v[c];
    w.gamma[r] = -pv;
  }
  for (int r = 0; r < sys_.nc; ++r) w.phi[r] = -w.gamma[r];  // Phiq v
  int status = 0;
  if (!projection_solve(t, q, w.phi.data(), status)) fail(t, "projection onto Phiq v = 0", status);
  for (int i = 0; i < sys_.nv; ++i) v[i] += w.dv[i];
}

void Mechanism::stabilize(double t, double* y) const {
  normalize_quaternions(y);
  if (sys_.nc == 0 || set_.stabilization != Stabilization::kProjection) return;
  project_positions(t, y);
  project_velocities(t, y, y + sys_.nq);
}

std::vector<double> Mechanism::initial_state(const double* q0, const double* v0, bool* assembled) const {
  std::vector<double> y(size(), 0.0);
  std::copy(q0, q0 + sys_.nq, y.begin());
  if (v0) std::copy(v0, v0 + sys_.nv, y.begin() + sys_.nq);
  normalize_quaternions(y.data());
  if (assembled) *assembled = phi_norm(y.data()) > set_.phi_tol;
  if (sys_.nc > 0) {
    project_positions(0.0, y.data());
    project_velocities(0.0, y.data(), y.data() + sys_.nq);
  }
  return y;
}

OdeProblem Mechanism::problem() const {
  OdeProblem p;
  p.n = size();
  p.rhs = [this](double t, const double* y, double* dydt, std::string& error) { return rhs(t, y, dydt, error); };
  p.after_step = [this](double t, double* y) { stabilize(t, y); };
  return p;
}

Stats Mechanism::run(double t0, double t_end, std::vector<double>& y, const Settings& settings,
                     const Observer& observe) const {
  Work& w = work(sys_);
  w.near_singular = w.singular_checks = 0;
  w.near_singular_note.clear();
  w.near_mode = nullptr;
  Stats st = integrate(problem(), t0, t_end, y, settings, observe);
  st.near_singular = w.near_singular;
  st.singular_checks = w.singular_checks;
  st.near_singular_note = w.near_singular_note;
  return st;
}

double Mechanism::energy(const double* y) const {
  Work& w = work(sys_);
  const double* v = y + sys_.nq;
  sys_.mass_matrix(y, w.M.data());
  double T = 0.0;
  for (int c = 0; c < sys_.nv; ++c)
    for (int r = 0; r < sys_.nv; ++r) T += v[r] * w.M[r + static_cast<std::size_t>(c) * sys_.nv] * v[c];
  const double V = sys_.potential_energy ? sys_.potential_energy(y) : std::numeric_limits<double>::quiet_NaN();
  return 0.5 * T + V;
}

double Mechanism::phi_norm(const double* y) const {
  if (sys_.nc == 0) return 0.0;
  Work& w = work(sys_);
  sys_.constraints(y, w.phi.data());
  return max_abs(w.phi);
}

double Mechanism::phiqv_norm(const double* y) const {
  if (sys_.nc == 0) return 0.0;
  Work& w = work(sys_);
  sys_.constraint_jacobian(y, w.Phiq.data());
  double m = 0.0;
  for (int r = 0; r < sys_.nc; ++r) {
    double pv = 0.0;
    for (int c = 0; c < sys_.nv; ++c) pv += w.Phiq[r + static_cast<std::size_t>(c) * sys_.nc] * y[sys_.nq + c];
    m = std::max(m, std::abs(pv));
  }
  return m;
}

}  // namespace jrgen::sim
