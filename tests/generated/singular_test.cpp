// --singular proximal (issue 19, item 6; docs/singular.md): at singular and
// redundant constraint configurations the generated solvers return status 0,
// set last_solve_regularized(), and give the unique qdd, the unique
// constraint force Phiq^T lambda and the minimum-norm lambda; elsewhere they
// are bitwise the solvers without the option.
//
// Reference: the same M, Q = tau - h, Phiq and gamma (from the solver's own
// pieces, so that the reference solves exactly the system the solver saw) in
// long double: W = Phiq M^-1 Phiq^T, its eigendecomposition, the
// pseudo-inverse keeping eigenvalues above 1e-10 of the largest (the
// vanishing directions here are 1e-17 or below; the regular ones above 1e-2),
// lambda = W^+ (Phiq M^-1 Q - gamma), qdd = M^-1 (Q - Phiq^T lambda).
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "gen_loops_fourbar_proximal.hpp"
#include "gen_loops_hmmwv14.hpp"
#include "gen_loops_hmmwv14_proximal.hpp"
#include "gen_loops_parallelogram.hpp"
#include "gen_loops_parallelogram_proximal.hpp"
#include "gen_loops_parallelogram_proximal_divide_ldlt.hpp"
#include "gen_loops_parallelogram_proximal_tables_ldlt.hpp"

