// Issue 20, item 2: the generated forward_dynamics of serial chains of 1000
// and 10 000 revolute joints (a rope) runs an O(n) route (the runtime's
// articulated-body algorithm: the specialized programs would be too large),
// returns status 0 and satisfies M qdd = tau - h to working precision.  The
// residual is computed in O(n), without M: r = ID(q, v, qdd) - tau with the
// runtime's recursive Newton-Euler (jr::inverse_dynamics, a different
// algorithm from the articulated-body one), against the scale of the terms
// it balances; on the 1000-joint chain also with the independent reference's
// world-frame Newton-Euler (tests/reference).
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <jrgen/articulated.hpp>

#include "analysis/runtime_model.hpp"
#include "common/model_cases.hpp"
#include "common/tolerance.hpp"
#include "gen_chain_1000.hpp"
#include "gen_chain_10000.hpp"
#include "gen_loops_rope_300.hpp"
#include "gen_loops_rope_300_steps.hpp"
#include "reference/reference_dynamics.hpp"
#include "topology/topology.hpp"

namespace {

using jrgen::testing::kEps;

const Eigen::Vector3d kGravity(0.0, 0.0, -9.81);

using Dynamics = int (*)(const double*, const double*, const double*, double*, double*);

void check_chain(const char* name, Dynamics forward_dynamics, const char* (*last_error)(), bool reference) {
  const jrgen::ir::Robot robot = jrgen::testing::read_model_case(jrgen::testing::find_model_case(name));
  const jrgen::topology::Tree tree = jrgen::topology::build_tree(robot);
  jrgen::analysis::RuntimeModel rm(tree, kGravity);
  const int nv = tree.nv;
  std::mt19937_64 rng(20);
  const Eigen::VectorXd q = jrgen::reference::random_configuration(robot, rng);
  const Eigen::VectorXd v = jrgen::reference::random_velocity(robot, rng);
  const Eigen::VectorXd tau = 10.0 * jrgen::reference::random_velocity(robot, rng);
  Eigen::VectorXd qdd(nv);
  ASSERT_EQ(forward_dynamics(q.data(), v.data(), tau.data(), qdd.data(), nullptr), 0) << last_error();

  // Lemma 2 order for the runtime's recursions.
  Eigen::VectorXd qdd_lem(nv), tau_lem(nv), id(nv), h(nv), zero = Eigen::VectorXd::Zero(nv);
  for (int j = 0; j < nv; ++j) {
    qdd_lem[j] = qdd[tree.dof_user[j]];
    tau_lem[j] = tau[tree.dof_user[j]];
  }
  bool damping = false;
  for (const jrgen::topology::Body& b : tree.bodies) damping = damping || b.damping != 0.0;
  jr::kinematics(rm.model(), rm.workspace(), q.data());
  jr::inverse_dynamics(rm.model(), rm.workspace(), v.data(), qdd_lem.data(), id.data(), true, damping);
  jr::inverse_dynamics(rm.model(), rm.workspace(), v.data(), zero.data(), h.data(), true, damping);
  // ||M qdd|| + ||tau|| + ||h|| (M qdd = ID - h), a lower bound of
  // ||M|| ||qdd|| + ..., with c(n) = 100 nv as for every backward-stable
  // recursion along a path of n bodies.
  const double scale = (id - h).norm() + tau.norm() + h.norm();
  EXPECT_LE((id - tau_lem).norm(), 100.0 * nv * kEps * scale) << name;
  if (reference) {
    const Eigen::VectorXd r = jrgen::reference::inverse_dynamics(robot, q, v, qdd, kGravity) - tau;
    EXPECT_LE(r.norm(), 100.0 * nv * kEps * scale) << name << " (reference)";
  }
}

TEST(LongChain, ThousandJoints) {
  check_chain("chain_1000", &gen_chain_1000::forward_dynamics, &gen_chain_1000::last_error, true);
}

TEST(LongChain, TenThousandJoints) {
  check_chain("chain_10000", &gen_chain_10000::forward_dynamics, &gen_chain_10000::last_error, false);
}

// The rope tied back to its base (loops_rope_300, assembled at q = 0 with
// its vertical row dropped): the runtime's articulated-body route for loops
// against M and Steps 1-4 of the same model generated with --singular
// proximal (which takes the paper's route).  Both solve eq. (17) backward
// stably, so they agree within eps times the conditioning of the system;
// 1e-9 leaves room over what is seen (printed), and a wrong term gives O(1).
// qdd also satisfies Phiq qdd = gamma to the rows' scale.
TEST(LongChain, RopeLoopArticulatedRouteMatchesSteps) {
  const int nv = gen_loops_rope_300::nv, nc = gen_loops_rope_300::nc;
  ASSERT_EQ(nc, 2);
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd q = Eigen::VectorXd::Zero(gen_loops_rope_300::nq), v(nv), tau(nv);
  for (int i = 0; i < nv; ++i) {
    v[i] = 0.1 * u(rng);
    tau[i] = 0.01 * u(rng);
  }
  Eigen::VectorXd a(nv), b(nv), la(nc), lb(nc);
  ASSERT_EQ(gen_loops_rope_300::forward_dynamics(q.data(), v.data(), tau.data(), a.data(), la.data()), 0)
      << gen_loops_rope_300::last_error();
  ASSERT_EQ(gen_loops_rope_300_steps::forward_dynamics(q.data(), v.data(), tau.data(), b.data(), lb.data()), 0)
      << gen_loops_rope_300_steps::last_error();
  std::printf("rope: qdd differ by %.2e, lambda by %.2e (relative)\n", (a - b).norm() / b.norm(),
              (la - lb).norm() / lb.norm());
  EXPECT_LE((a - b).norm(), 1e-9 * b.norm());
  EXPECT_LE((la - lb).norm(), 1e-9 * lb.norm());
  Eigen::MatrixXd Phiq(nc, nv);
  Eigen::VectorXd gamma(nc);
  gen_loops_rope_300_steps::constraint_jacobian(q.data(), Phiq.data());
  gen_loops_rope_300_steps::constraint_gamma(q.data(), v.data(), gamma.data());
  EXPECT_LE((Phiq * a - gamma).norm(), 100.0 * nv * kEps * (Phiq.norm() * a.norm() + gamma.norm()));
}

}  // namespace
