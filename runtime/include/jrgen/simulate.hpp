// Time integration of mechanisms solved by a jrgen-generated solver
// (docs/simulation.md; docs/interface.md sections 3 and 7).
//
// Two layers:
//
//  * OdeProblem + integrate(): y' = f(t, y) with error-controlled methods,
//    usable on any ODE (the tests run them on ODEs with known solutions):
//      "auto"    (default) dopri5 with Hairer's stiffness detection (h |lambda|
//                above dopri5's stability boundary 3.25 on 15 accepted steps,
//                HNW I, II.10); from then on radau5.  One way: a problem that
//                stops being stiff stays with radau5.
//      "dopri5"  Dormand-Prince 5(4), explicit, FSAL, dense output of order 4
//                (Hairer, Norsett & Wanner I, II.4-II.6);
//      "radau5"  Radau IIA of order 5 (HW II, IV.5), simplified Newton on
//                (I - h A (x) J) as one real LU of size 3n, J by finite
//                differences of f, reused across steps while Newton
//                converges; RADAU5's error estimate (HW II, IV.8 (8.19));
//                dense output by the collocation polynomial;
//      "sdirk4"  the L-stable SDIRK of order 4 with embedded order 3,
//                gamma = 1/4 (HW II, IV.6, Table 6.5), simplified Newton on
//                (I - h gamma J) (size n), the same Jacobian reuse; error
//                estimate filtered by (I - h gamma J)^-1 (HW II, IV.8 (8.20));
//                dense output by cubic Hermite interpolation;
//      "rk4"     classical Runge-Kutta with the fixed step dt (no error control;
//                its error is estimated: Stats::err_est).
//    The default copes with stiff problems.
//
//  * System + Mechanism: the state y = (q, v) of a generated solver,
//    f(y) = (qdot(q, v), qdd(q, v)) with qdd from forward_dynamics, and
//    constraint stabilization after every step:
//      Stabilization::kProjection (default): q projected onto Phi(q) = 0 and v
//        onto Phiq v = 0 in the mass metric, with the generated solve_augmented;
//      Stabilization::kBaumgarte: qdd from Phiq qdd = gamma - 2 alpha Phiq v
//        - beta^2 Phi instead (for comparison; Phi drifts by O(tolerance));
//      Stabilization::kNone.
//
// Usage with a solver generated in namespace `fourbar`:
//
//   #include "fourbar_dyn.hpp"
//   #include <jrgen/simulate.hpp>
//   jrgen::sim::Mechanism mech(JRGEN_SIM_SYSTEM(fourbar));
//   std::vector<double> y = mech.initial_state(fourbar::q_assembled, nullptr);  // assembled, projected
//   jrgen::sim::Settings s;  s.rtol = 1e-8;  s.atol = 1e-10;
//   jrgen::sim::Stats st = mech.run(0.0, 2.0, y, s, [&](double t, const double* y) { ... });
//
// Joint forces: Mechanism::set_forces(tau(t, q, v)) (default zero).  The
// evaluation buffers are thread_local: runs on separate states may share a
// const Mechanism across threads.
//
// Failures throw jrgen::sim::Failure, whose what() is one line naming the
// time and, when the generated solver failed, its last_error() (the joint or
// loop): step size underflow (Newton divergence included), a non-zero solver
// status, a projection that does not converge.  Never a silent blow-up: a
// non-finite state is a solver status 3.
//
// Solvers generated with --singular proximal (docs/singular.md) answer at a
// singular configuration with a regularized solve (status 0,
// last_solve_regularized()), and near, not at, it with the regularized answer
// written but status 2 (it lacks its digits there); both are regularized
// answers here.  The Mechanism sees that flag (System::
// last_solve_regularized, filled by JRGEN_SIM_SYSTEM when the namespace has
// it): a stage of a step that got a regularized answer rejects the step like
// a failed solve (the regularized acceleration is not the limit along the
// motion: it relaxes the vanishing constraint direction), so a run that
// cannot step over the singular band ends in a named step size underflow;
// a regularized answer at an accepted state (a run started or landing on the
// singular configuration) is used, counted in Stats::regularized_used and
// described in Stats::regularized_note (time, constraint row and joints).
// With MechanismSettings::singular_damping (default 1e-10), a status 2 or a
// regularized answer near a rank loss of the constraint rows is replaced by
// the damped solve's (status 0, counted in Stats::near_singular) before any
// of this: the regularized path above is what remains with the damping off.
#pragma once

#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace jrgen::sim {

/// A failure of the integration, what() = one line with the time.
class Failure : public std::runtime_error {
 public:
  Failure(double t, const std::string& what);
  double t;
};

