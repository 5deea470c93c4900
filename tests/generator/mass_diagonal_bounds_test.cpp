// topology::mass_diagonal_bounds (issue 29, item 3): the upper bounds of M's
// diagonal over all configurations that the articulated-body routes test their
// pivots against (docs/status.md).  Checked against the independent world-frame
// reference's M (tests/reference/) at random configurations of every tree
// model: M_jj never exceeds its bound, and the bound is not vacuous (finite on
// the dofs with no translating joint below, and printed with its margin).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "common/model_cases.hpp"
#include "reference/reference_dynamics.hpp"
#include "topology/topology.hpp"

namespace jrgen {
namespace {

class MassDiagonalBounds : public ::testing::TestWithParam<testing::ModelCase> {};

TEST_P(MassDiagonalBounds, BoundEveryDiagonalEntryAtRandomConfigurations) {
  const ir::Robot robot = testing::read_model_case(GetParam());
  const topology::Tree tree = topology::build_tree(robot);
  const std::vector<double> bound = topology::mass_diagonal_bounds(tree);
  ASSERT_EQ(static_cast<int>(bound.size()), tree.nv);
  std::mt19937_64 rng(11);
  double loosest = 0;  // the largest bound / M_jj over finite bounds
  int finite = 0;
  for (double b : bound) finite += std::isfinite(b) ? 1 : 0;
  for (int trial = 0; trial < 4; ++trial) {
    const Eigen::VectorXd q = reference::random_configuration(robot, rng);
    const Eigen::MatrixXd M = reference::mass_matrix(robot, q);
    for (int j = 0; j < tree.nv; ++j) {
      const double m = M(tree.dof_user[j], tree.dof_user[j]);
      // The reference sums the same masses in another order: 1e-12 relative.
      EXPECT_LE(m, bound[j] * (1 + 1e-12)) << GetParam().name << " dof " << j << " (user "
                                           << tree.dof_user[j] << ")";
      if (std::isfinite(bound[j]) && m > 0) loosest = std::max(loosest, bound[j] / m);
    }
  }
  std::printf("%s: %d of %d dofs bounded, bound / M_jj at most %.3g\n", GetParam().name.c_str(), finite, tree.nv,
              loosest);
  EXPECT_GT(finite, 0) << "no dof bounded";
}

INSTANTIATE_TEST_SUITE_P(All, MassDiagonalBounds, ::testing::ValuesIn(testing::all_tree_models()),
                         [](const ::testing::TestParamInfo<testing::ModelCase>& info) { return info.param.name; });

}  // namespace
}  // namespace jrgen