namespace jrgen {
namespace {

using MatrixXld = Eigen::Matrix<long double, Eigen::Dynamic, Eigen::Dynamic>;
using VectorXld = Eigen::Matrix<long double, Eigen::Dynamic, 1>;
constexpr double kEps = 2.220446049250313e-16;

struct Api {
  const char* name;
  int nq, nv, nc;
  int (*forward_dynamics)(const double*, const double*, const double*, double*, double*);
  int (*solve_augmented)(const double*, const double*, const double*, const double*, double*, double*);
  void (*mass_matrix)(const double*, double*);
  void (*bias_forces)(const double*, const double*, double*);
  void (*constraints)(const double*, double*);
  void (*constraint_jacobian)(const double*, double*);
  void (*constraint_gamma)(const double*, const double*, double*);
  const char* (*last_error)();
  bool (*last_solve_regularized)();
};

#define JRGEN_API(ns)                                                                                        \
  Api {                                                                                                      \
    #ns, ns::nq, ns::nv, ns::nc, &ns::forward_dynamics, &ns::solve_augmented, &ns::mass_matrix,              \
        &ns::bias_forces, &ns::constraints, &ns::constraint_jacobian, &ns::constraint_gamma, &ns::last_error, \
        &ns::last_solve_regularized                                                                          \
  }

const std::vector<Api>& parallelograms() {
  static const std::vector<Api> apis = {JRGEN_API(gen_loops_parallelogram_proximal),
                                        JRGEN_API(gen_loops_parallelogram_proximal_divide_ldlt),
                                        JRGEN_API(gen_loops_parallelogram_proximal_tables_ldlt)};
  return apis;
}

struct System {
  Eigen::MatrixXd M, J;
  Eigen::VectorXd Q, gamma;
};

System system_at(const Api& s, const Eigen::VectorXd& q, const Eigen::VectorXd& v, const Eigen::VectorXd& tau) {
  System sys{Eigen::MatrixXd(s.nv, s.nv), Eigen::MatrixXd(s.nc, s.nv), Eigen::VectorXd(s.nv),
             Eigen::VectorXd(s.nc)};
  s.mass_matrix(q.data(), sys.M.data());
  Eigen::VectorXd h(s.nv);
  s.bias_forces(q.data(), v.data(), h.data());
  sys.Q = tau - h;
  s.constraint_jacobian(q.data(), sys.J.data());
  s.constraint_gamma(q.data(), v.data(), sys.gamma.data());
  return sys;
}

struct Reference {
  VectorXld qdd, lambda, force;  // force = Phiq^T lambda
  MatrixXld kept;                // projector onto the kept eigenvectors of W
  int rank;
};

Reference reference(const System& sys) {
  const MatrixXld M = sys.M.cast<long double>(), J = sys.J.cast<long double>();
  const Eigen::LLT<MatrixXld> llt(M);
  const MatrixXld W = J * llt.solve(J.transpose());
  const VectorXld b = J * llt.solve(sys.Q.cast<long double>()) - sys.gamma.cast<long double>();
  const Eigen::SelfAdjointEigenSolver<MatrixXld> es(W);
  const long double top = es.eigenvalues().cwiseAbs().maxCoeff();
  Reference r;
  r.lambda = VectorXld::Zero(W.rows());
  r.kept = MatrixXld::Zero(W.rows(), W.rows());
  r.rank = 0;
  for (int k = 0; k < W.rows(); ++k) {
    const long double s = es.eigenvalues()[k];
    if (s <= 1e-10L * top) continue;
    ++r.rank;
    r.kept += es.eigenvectors().col(k) * es.eigenvectors().col(k).transpose();
    r.lambda += es.eigenvectors().col(k) * (es.eigenvectors().col(k).dot(b) / s);
  }
  r.force = J.transpose() * r.lambda;
  r.qdd = llt.solve(sys.Q.cast<long double>() - r.force);
  return r;
}

long double rel(const Eigen::VectorXd& x, const VectorXld& ref) {
  return (x.cast<long double>() - ref).norm() / std::max(ref.norm(), 1e-300L);
}

struct Errors {
  long double qdd, force, lambda, lambda_kept;  // lambda_kept: in the kept eigenspace of W only
};

// Solves (forward_dynamics with a state, else solve_augmented on sys) and
// compares with the reference; expects status 0 and the flag `regularized`.
Errors check(const Api& s, const System& sys, bool regularized, const char* label,
             const Eigen::VectorXd* q = nullptr, const Eigen::VectorXd* v = nullptr,
             const Eigen::VectorXd* tau = nullptr) {
  Eigen::VectorXd qdd(s.nv), lambda(s.nc);
  const int status = q ? s.forward_dynamics(q->data(), v->data(), tau->data(), qdd.data(), lambda.data())
                       : s.solve_augmented(sys.M.data(), sys.Q.data(), sys.J.data(), sys.gamma.data(), qdd.data(),
                                           lambda.data());
  EXPECT_EQ(status, 0) << s.name << " " << label << ": " << s.last_error();
  EXPECT_EQ(s.last_solve_regularized(), regularized) << s.name << " " << label;
  const Reference ref = reference(sys);
  const Eigen::VectorXd force = sys.J.transpose() * lambda;
  const VectorXld kept = ref.kept * lambda.cast<long double>();
  const Errors e{rel(qdd, ref.qdd), rel(force, ref.force), rel(lambda, ref.lambda),
                 (kept - ref.lambda).norm() / ref.lambda.norm()};
  std::printf("%s %s: rank %d, regularized %d, |qdd - ref| %.1Le, |Phiq^T lambda - ref| %.1Le, |lambda - ref| %.1Le (%.1Le in "
              "the kept eigenspace)\n",
              s.name, label, ref.rank, s.last_solve_regularized() ? 1 : 0, e.qdd, e.force, e.lambda, e.lambda_kept);
  return e;
}

// Tolerances.  qdd and Phiq^T lambda are unique: backward-stable Cholesky
// solves of M and of the kept part of W, each c n eps cond (cond(M) = 65 for
// the parallelogram, cond of W's kept part ~ 10), plus the null-space noise of
// the iteration (~5 sqrt(eps) relative in lambda, multiplied by Phiq^T's
// ~1e-16 along that direction): 1e-12 keeps a margin of 100 or more over the
// measured errors.  lambda is the minimum-norm one to ~5 sqrt(eps) |z_m| /
// max W_jj relative (docs/singular.md): 1e-6.
constexpr long double kUniqueTolerance = 1e-12L, kLambdaTolerance = 1e-6L;

// The HMMWV's zero configuration (assembled): identity quaternions.
Eigen::VectorXd hmmwv_zero() {
  namespace h = gen_loops_hmmwv14_proximal;
  Eigen::VectorXd q = Eigen::VectorXd::Zero(h::nq);
  for (int j = 0; j < h::njoints; ++j) {
    const int nqj = (j + 1 < h::njoints ? h::joint_q_index[j + 1] : h::nq) - h::joint_q_index[j];
    if (nqj == 4) q[h::joint_q_index[j]] = 1.0;      // ball: w
    if (nqj == 7) q[h::joint_q_index[j] + 3] = 1.0;  // floating: w after the position
  }
  return q;
}

Eigen::VectorXd tau_of(int nv) {
  Eigen::VectorXd tau(nv);
  for (int i = 0; i < nv; ++i) tau[i] = 0.7 * std::cos(2.0 + i);
  return tau;
}

// The parallelogram on its parallelogram branch: crank angle theta, the
// coupler stays parallel to the ground, q = (theta, -theta, theta).  The
// change point is theta = pi/2 (all bars on the x axis).
Eigen::VectorXd parallelogram_q(double theta) { return Eigen::Vector3d(theta, -theta, theta); }

TEST(SingularProximal, ParallelogramAtItsChangePoint) {
  for (const Api& s : parallelograms()) {
    const Eigen::VectorXd q = parallelogram_q(M_PI / 2), v = Eigen::VectorXd::Zero(3), tau = tau_of(3);
    const System sys = system_at(s, q, v, tau);
    const Errors e = check(s, sys, true, "change point", &q, &v, &tau);
    EXPECT_LE(e.qdd, kUniqueTolerance);
    EXPECT_LE(e.force, kUniqueTolerance);
    EXPECT_LE(e.lambda, kLambdaTolerance);
  }
}

// Near the change point: at theta = pi/2 + 1e-9 the vanishing eigenvalue s of
// T^T T is ~1e-18 of the largest (regularized path).  The iteration would relax that
// direction (the regular solution's force along it, z_u / sqrt(s) with z_m's component
// z_u ~ sqrt(s), is O(1) of qdd and the regularization drops it), so the solve names it:
// status 2, "regularized solve without its digits" (docs/singular.md, "Status 0 of the
// regularized solve"; before, status 0 with that direction relaxed).  At pi/2 + 1e-3 s is
// ~1e-6 (regular path, every digit the condition allows: cond(T^T T) 1e6 costs lambda up
// to 6 digits, qdd and the force fewer).
TEST(SingularProximal, ParallelogramNearItsChangePoint) {
  for (const Api& s : parallelograms()) {
    for (const double offset : {1e-9, -1e-9, 1e-3}) {
      const Eigen::VectorXd q = parallelogram_q(M_PI / 2 + offset), tau = tau_of(3);
      const Eigen::VectorXd v = Eigen::VectorXd::Zero(3);
      Eigen::VectorXd phi(s.nc);
      s.constraints(q.data(), phi.data());
      EXPECT_LT(phi.cwiseAbs().maxCoeff(), 1e-15);  // assembled
      if (std::fabs(offset) < 1e-6) {
        Eigen::VectorXd qdd(s.nv), lambda(s.nc);
        EXPECT_EQ(s.forward_dynamics(q.data(), v.data(), tau.data(), qdd.data(), lambda.data()), 2) << s.name;
        EXPECT_TRUE(s.last_solve_regularized()) << s.name;
        EXPECT_NE(std::string(s.last_error()).find("regularized solve without its digits"), std::string::npos)
            << s.name << ": " << s.last_error();
        std::printf("%s %g off: %s\n", s.name, offset, s.last_error());
        continue;
      }
      const System sys = system_at(s, q, v, tau);
      const Errors e = check(s, sys, false, "1e-3 off", &q, &v, &tau);
      EXPECT_LE(e.qdd, kUniqueTolerance);
      EXPECT_LE(e.force, kUniqueTolerance);
      EXPECT_LE(e.lambda, 1e-8L);
    }
  }
}

// The crank-rocker four-bar with its three bars on the x axis (a flat,
// unassembled configuration: Phiq has rank 1).  v = 0, so gamma = 0 and the
// system is consistent.
TEST(SingularProximal, FourbarFlat) {
  const Api s = JRGEN_API(gen_loops_fourbar_proximal);
  const double a = std::atan2(0.4, 0.3), b = std::atan2(0.5, 0.9);
  const Eigen::VectorXd q = Eigen::Vector3d(-a, a - b, b + M_PI / 2), v = Eigen::VectorXd::Zero(3);
  const Eigen::VectorXd tau = tau_of(3);
  const System sys = system_at(s, q, v, tau);
  const Errors e = check(s, sys, true, "flat", &q, &v, &tau);
  EXPECT_LE(e.qdd, kUniqueTolerance);
  EXPECT_LE(e.force, kUniqueTolerance);
  EXPECT_LE(e.lambda, kLambdaTolerance);
}

// Redundant rows kept: the two rows given to solve_augmented are one and the
// same row (and gamma entry): T^T T has rank 1 exactly.  The minimum-norm
// lambda splits the force evenly between them.  On the parallelogram at a
// regular state and on the HMMWV (dense Step 3.4: rows 0 and 1 of one
// spherical cut, 16 rows, cond(M) ~ 1e5: its tolerance is that many times
// larger).
TEST(SingularProximal, RedundantRows) {
  const Eigen::VectorXd tau3 = tau_of(3);
  for (const Api& s : parallelograms()) {
    const Eigen::VectorXd q = parallelogram_q(0.4), v = Eigen::Vector3d(0.3, -0.3, 0.3);
    System sys = system_at(s, q, v, tau3);
    sys.J.row(1) = sys.J.row(0);
    sys.gamma[1] = sys.gamma[0];
    const Errors e = check(s, sys, true, "redundant");
    EXPECT_LE(e.qdd, kUniqueTolerance);
    EXPECT_LE(e.force, kUniqueTolerance);
    EXPECT_LE(e.lambda, kLambdaTolerance);
  }
  const Api s = JRGEN_API(gen_loops_hmmwv14_proximal);
  const Eigen::VectorXd q = hmmwv_zero();
  const Eigen::VectorXd v = Eigen::VectorXd::Zero(s.nv), tau = tau_of(s.nv);
  System sys = system_at(s, q, v, tau);
  sys.J.row(1) = sys.J.row(0);
  sys.gamma[1] = sys.gamma[0];
  const Errors e = check(s, sys, true, "redundant");
  EXPECT_LE(e.qdd, 1e5L * kUniqueTolerance);
  EXPECT_LE(e.force, 1e5L * kUniqueTolerance);
  EXPECT_LE(e.lambda, kLambdaTolerance);
}

// Regular states: the option changes nothing, bitwise (the regular Step 3.4
// runs, and its result is used as it is).
TEST(SingularProximal, RegularStatesAreBitwiseUnchanged) {
  const Api with = JRGEN_API(gen_loops_hmmwv14_proximal), without = Api{
      "gen_loops_hmmwv14", gen_loops_hmmwv14::nq, gen_loops_hmmwv14::nv, gen_loops_hmmwv14::nc,
      &gen_loops_hmmwv14::forward_dynamics, &gen_loops_hmmwv14::solve_augmented, &gen_loops_hmmwv14::mass_matrix,
      &gen_loops_hmmwv14::bias_forces, &gen_loops_hmmwv14::constraints, &gen_loops_hmmwv14::constraint_jacobian,
      &gen_loops_hmmwv14::constraint_gamma, &gen_loops_hmmwv14::last_error, nullptr};
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::VectorXd q = hmmwv_zero() + 0.05 * Eigen::VectorXd::Random(with.nq);
    const Eigen::VectorXd v = Eigen::VectorXd::Random(with.nv), tau = Eigen::VectorXd::Random(with.nv);
    Eigen::VectorXd qdd1(with.nv), qdd2(with.nv), l1(with.nc), l2(with.nc);
    ASSERT_EQ(with.forward_dynamics(q.data(), v.data(), tau.data(), qdd1.data(), l1.data()), 0) << with.last_error();
    EXPECT_FALSE(with.last_solve_regularized());
    ASSERT_EQ(without.forward_dynamics(q.data(), v.data(), tau.data(), qdd2.data(), l2.data()), 0);
    EXPECT_EQ(std::memcmp(qdd1.data(), qdd2.data(), sizeof(double) * with.nv), 0);
    EXPECT_EQ(std::memcmp(l1.data(), l2.data(), sizeof(double) * with.nc), 0);
  }
  // The parallelogram (solve_augmented: no gravity involved) at regular states.
  const Api p = parallelograms()[0];
  for (const double theta : {0.0, 0.4, 1.2, 2.5}) {
    const System sys = system_at(p, parallelogram_q(theta), Eigen::Vector3d(0.2, -0.2, 0.2), tau_of(3));
    Eigen::VectorXd qdd1(3), qdd2(3), l1(p.nc), l2(p.nc);
    ASSERT_EQ(p.solve_augmented(sys.M.data(), sys.Q.data(), sys.J.data(), sys.gamma.data(), qdd1.data(), l1.data()),
              0);
    EXPECT_FALSE(p.last_solve_regularized());
    ASSERT_EQ(gen_loops_parallelogram::solve_augmented(sys.M.data(), sys.Q.data(), sys.J.data(), sys.gamma.data(),
                                                        qdd2.data(), l2.data()),
              0);
    EXPECT_EQ(std::memcmp(qdd1.data(), qdd2.data(), sizeof(double) * 3), 0);
    EXPECT_EQ(std::memcmp(l1.data(), l2.data(), sizeof(double) * p.nc), 0);
  }
}

// Without the option the same singular states still give status 2.
TEST(SingularProximal, WithoutTheOptionStatus2Remains) {
  const Eigen::VectorXd q = parallelogram_q(M_PI / 2), v = Eigen::VectorXd::Zero(3), tau = tau_of(3);
  Eigen::VectorXd qdd(3), lambda(gen_loops_parallelogram::nc);
  EXPECT_EQ(gen_loops_parallelogram::forward_dynamics(q.data(), v.data(), tau.data(), qdd.data(), lambda.data()), 2);
}

}  // namespace
}  // namespace jrgen