// ---------------------------------------------------------------------------
// ODE layer

/// OdeProblem::rhs may return this (not an error): dydt is valid but came
/// from a regularized solve at a singular configuration (docs/singular.md),
/// with `error` describing it.  A stage of a step rejects the step; at an
/// accepted state the value is used and counted (Stats::regularized_used).
inline constexpr int kRhsRegularized = -1;

struct OdeProblem {
  int n = 0;
  /// dydt = f(t, y).  Returns 0, or non-zero with `error` set (one line):
  /// the step is then rejected and retried with h / 4 (a state outside the
  /// solver's domain reached by too long a step), and a failure at the
  /// accepted state itself ends the run.
  std::function<int(double t, const double* y, double* dydt, std::string& error)> rhs;
  /// Called on every accepted y (projection, quaternion normalization); may
  /// change y and may throw Failure.  Optional.
  std::function<void(double t, double* y)> after_step;
};

struct Settings {
  std::string method = "auto";  ///< "auto" (default), "radau5", "sdirk4", "dopri5", "rk4"
  double rtol = 1e-6, atol = 1e-8;
  double dt = 0.0;       ///< rk4: the step (required); others: the first step (0: chosen, HNW II.4)
  double h_max = 0.0;    ///< largest step (0: t_end - t0)
  double every = 0.0;    ///< output every `every` (dense output; 0: every accepted step)
  long max_steps = 10000000;
};

struct Stats {
  long steps = 0;        ///< accepted steps
  long rejected = 0;     ///< rejected steps (error test or Newton failure)
  long f_calls = 0;      ///< evaluations of f, Jacobian columns included
  long jacobians = 0;    ///< finite-difference Jacobians (radau5, sdirk4)
  long factorizations = 0;  ///< LU factorizations of the Newton matrix (radau5, sdirk4)
  long newton_failures = 0; ///< steps retried because Newton did not converge
  long switches = 0;     ///< auto: 1 once it switched from dopri5 to radau5
  long regularized = 0;  ///< f calls answered by a regularized solve (kRhsRegularized), used or not
  long regularized_used = 0;  ///< of these, at accepted states: their answers are in the result
  std::string regularized_note;  ///< the first used one: "at t = ...: " and rhs's description
  /// Mechanism::run with MechanismSettings::singular_damping: f calls and projection solves
  /// answered by the damped solve near a rank loss of the constraint rows, and the dense
  /// checks (eigendecompositions of W) the screen ran, damped or not.  Zero away from any
  /// rank loss.
  long near_singular = 0;
  long singular_checks = 0;
  std::string near_singular_note;  ///< the first damped answer: "at t = ...: " and the rows
  /// The sum over accepted steps of each step's local error estimate (max norm, the state's
  /// units): a first-order estimate of how far off the result may be, without the growth or
  /// decay of errors along the motion (docs/simulation.md, "Fixed steps: err_est").  rk4:
  /// h / 6 |k4 - f(y1)|, its embedded order-3 formula (no extra f call); the other methods:
  /// the estimate their step-size control used.
  double err_est = 0.0;
  double err_step_max = 0.0;  ///< the largest of those estimates
  double t = 0.0;        ///< time reached
};

/// Observer: called at t0, at every output time (every accepted step, or
/// every `every` by dense output) and at t_end, with the state there.
using Observer = std::function<void(double t, const double* y)>;

/// Integrates y from t0 to t_end in place; y holds the state at t_end.
/// Throws Failure (step size underflow, f failing at an accepted state,
/// unknown method, too many steps).
Stats integrate(const OdeProblem& problem, double t0, double t_end, std::vector<double>& y,
                const Settings& settings, const Observer& observe = nullptr);

/// The documented method names.
const std::vector<std::string>& method_names();

// ---------------------------------------------------------------------------
// Mechanism layer

/// A generated solver's API (docs/interface.md section 4) as function pointers.
/// JRGEN_SIM_SYSTEM(ns) fills it from namespace ns.
struct System {
  int nq, nv, nc, njoints;
  const char* const* joint_names;
  const int* joint_q_index;
  const int* joint_v_index;
  int (*forward_dynamics)(const double* q, const double* v, const double* tau, double* qdd, double* lambda);
  int (*solve_augmented)(const double* M, const double* Q, const double* Phiq, const double* gamma, double* qdd,
                         double* lambda);
  void (*mass_matrix)(const double* q, double* M);
  void (*bias_forces)(const double* q, const double* v, double* h);
  void (*constraints)(const double* q, double* phi);
  void (*constraint_jacobian)(const double* q, double* Phiq);
  void (*constraint_gamma)(const double* q, const double* v, double* gamma);
  /// Gravity + spring potential (docs/interface.md section 2b); nullptr: the
  /// energy is NaN.
  double (*potential_energy)(const double* q);
  const char* (*last_error)();
  /// --singular proximal solvers: true after a regularized solve
  /// (docs/singular.md); nullptr for solvers without the option.
  bool (*last_solve_regularized)();
};

