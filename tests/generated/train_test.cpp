// Vehicle trains and the table-driven Step 3 (jrgen/constraint_solve.hpp):
//   - the table-driven Step 3 gives the straight-line Step 3's results on the
//     HMMWV (both methods) up to rounding: the loops do the same products,
//     summed in another order;
//   - a train whose hitch rows are made dependent (a hitch row copied onto
//     another row of the same hitch) is reported with status 2, naming the
//     hitch, straight-line and table-driven;
//   - the trains' dimensions: 27 coordinates and 16 rows per vehicle, 3 rows
//     per hitch.
// (The generated trains and table-driven solvers also run every test of
// generated_loops_test against the dense reference.)
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>
#include <string>

#include "common/model_cases.hpp"
#include "common/tolerance.hpp"
#include "generated/solver_registry.hpp"
#include "reference/reference_dynamics.hpp"

namespace jrgen {
namespace {

using testing::GeneratedSolver;

const GeneratedSolver& solver(const std::string& target) {
  for (const GeneratedSolver& s : testing::generated_solvers())
    if (s.target == target) return s;
  throw std::runtime_error("no generated solver " + target);
}

// forward_dynamics of two solvers of one model at random states.  Both are
// backward stable solves of the same system; the table-driven loops sum the
// same products in another order, so the results differ by rounding
// amplified by the conditioning of M and T^T T: c eps cond, with c eps ~1e-15
// and cond <= ~1e2 at these states.  Bound 1e-13; measured: <= 6e-15.
void expect_same_solution(const GeneratedSolver& a, const GeneratedSolver& b) {
  ASSERT_EQ(a.nv, b.nv);
  ASSERT_EQ(a.nc, b.nc);
  const ir::Robot robot = testing::read_model_case(testing::find_model_case(a.model_case));
  std::mt19937_64 rng(11);
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::VectorXd q =
        reference::integrate(robot, reference::neutral_configuration(robot), 0.1 * reference::random_velocity(robot, rng), 1.0);
    const Eigen::VectorXd v = reference::random_velocity(robot, rng);
    const Eigen::VectorXd tau = Eigen::VectorXd::Random(a.nv);
    Eigen::VectorXd qa(a.nv), qb(b.nv), la(a.nc), lb(b.nc);
    ASSERT_EQ(a.forward_dynamics(q.data(), v.data(), tau.data(), qa.data(), la.data()), 0) << a.last_error();
    ASSERT_EQ(b.forward_dynamics(q.data(), v.data(), tau.data(), qb.data(), lb.data()), 0) << b.last_error();
    EXPECT_LE(testing::relative_error(qb, qa), 1e-13) << b.target;
    EXPECT_LE(testing::relative_error(lb, la), 1e-13) << b.target;
    std::printf("%s vs %s: qdd %.2e, lambda %.2e\n", b.target.c_str(), a.target.c_str(),
                testing::relative_error(qb, qa), testing::relative_error(lb, la));
  }
}

TEST(TableDrivenStep3, MatchesStraightLineOnTheHmmwv) {
  expect_same_solution(solver("gen_loops_hmmwv14"), solver("gen_loops_hmmwv14_tables"));
  expect_same_solution(solver("gen_loops_hmmwv14_ldlt"), solver("gen_loops_hmmwv14_tables_ldlt"));
}

TEST(TableDrivenStep3, MatchesStraightLineOnATrain) {
  expect_same_solution(solver("gen_loops_train_3_ldlt"), solver("gen_loops_train_3_tables"));
}

// The last hitch's third row (point z) replaced by its first (point x): two
// equal rows of one cut, so T^T T is singular (its pivot vanishes to
// rounding) and the solver must say which loop joint.
void expect_singular_hitch(const GeneratedSolver& s) {
  const ir::Robot robot = testing::read_model_case(testing::find_model_case(s.model_case));
  const Eigen::VectorXd q = reference::neutral_configuration(robot);
  const Eigen::MatrixXd M = reference::mass_matrix(robot, q);
  Eigen::MatrixXd J(s.nc, s.nv);
  s.constraint_jacobian(q.data(), J.data());
  J.row(s.nc - 1) = J.row(s.nc - 3);  // the hitches are the last cuts, 3 rows each
  const Eigen::VectorXd Q = Eigen::VectorXd::Ones(s.nv), g = Eigen::VectorXd::Zero(s.nc);
  Eigen::VectorXd qdd(s.nv), lambda(s.nc);
  EXPECT_EQ(s.solve_augmented(M.data(), Q.data(), J.data(), g.data(), qdd.data(), lambda.data()), 2) << s.target;
  const std::string error = s.last_error();
  EXPECT_NE(error.find("constraint rows singular"), std::string::npos) << error;
  EXPECT_NE(error.find("loop joint 'hitch_"), std::string::npos) << error;
}

TEST(Trains, RedundantHitchIsReportedNamingTheHitch) {
  for (const char* target : {"gen_loops_train_2", "gen_loops_train_3_ldlt", "gen_loops_train_3_tables",
                             "gen_loops_train_2_tables_ldlt"})
    expect_singular_hitch(solver(target));
}

TEST(Trains, Dimensions) {
  for (const GeneratedSolver& s : testing::generated_solvers()) {
    if (s.model_case.rfind("loops_train_", 0) != 0) continue;
    const int k = std::stoi(s.model_case.substr(12));
    EXPECT_EQ(s.nv, 27 * k) << s.target;
    EXPECT_EQ(s.nc, 16 * k + 3 * (k - 1)) << s.target;
  }
}

}  // namespace
}  // namespace jrgen
