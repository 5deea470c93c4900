// Stiff and extreme cases, measured (docs/extreme.md):
//
//   - huge mass ratios (trees with masses over 4 and 8 decades): the generated
//     Cholesky solve is as accurate as the *scaled* condition number allows.
//     Cholesky is invariant under symmetric diagonal scaling: its computed
//     factor is the exact factor of M + E with |E| <= c(n) eps |L||L^T|
//     (Higham, Accuracy and Stability of Numerical Algorithms, Thm. 10.3), so
//     the forward error is bounded by c(n) eps cond2(S M S), S = diag(M)^-1/2
//     (van der Sluis; Demmel, "On floating point errors in Cholesky", 1989),
//     not by cond2(M), which a mass ratio alone drives up.  The bound is
//     held with c(n) = 4 n, the tolerance of generated_solver_test.
//   - near-singular loops: two rows of one cut made nearly dependent
//     (row b <- row a + delta row b).  T^T T then has condition ~ 1/delta^2;
//     down to the pivot tolerance the error stays below
//     (nv + nc) eps (cond(M) + cond(T^T T)), and below it the solve stops with status 2
//     naming the loop joint and row, never a silent NaN or garbage.
//
// References: the same systems solved in long double (64-bit significand)
// with iterative refinement.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <cstdio>
#include <random>
#include <string>

#include "common/tolerance.hpp"
#include "generated/solver_registry.hpp"