namespace detail {
template <class T>
struct TypeTag {
  using type = T;
};
}  // namespace detail

enum class Stabilization { kProjection, kBaumgarte, kNone };

struct MechanismSettings {
  Stabilization stabilization = Stabilization::kProjection;
  double alpha = 10.0, beta = 10.0;  ///< Baumgarte: Phi'' + 2 alpha Phi' + beta^2 Phi = 0
  /// Projection: q is projected when max |Phi| > phi_tol / 100; Newton
  /// iterations on Phi(q) = 0 run while they reduce
  /// max |Phi| (at least by half) and it is above phi_tol / 100; ending
  /// above phi_tol (absolute, the model's length unit: raise it for a model
  /// measured in millimetres) or after 30 iterations is a Failure.
  double phi_tol = 1e-12;
  /// Crossing a configuration where the constraint rows lose rank (a parallelogram's flat
  /// configuration; docs/simulation.md, "A02 in time").  tau > 0 (default 1e-10, for
  /// mechanisms with constraints): where the generated solve says the rows are near a rank
  /// loss, the accelerations and the projections' corrections come from a dense solve that
  /// damps the eigencomponents of W = Phiq M^-1 Phiq^T below tau times its largest
  /// eigenvalue (Tikhonov: 1 / s becomes s / (s^2 + (tau s_max)^2)).  The dense solve
  /// (an eigendecomposition of W) runs only when a screen fires: the generated solve
  /// returned status 2 or a regularized answer; or a projection's solve (lambda = W^-1 r, one
  /// step of inverse iteration) gives a Rayleigh quotient below kNearEnter times a bound of
  /// W's largest eigenvalue; or the last dense check found W within kNearExit tau of a rank
  /// loss.  There the accelerations are damped only if W's smallest eigenvalue is below
  /// 1e3 tau times its largest, else the generated answer stands; the projections use the
  /// damped correction.
  /// Stats::near_singular counts the damped answers, Stats::singular_checks the dense
  /// eigendecompositions.  0: off (the generated solver's answers, its status 2 a Failure).
  /// Not used with Stabilization::kBaumgarte; with kNone no projection runs, so only a
  /// status 2 or a regularized answer fires the screen.
  double singular_damping = 1e-10;
};

/// The screen of MechanismSettings::singular_damping.  The projections (once per accepted
/// step) estimate W's smallest eigenvalue from their own solve; below kNearEnter times a
/// bound of its largest, a dense check runs.  A dense check that finds W's smallest
/// eigenvalue below kNearExit tau times its largest makes every later f call and projection
/// run the dense check too, until one finds it above (hysteresis).
inline constexpr double kNearEnter = 1e-5;
inline constexpr double kNearExit = 1e4;

class Mechanism {
 public:
  explicit Mechanism(const System& system, MechanismSettings settings = {});

  const System& system() const { return sys_; }
  int size() const { return sys_.nq + sys_.nv; }

  /// Joint forces tau(t, q, v) (nv); default zero.
  void set_forces(std::function<void(double t, const double* q, const double* v, double* tau)> tau) {
    tau_ = std::move(tau);
  }

  /// y = (q0, v0): quaternions normalized, q0 assembled onto Phi = 0 when
  /// it is not (then `assembled` is set), v0 (nullptr: 0) projected onto
  /// Phiq v = 0.  Throws Failure (t = 0) when the assembly does not converge.
  std::vector<double> initial_state(const double* q0, const double* v0, bool* assembled = nullptr) const;

  /// The ODE f(y) = (qdot, qdd) with stabilization after each step.
  OdeProblem problem() const;

  /// integrate(problem(), ...), f_calls = forward-dynamics evaluations.
  Stats run(double t0, double t_end, std::vector<double>& y, const Settings& settings,
            const Observer& observe = nullptr) const;

  /// qdot (nq) from (q, v): qdot = v for one-coordinate joints and planar,
  /// quat' = 1/2 quat (x) (0, omega) for ball and floating (omega in the
  /// child frame), x' = linear velocity (joint frame) for floating.
  void qdot(const double* q, const double* v, double* qd) const;
  /// 1/2 v^T M v + potential_energy(q).
  double energy(const double* y) const;
  /// max |Phi(q)| and max |Phiq v|.
  double phi_norm(const double* y) const;
  double phiqv_norm(const double* y) const;
  /// Projection of y onto Phi = 0, Phiq v = 0 (mass metric) and quaternion
  /// normalization; t is for the message of a Failure.
  void stabilize(double t, double* y) const;

