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
#include <random>
#include <vector>

#include <jrgen/articulated.hpp>

#include "analysis/runtime_model.hpp"
#include "common/model_cases.hpp"
#include "common/tolerance.hpp"
#include "gen_chain_1000.hpp"
#include "gen_chain_10000.hpp"
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

}  // namespace
