// The elimination order of the constraint rows (topology::constraint_row_order)
// and the pattern of T^T T's Cholesky factor built on it (emit::SchurPattern,
// Steps 3.3-3.4), for every loop model case and for vehicle trains:
//   - the order is a permutation, and its factor costs no more than the
//     natural (cut, row) order's;
//   - the factor pattern equals a dense symbolic elimination in that order,
//     starting from T^T T's structural non-zeros computed independently
//     (rows r, s coupled when their cuts' Lemma 3 dof lists intersect):
//     every fill entry is accounted for and none is spurious;
//   - for trains the cost of Step 3 is linear in the number of vehicles;
//   - the sparse row selection keeps every row of a train (16 per vehicle,
//     3 per hitch).
#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>

#include "analysis/constraints.hpp"
#include "common/model_cases.hpp"
#include "common/random_model.hpp"
#include "emit/loops.hpp"
#include "topology/topology.hpp"
#include "urdf/urdf_reader.hpp"

namespace jrgen {
namespace {

topology::Tree analyzed_tree(const ir::Robot& robot) {
  topology::Tree tree = topology::build_tree(robot);
  analysis::analyze_constraints(robot, tree, false);
  return tree;
}

ir::Robot train_robot(int vehicles) {
  const std::string dir = std::string(JRGEN_SOURCE_DIR) + "/models/";
  const testing::ModelWithCuts t = testing::vehicle_train(vehicles, testing::read_text(dir + "hmmwv14.urdf"),
                                                          testing::read_text(dir + "hmmwv14.cuts.xml"));
  return testing::read_model_case({"train_" + std::to_string(vehicles), t.urdf, t.cuts});
}

void check_pattern(const topology::Tree& tree) {
  const emit::SchurPattern sp = emit::schur_pattern(tree);
  const int m = sp.m;
  ASSERT_EQ(m, tree.nc());
  std::vector<int> sorted = sp.order;
  std::sort(sorted.begin(), sorted.end());
  for (int i = 0; i < m; ++i) ASSERT_EQ(sorted[i], i) << "order is not a permutation";

  // Kept row -> cut, independently of the emitter.
  std::vector<int> cut_of_row;
  for (std::size_t c = 0; c < tree.cuts.size(); ++c)
    for (std::size_t r = 0; r < tree.cuts[c].kept_rows.size(); ++r) cut_of_row.push_back(static_cast<int>(c));
  auto coupled = [&](int a, int b) {
    const std::vector<int>& x = tree.cuts[cut_of_row[a]].dofs;
    const std::vector<int>& y = tree.cuts[cut_of_row[b]].dofs;
    std::vector<int> common;
    std::set_intersection(x.begin(), x.end(), y.begin(), y.end(), std::back_inserter(common));
    return !common.empty();
  };
  // Dense symbolic elimination in the order's positions.
  std::vector<std::vector<char>> B(m, std::vector<char>(m, 0));
  std::vector<std::vector<char>> structural(m, std::vector<char>(m, 0));
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j) B[i][j] = structural[i][j] = coupled(sp.order[i], sp.order[j]);
  for (int k = 0; k < m; ++k)
    for (int i = k + 1; i < m; ++i)
      if (B[i][k])
        for (int j = k + 1; j < m; ++j)
          if (B[j][k]) B[i][j] = B[j][i] = 1;
  for (int j = 0; j < m; ++j) {
    std::vector<int> expected;
    for (int i = j + 1; i < m; ++i)
      if (B[i][j]) expected.push_back(i);
    EXPECT_EQ(sp.pattern[j], expected) << "column " << j;
    ASSERT_EQ(sp.structural[j].size(), sp.pattern[j].size());
    for (std::size_t e = 0; e < sp.pattern[j].size(); ++e)
      EXPECT_EQ(static_cast<bool>(sp.structural[j][e]), static_cast<bool>(structural[sp.pattern[j][e]][j]))
          << "entry (" << sp.pattern[j][e] << ", " << j << ")";
  }

  std::vector<int> rows_per_cut;
  for (const topology::Cut& c : tree.cuts) rows_per_cut.push_back(static_cast<int>(c.kept_rows.size()));
  const topology::RowOrder order = topology::constraint_row_order(tree, rows_per_cut);
  EXPECT_EQ(order.order, sp.order);
  if (order.natural_ops >= 0) EXPECT_LE(order.ops, order.natural_ops);
}

class SchurOrder : public ::testing::TestWithParam<testing::ModelCase> {};

TEST_P(SchurOrder, FactorPatternIsTheSymbolicElimination) {
  check_pattern(analyzed_tree(testing::read_model_case(GetParam())));
}

INSTANTIATE_TEST_SUITE_P(Loops, SchurOrder, ::testing::ValuesIn(testing::loop_models()),
                         [](const ::testing::TestParamInfo<testing::ModelCase>& info) { return info.param.name; });

// A train whose cuts come in an order hostile to the natural elimination
// (hitches first, then the vehicles from both ends inwards): minimum degree
// must win, and its pattern must still be exact.
TEST(SchurOrderTrain, ShuffledCutsStillGiveAnExactPattern) {
  ir::Robot robot = train_robot(6);
  std::vector<ir::CutJoint> hitches, vehicles;
  for (const ir::CutJoint& c : robot.cuts) (c.name.rfind("hitch_", 0) == 0 ? hitches : vehicles).push_back(c);
  std::vector<ir::CutJoint> shuffled = hitches;
  for (std::size_t a = 0, b = vehicles.size(); a < b; ++a) {
    shuffled.push_back(vehicles[a]);
    if (a + 1 < b) shuffled.push_back(vehicles[--b]);
  }
  robot.cuts = shuffled;
  const topology::Tree tree = analyzed_tree(robot);
  check_pattern(tree);
  std::vector<int> rows_per_cut;
  for (const topology::Cut& c : tree.cuts) rows_per_cut.push_back(static_cast<int>(c.kept_rows.size()));
  const topology::RowOrder order = topology::constraint_row_order(tree, rows_per_cut);
  EXPECT_TRUE(order.minimum_degree) << "ops " << order.ops << ", natural " << order.natural_ops;
  EXPECT_TRUE(order.natural_ops < 0 || order.ops < order.natural_ops);
}

// Lemma 3 on a train: every T^T T entry couples cuts of one vehicle or of two
// hitched ones, so the cost of Steps 3.3-3.4 per vehicle is constant.
TEST(SchurOrderTrain, FactorCostIsLinearInTheNumberOfVehicles) {
  std::vector<long long> ops, nnz;
  for (int k : {3, 4, 5, 6}) {
    const topology::Tree tree = analyzed_tree(train_robot(k));
    EXPECT_EQ(tree.nc(), 16 * k + 3 * (k - 1));  // every row kept
    const emit::SchurPattern sp = emit::schur_pattern(tree);
    std::vector<int> rows_per_cut;
    for (const topology::Cut& c : tree.cuts) rows_per_cut.push_back(static_cast<int>(c.kept_rows.size()));
    ops.push_back(topology::constraint_row_order(tree, rows_per_cut).ops);
    nnz.push_back(sp.nnz());
  }
  for (std::size_t i = 2; i < ops.size(); ++i) {
    EXPECT_EQ(ops[i] - ops[i - 1], ops[1] - ops[0]) << "factor cost not linear in the vehicles";
    EXPECT_EQ(nnz[i] - nnz[i - 1], nnz[1] - nnz[0]) << "factor size not linear in the vehicles";
  }
}

}  // namespace
}  // namespace jrgen