 private:
  int rhs(double t, const double* y, double* dydt, std::string& error) const;
  std::string singular_rows(const double* q) const;  // the dependent constraint row, for messages
  void retract(double* q, const double* dv) const;  // q <- q (+) dv
  void project_positions(double t, double* q) const;
  bool regularized_answer(int status) const;  // status 2 with a regularized answer written
  // MechanismSettings::singular_damping: whether W is near a rank loss (its smallest
  // eigenvalue below 1e3 tau s_max); then, or with `always`, dv = -M^-1 Phiq^T W_damped^+ r
  // (r = nullptr: the acceleration into dv, with the joint forces of the work buffer).
  bool damped_solve(const double* q, const double* v, const double* r, bool always, double* dv) const;
  // The free part of the damping's screen, after a generated solve that returned `status`
  // (0 or 2): status 2, a regularized answer, or a last dense check near a rank loss.
  bool damping_screen(int status) const;
  // The projections' screen (after solve_augmented with right-hand side r into the work
  // buffers): the Rayleigh quotient of lambda below kNearEnter times a bound of W's largest.
  bool rayleigh_small(const double* r) const;
  // The damped answer was used at t (counted for Stats::near_singular).
  void note_damped(double t, const double* q) const;
  // A projection's correction into the work buffer's dv (r: its right-hand side, Phi or
  // Phiq v); false when the generated solve failed with `status` and nothing was damped.
  bool projection_solve(double t, const double* q, const double* r, int& status) const;
  void project_velocities(double t, const double* q, double* v) const;
  void normalize_quaternions(double* q) const;
  [[noreturn]] void fail(double t, const char* what, int status) const;

  System sys_;
  MechanismSettings set_;
  std::vector<int> quat_;  ///< first q index of each quaternion
  std::vector<int> quat_v_;  ///< first v index of its angular velocity
  std::vector<int> lin_;   ///< floating joints: first q index (3 translations)
  std::vector<int> lin_v_;
  std::function<void(double, const double*, const double*, double*)> tau_;
};

}  // namespace jrgen::sim

// JRGEN_SIM_SYSTEM's detection of ns::last_solve_regularized: with `using
// namespace ns` and this fallback both visible, the call
// last_solve_regularized() picks the non-template ns function when it exists
// (it returns bool), else this template (it returns NoRegularization).  A
// namespace of its own at global scope: a using-directive makes its names
// visible in the nearest namespace enclosing both it and the use, the global
// one, so that lookup from inside any other namespace (jrgen::..., a user's)
// meets ns's function and this one in the same scope, not this one first.
namespace jrgen_sim_regularization_fallback {
struct NoRegularization {};
template <int = 0>
NoRegularization last_solve_regularized() {
  return {};
}
}  // namespace jrgen_sim_regularization_fallback

/// A jrgen::sim::System from the generated namespace `ns`.
#define JRGEN_SIM_SYSTEM(ns)                                                                          \
  ::jrgen::sim::System {                                                                              \
    ns::nq, ns::nv, ns::nc, ns::njoints, ns::joint_names, ns::joint_q_index, ns::joint_v_index,      \
        &ns::forward_dynamics, &ns::solve_augmented, &ns::mass_matrix, &ns::bias_forces,              \
        &ns::constraints, &ns::constraint_jacobian, &ns::constraint_gamma, &ns::potential_energy,        \
        &ns::last_error, JRGEN_SIM_REGULARIZED_FN(ns)                                                 \
  }

/// &ns::last_solve_regularized, or nullptr when ns has none (a solver
/// generated without --singular proximal).  C++17: the static_cast depends
/// on the lambda's parameter, so the discarded branch is never instantiated.
#define JRGEN_SIM_REGULARIZED_FN(ns)                                                                  \
  [](auto tag) -> bool (*)() {                                                                        \
    using R = typename decltype(tag)::type;                                                           \
    using namespace ::jrgen_sim_regularization_fallback;                                               \
    using namespace ns;                                                                               \
    if constexpr (std::is_same<decltype(last_solve_regularized()), R>::value)                         \
      return static_cast<R (*)()>(&last_solve_regularized);                                           \
    else                                                                                              \
      return nullptr;                                                                                 \
  }(::jrgen::sim::detail::TypeTag<bool>{})