namespace jrgen {
namespace {

using testing::GeneratedSolver;
using testing::kEps;
using MatrixXld = Eigen::Matrix<long double, Eigen::Dynamic, Eigen::Dynamic>;
using VectorXld = Eigen::Matrix<long double, Eigen::Dynamic, 1>;

const GeneratedSolver& solver(const std::string& target) {
  for (const GeneratedSolver& s : testing::generated_solvers())
    if (s.target == target) return s;
  throw std::runtime_error("no generated solver " + target);
}

// q uniform in [-1, 1], quaternion entries included: the solver normalizes
// them (docs/interface.md section 3).
Eigen::VectorXd random_q(const GeneratedSolver& s, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd q(s.nq);
  for (int i = 0; i < s.nq; ++i) q[i] = u(rng);
  return q;
}

long double rel(const Eigen::VectorXd& x, const VectorXld& ref) {
  return (x.cast<long double>() - ref).norm() / ref.norm();
}

// Condition number (2-norm) of a symmetric positive definite matrix, in long
// double so that values beyond 1e16 are still resolved.
long double spd_condition(const MatrixXld& A) {
  Eigen::SelfAdjointEigenSolver<MatrixXld> es(A, Eigen::EigenvaluesOnly);
  return es.eigenvalues().maxCoeff() / es.eigenvalues().minCoeff();
}

// ---- Huge mass ratios -------------------------------------------------------

class StiffTree : public ::testing::TestWithParam<std::string> {};

TEST_P(StiffTree, ErrorWithinTheScaledConditionBound) {
  const GeneratedSolver& s = solver(GetParam());
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 4; ++trial) {
    const Eigen::VectorXd q = random_q(s, rng);
    Eigen::VectorXd v(s.nv), tau(s.nv), h(s.nv), qdd(s.nv);
    for (int i = 0; i < s.nv; ++i) v[i] = u(rng), tau[i] = u(rng);
    Eigen::MatrixXd M(s.nv, s.nv);
    s.mass_matrix(q.data(), M.data());
    s.bias_forces(q.data(), v.data(), h.data());
    const Eigen::VectorXd Q = tau - h;
    ASSERT_EQ(s.solve_augmented(M.data(), Q.data(), nullptr, nullptr, qdd.data(), nullptr), 0) << s.last_error();

    // Reference: long double Cholesky of the same M, two refinement steps.
    const MatrixXld Ml = M.cast<long double>();
    const VectorXld Ql = Q.cast<long double>();
    const Eigen::LLT<MatrixXld> llt(Ml);
    VectorXld x = llt.solve(Ql);
    for (int k = 0; k < 2; ++k) x += llt.solve(Ql - Ml * x);

    const VectorXld d = Ml.diagonal().cwiseSqrt().cwiseInverse();
    const long double cond = spd_condition(Ml);
    const long double cond_scaled = spd_condition(d.asDiagonal() * Ml * d.asDiagonal());
    const long double err = rel(qdd, x);
    std::printf("%s: cond2(M) %.2Le, cond2(S M S) %.2Le, mass spread %.1e, |qdd - ref| / |ref| %.2Le\n",
                s.target.c_str(), cond, cond_scaled, M.diagonal().maxCoeff() / M.diagonal().minCoeff(), err);
    EXPECT_LE(err, 4.0L * s.nv * kEps * cond_scaled) << "cond2(S M S) = " << cond_scaled;
    // The full pipeline on the same state: success and a finite result.
    Eigen::VectorXd qdd_fd(s.nv);
    EXPECT_EQ(s.forward_dynamics(q.data(), v.data(), tau.data(), qdd_fd.data(), nullptr), 0) << s.last_error();
    EXPECT_TRUE(qdd_fd.allFinite());
  }
}

INSTANTIATE_TEST_SUITE_P(Extreme, StiffTree, ::testing::Values("gen_stiff_mass_1e4", "gen_stiff_mass_1e8"));

// ---- Near-singular loops ----------------------------------------------------

struct AugmentedReference {
  VectorXld qdd, lambda;
};

// A x = b, A = [M J^T; J 0], by LU with partial pivoting in long double and
// three refinement steps.
AugmentedReference solve_reference(const Eigen::MatrixXd& M, const Eigen::MatrixXd& J, const Eigen::VectorXd& Q,
                                   const Eigen::VectorXd& g) {
  const int n = static_cast<int>(M.rows()), m = static_cast<int>(J.rows());
  MatrixXld A = MatrixXld::Zero(n + m, n + m);
  A.topLeftCorner(n, n) = M.cast<long double>();
  A.topRightCorner(n, m) = J.transpose().cast<long double>();
  A.bottomLeftCorner(m, n) = J.cast<long double>();
  VectorXld b(n + m);
  b << Q.cast<long double>(), g.cast<long double>();
  const Eigen::PartialPivLU<MatrixXld> lu(A);
  VectorXld x = lu.solve(b);
  for (int k = 0; k < 3; ++k) x += lu.solve(b - A * x);
  return {x.head(n), x.tail(m)};
}

TEST(NearSingularLoop, ErrorFollowsConditionThenStatus2NamesTheLoop) {
  const GeneratedSolver& s = solver("gen_loops_hmmwv14");
  // The zero configuration is assembled (the cuts' frames coincide there and
  // the distance cuts take their zero-configuration lengths).
  Eigen::VectorXd q = Eigen::VectorXd::Zero(s.nq);
  for (int j = 0; j < s.njoints; ++j) {
    const int nqj = (j + 1 < s.njoints ? s.joint_q_index[j + 1] : s.nq) - s.joint_q_index[j];
    if (nqj == 4) q[s.joint_q_index[j]] = 1.0;      // ball: w
    if (nqj == 7) q[s.joint_q_index[j] + 3] = 1.0;  // floating: w after the position
  }
  Eigen::VectorXd phi(s.nc);
  s.constraints(q.data(), phi.data());
  ASSERT_LT(phi.lpNorm<Eigen::Infinity>(), 1e-12);

  Eigen::MatrixXd M(s.nv, s.nv), J0(s.nc, s.nv);
  s.mass_matrix(q.data(), M.data());
  s.constraint_jacobian(q.data(), J0.data());
  const Eigen::VectorXd Q = Eigen::VectorXd::LinSpaced(s.nv, -1.0, 1.0);
  const Eigen::VectorXd g = Eigen::VectorXd::Zero(s.nc);
  const long double cond_M = spd_condition(M.cast<long double>());

  // Rows 0 and 1 are the x and y rows of one spherical cut (same structural
  // pattern, so every entry of the combination is read).
  const Eigen::VectorXd r0 = J0.row(0).transpose(), r1 = J0.row(1).transpose();
  long double previous_cond_W = 0;
  for (const double delta : {1e-1, 1e-2, 1e-3, 1e-4}) {
    Eigen::MatrixXd J = J0;
    J.row(1) = (r0 + delta * r1).transpose();
    Eigen::VectorXd qdd(s.nv), lambda(s.nc);
    ASSERT_EQ(s.solve_augmented(M.data(), Q.data(), J.data(), g.data(), qdd.data(), lambda.data()), 0)
        << "delta " << delta << ": " << s.last_error();
    const AugmentedReference ref = solve_reference(M, J, Q, g);
    // cond2 of W = J M^-1 J^T = T^T T, in long double.
    const MatrixXld Ml = M.cast<long double>(), Jl = J.cast<long double>();
    const MatrixXld W = Jl * Eigen::LLT<MatrixXld>(Ml).solve(Jl.transpose());
    const long double cond_W = spd_condition(W);
    const long double err = rel(qdd, ref.qdd);
    const long double err_force = (J.transpose().cast<long double>() * (lambda.cast<long double>() - ref.lambda)).norm() /
                                  (J.transpose().cast<long double>() * ref.lambda).norm();
    const double residual = (J * qdd - g).norm() / (J.norm() * qdd.norm());
    // The constraint residual is that of the Step 3.4 solve, W lambda = z_m:
    // a backward-stable solve leaves |z_m - W lambda| <= c eps |W| |lambda|,
    // and |lambda| grows like 1 / delta as the two rows become dependent.
    const double residual_bound = static_cast<double>(s.nv + s.nc) * static_cast<double>(kEps) *
                                  (1.0 + static_cast<double>(W.norm()) * lambda.norm() / (J.norm() * qdd.norm()));
    std::printf("delta %.0e: cond2(T^T T) %.2Le, |qdd - ref| / |ref| %.2Le, |Phiq^T dlambda| / |Phiq^T lambda| %.2Le, "
                "|Phiq qdd - gamma| / (|Phiq| |qdd|) %.1e (bound %.1e)\n",
                delta, cond_W, err, err_force, residual, residual_bound);
    // Two backward-stable Cholesky solves, of M (Steps 1, 2, 4) and of T^T T
    // (Step 3.4): to first order their forward errors add, each c(n) eps
    // cond.  With c(n) = nv + nc the measured errors sit 100x or more below.
    const long double bound = static_cast<long double>(s.nv + s.nc) * kEps * (cond_M + cond_W);
    EXPECT_LE(err, bound) << "delta " << delta;
    EXPECT_LE(err_force, bound) << "delta " << delta;
    EXPECT_LE(residual, residual_bound) << "delta " << delta;
    EXPECT_GT(cond_W, previous_cond_W);              // the sweep does approach the singularity
    previous_cond_W = cond_W;
  }
  // Past the pivot tolerance (a pivot below 1e-14 of its diagonal entry of
  // T^T T: no digit of lambda would survive), and at exact dependence, the
  // solve reports status 2 and names the cut.
  for (const double delta : {1e-5, 1e-9, 0.0}) {  // T^T T pivot below 1e-9 of W_jj from 1e-5 on
    Eigen::MatrixXd J = J0;
    J.row(1) = (r0 + delta * r1).transpose();
    Eigen::VectorXd qdd = Eigen::VectorXd::Zero(s.nv), lambda(s.nc);
    EXPECT_EQ(s.solve_augmented(M.data(), Q.data(), J.data(), g.data(), qdd.data(), lambda.data()), 2)
        << "delta " << delta;
    const std::string message = s.last_error();
    std::printf("delta %.0e: status 2, %s\n", delta, message.c_str());
    EXPECT_NE(message.find("constraint rows singular"), std::string::npos) << message;
    EXPECT_NE(message.find("loop joint 'rf_lower_ball'"), std::string::npos) << message;
  }
}

}  // namespace
}  // namespace jrgen
