// The specialized terms of forward_dynamics, mass_matrix, bias_forces and the
// constraint pieces (emit/terms.cpp, issue 20) against the runtime's generic
// terms (the same model generated with JRGEN_TERMS_LIMIT=0): the generic path
// stays the reference.  Evaluations (M, h, Phi, Phiq, gamma) must agree to a
// few rounding errors of their own scale; the solves are held to the backward
// error of eq. (17) evaluated with the runtime's terms.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <ostream>
#include <random>
#include <string>
#include <vector>

#include "common/model_cases.hpp"
#include "common/tolerance.hpp"
#include "generated/solver_registry.hpp"
#include "reference/reference_dynamics.hpp"

namespace {

using jrgen::testing::GeneratedSolver;
using jrgen::testing::kEps;

struct Pair {
  std::string specialized, runtime;
};
void PrintTo(const Pair& p, std::ostream* os) { *os << p.specialized << " vs " << p.runtime; }

const GeneratedSolver& solver(const std::string& target) {
  for (const GeneratedSolver& s : jrgen::testing::generated_solvers())
    if (s.target == target) return s;
  throw std::runtime_error("no generated solver " + target);
}

class Terms : public ::testing::TestWithParam<Pair> {};

// c(n) = 100 nv: each entry is a sum along a path of at most nv bodies of
// products of a few factors, each rounded (as in dynamics_emit_test); a wrong
// term gives O(1) relative differences.
TEST_P(Terms, AgreeWithTheRuntimeTerms) {
  const GeneratedSolver& s = solver(GetParam().specialized);
  const GeneratedSolver& r = solver(GetParam().runtime);
  ASSERT_EQ(s.nv, r.nv);
  ASSERT_EQ(s.nc, r.nc);
  const jrgen::ir::Robot robot = jrgen::testing::read_model_case(jrgen::testing::find_model_case(s.model_case));
  const int nv = s.nv, nc = s.nc;
  const double tol = 100.0 * nv * kEps;
  std::mt19937_64 rng(2026);
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::VectorXd q = jrgen::reference::random_configuration(robot, rng);
    const Eigen::VectorXd v = jrgen::reference::random_velocity(robot, rng);
    const Eigen::VectorXd tau = 10.0 * jrgen::reference::random_velocity(robot, rng);
    Eigen::MatrixXd Ms(nv, nv), Mr(nv, nv);
    Eigen::VectorXd hs(nv), hr(nv);
    s.mass_matrix(q.data(), Ms.data());
    r.mass_matrix(q.data(), Mr.data());
    s.bias_forces(q.data(), v.data(), hs.data());
    r.bias_forces(q.data(), v.data(), hr.data());
    const double g = Eigen::Vector3d(s.gravity[0], s.gravity[1], s.gravity[2]).norm();
    EXPECT_LE((Ms - Mr).norm(), tol * Mr.norm()) << "M, trial " << trial;
    EXPECT_LE((hs - hr).norm(), tol * (hr.norm() + Mr.norm() * (v.squaredNorm() + g)))
        << "h, trial " << trial;

    Eigen::MatrixXd Pr = Eigen::MatrixXd::Zero(nc, nv), Ps = Pr;
    Eigen::VectorXd phis(nc), phir(nc), gs(nc), gr(nc);
    if (nc > 0) {
      s.constraints(q.data(), phis.data());
      r.constraints(q.data(), phir.data());
      s.constraint_jacobian(q.data(), Ps.data());
      r.constraint_jacobian(q.data(), Pr.data());
      s.constraint_gamma(q.data(), v.data(), gs.data());
      r.constraint_gamma(q.data(), v.data(), gr.data());
      // Positions of a few metres at most in these models; gamma scales with
      // |Phiq| |v|^2.
      const double L = std::max(1.0, phir.lpNorm<Eigen::Infinity>());
      EXPECT_LE((phis - phir).norm(), tol * L) << "Phi, trial " << trial;
      EXPECT_LE((Ps - Pr).norm(), tol * std::max(1.0, Pr.norm())) << "Phiq, trial " << trial;
      EXPECT_LE((gs - gr).norm(), tol * (gr.norm() + std::max(1.0, Pr.norm()) * v.squaredNorm()))
          << "gamma, trial " << trial;
    }

    // forward_dynamics: the backward error of eq. (17) with the runtime's terms.
    Eigen::VectorXd qdd(nv), lambda(std::max(nc, 1));
    ASSERT_EQ(s.forward_dynamics(q.data(), v.data(), tau.data(), qdd.data(), lambda.data()), 0) << s.last_error();
    Eigen::VectorXd r1 = Mr * qdd + hr - tau;
    double scale1 = Mr.norm() * qdd.norm() + tau.norm() + hr.norm();
    if (nc > 0) {
      r1 += Pr.transpose() * lambda.head(nc);
      scale1 += Pr.norm() * lambda.head(nc).norm();
      const Eigen::VectorXd r2 = Pr * qdd - gr;
      // Step 3's solve for lambda: its error grows with cond(T^T T); the
      // acceleration rows hold to the constraint's own scale.
      EXPECT_LE(r2.norm(), 1e3 * tol * (Pr.norm() * qdd.norm() + gr.norm())) << "Phiq qdd = gamma, trial " << trial;
    }
    // A tree's solve (Cholesky or the articulated-body recursion) is backward
    // stable: c(n) eps of the balanced terms.  With loops, lambda carries the
    // conditioning of T^T T (range-space method), hence the factor 1e3.
    EXPECT_LE(r1.norm(), (nc > 0 ? 1e3 : 1.0) * tol * scale1) << "M qdd + Phiq^T lambda = tau - h, trial " << trial;
  }
}

INSTANTIATE_TEST_SUITE_P(All, Terms,
                         ::testing::Values(Pair{"gen_arm7", "gen_arm7_runtime_terms"},
                                           Pair{"gen_legged30", "gen_legged30_runtime_terms"},
                                           Pair{"gen_ext_anymal", "gen_ext_anymal_runtime_terms"},
                                           Pair{"gen_loops_hmmwv14", "gen_loops_hmmwv14_runtime_terms"},
                                           Pair{"gen_loops_stewart", "gen_loops_stewart_runtime_terms"}),
                         [](const auto& info) { return info.param.specialized; });

}  // namespace
