// The specialized articulated-body block (emit/articulated_terms.cpp, issue
// 20 item 2) against the independent reference (tests/reference: world-frame
// Newton-Euler and a dense M) on every tree model of the suite, evaluated at
// generation time (Program::evaluate, the operations of the emitted code).
#include "emit/articulated_terms.hpp"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <random>
#include <string>

#include "analysis/runtime_model.hpp"
#include "common/model_cases.hpp"
#include "common/tolerance.hpp"
#include "reference/reference_dynamics.hpp"
#include "topology/topology.hpp"

namespace {

using jrgen::emit::Program;
using jrgen::testing::ModelCase;

class ArticulatedEmit : public ::testing::TestWithParam<ModelCase> {};

const Eigen::Vector3d kGravity(0.0, 0.0, -9.81);

struct Built {
  jrgen::ir::Robot robot;
  jrgen::topology::Tree tree;
};

// Backward error: qdd solves M qdd = tau - h exactly for a nearby problem
// when the residual r = M qdd + h - tau (the reference's Newton-Euler with
// qdd, no M formed) is small against the terms it balances.  A backward
// stable O(n) recursion (each sweep a short sum per body) leaves
// ||r|| <= c(n) eps (||M|| ||qdd|| + ||tau|| + ||h||); c(n) = 100 nv covers
// the sums along a path of up to nv bodies with room, and is far below what
// a wrong term gives (O(1)).
TEST_P(ArticulatedEmit, SolvesTheEquationsOfMotionToWorkingPrecision) {
  Built m{jrgen::testing::read_model_case(GetParam()), {}};
  m.tree = jrgen::topology::build_tree(m.robot);
  Program program("const double* q, const double* v, const double* tau");
  program.begin_function("articulated", "test");
  program.begin_block("aba");
  const auto frames = jrgen::emit::joint_frames(program, m.tree);
  const auto motion = jrgen::emit::body_velocities(program, m.tree, frames);
  const auto result = jrgen::emit::articulated_body(program, m.tree, frames, motion, kGravity);
  std::mt19937_64 rng(7);
  for (int trial = 0; trial < 3; ++trial) {
    const Eigen::VectorXd q = jrgen::reference::random_configuration(m.robot, rng);
    const Eigen::VectorXd v = jrgen::reference::random_velocity(m.robot, rng);
    const Eigen::VectorXd tau = 10.0 * jrgen::reference::random_velocity(m.robot, rng);
    const auto x = program.evaluate([&](const std::string& in) {
      const int i = std::stoi(in.substr(in.find('[') + 1));
      return in[0] == 'q' ? q[i] : in[0] == 'v' ? v[i] : tau[i];
    });
    Eigen::VectorXd qdd(m.tree.nv);
    for (int j = 0; j < m.tree.nv; ++j) qdd[m.tree.dof_user[j]] = Program::value(result.qdd[j], x);
    const Eigen::VectorXd h = jrgen::reference::bias_forces(m.robot, q, v, kGravity);
    const Eigen::MatrixXd M = jrgen::reference::mass_matrix(m.robot, q);
    // The force elements (docs/interface.md 2b; the reference knows none): the runtime's
    // jr::force_elements, Lemma 2 order mapped to user order.
    Eigen::VectorXd fe = Eigen::VectorXd::Zero(m.tree.nv);
    if (m.tree.has_force_elements()) {
      jrgen::analysis::RuntimeModel rm(m.tree, kGravity);
      Eigen::VectorXd fe_lem = Eigen::VectorXd::Zero(m.tree.nv);
      jr::kinematics(rm.model(), rm.workspace(), q.data());
      jr::force_elements(rm.model(), rm.forces(), rm.workspace(), q.data(), v.data(), fe_lem.data());
      for (int j = 0; j < m.tree.nv; ++j) fe[m.tree.dof_user[j]] = fe_lem[j];
    }
    const Eigen::VectorXd r = jrgen::reference::inverse_dynamics(m.robot, q, v, qdd, kGravity) + fe - tau;
    const double scale = M.norm() * qdd.norm() + tau.norm() + h.norm() + fe.norm();
    EXPECT_LE(r.norm(), 100.0 * m.tree.nv * jrgen::testing::kEps * scale)
        << "trial " << trial << ", |r| = " << r.norm() << ", scale " << scale;
  }
}

// The pivots of the articulated-body algorithm are those of Step 1's
// leaves-first L D L^T of M (the runtime's table-driven factorization on
// the same packed M): both are Schur complements of the same matrix, each
// computed with a relative error of a few eps times the growth of the
// partial sums; 1e-9 leaves room for the models' mass ratios (up to 1e6).
TEST_P(ArticulatedEmit, PivotsAreThoseOfTheLeavesFirstFactorization) {
  Built m{jrgen::testing::read_model_case(GetParam()), {}};
  m.tree = jrgen::topology::build_tree(m.robot);
  Program program("const double* q, const double* v, const double* tau");
  program.begin_function("articulated", "test");
  program.begin_block("aba");
  const auto frames = jrgen::emit::joint_frames(program, m.tree);
  const auto motion = jrgen::emit::body_velocities(program, m.tree, frames);
  const auto result = jrgen::emit::articulated_body(program, m.tree, frames, motion, kGravity);
  jrgen::analysis::RuntimeModel rm(m.tree, kGravity);
  std::mt19937_64 rng(8);
  const Eigen::VectorXd q = jrgen::reference::random_configuration(m.robot, rng);
  const auto x = program.evaluate([&](const std::string& in) {
    return in[0] == 'q' ? q[std::stoi(in.substr(2))] : 0.0;
  });
  jr::kinematics(rm.model(), rm.workspace(), q.data());
  std::vector<double> L(m.tree.nnz()), Dinv(m.tree.nv);
  jr::mass_matrix_packed(rm.model(), rm.workspace(), L.data());
  double pivot = 0.0;
  ASSERT_LT(jr::factor_packed(rm.model(), L.data(), Dinv.data(), true, 0.0, &pivot), 0);
  for (int j = 0; j < m.tree.nv; ++j) {
    // A joint's several dofs are pivoted in its own order by both.
    const double d = Program::value(result.pivots[j], x), ref = 1.0 / Dinv[j];
    EXPECT_NEAR(d, ref, 1e-9 * std::abs(ref)) << "dof " << j;
  }
}

std::vector<ModelCase> cases() {
  std::vector<ModelCase> out = jrgen::testing::project_tree_models();
  for (const ModelCase& c : jrgen::testing::external_models()) out.push_back(c);
  const std::vector<ModelCase> random = jrgen::testing::random_trees();
  for (std::size_t i = 0; i < random.size() && i < 10; ++i) out.push_back(random[i]);
  return out;
}

INSTANTIATE_TEST_SUITE_P(All, ArticulatedEmit, ::testing::ValuesIn(cases()),
                         [](const auto& info) { return info.param.name; });

}  // namespace
