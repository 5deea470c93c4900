// Run-time status codes of the generated solvers (docs/interface.md section 6;
// issue 19, items 4 and 5), on every solver of the registry:
//   - a NaN or infinity anywhere in q, v or tau gives code 3 naming the
//     coordinate and its joint; in solve_augmented's M, Q, Phiq or gamma
//     likewise (the entry named);
//   - status 0 means the digits are there: the states of issue 19 that
//     returned 0 with no correct digit (a parallelogram four-bar at its
//     change point, a four-bar at an unassembled collinear q, icub at its zero
//     state; and a constraint row scaled to rounding level on the dense Schur
//     path) now give code 2 or 1 naming the loop joint and row or the joint,
//     on every shape of the solve (LLT, LDLT, --divide, table-driven Steps
//     1, 2, 4 and Step 3);
//   - no false alarm: the spread of M's pivots (d_min / d_max, the quantity
//     the solvers test against 1e-13) on every model at random states, and of
//     T^T T's at assembled ones, printed with its margin to the limit.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>

#include "common/model_cases.hpp"
#include "generated/solver_registry.hpp"
#include "reference/reference_dynamics.hpp"

namespace jrgen {
namespace {

using testing::GeneratedSolver;
using MatrixXld = Eigen::Matrix<long double, Eigen::Dynamic, Eigen::Dynamic>;

constexpr double kSpreadLimit = 1e-13;  // templates/solver.cpp.tmpl

// The joint (user order) of entry i of q or v.
int joint_of(const GeneratedSolver& s, const int* first, int i) {
  int j = s.njoints - 1;
  while (j > 0 && first[j] > i) --j;
  return j;
}

// Up to 8 indices spread over 0..n-1, the last included.
std::vector<int> sample(int n) {
  std::vector<int> out;
  const int step = std::max(1, n / 8);
  for (int i = 0; i < n; i += step) out.push_back(i);
  if (out.back() != n - 1) out.push_back(n - 1);
  return out;
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// d_min / d_max of the pivots of L D L^T (long double, no pivoting) of the
// symmetric positive definite A eliminated in the order `order`.
long double pivot_spread(const MatrixXld& A, const std::vector<int>& order) {
  const int n = static_cast<int>(A.rows());
  MatrixXld B(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) B(i, j) = A(order[i], order[j]);
  long double lo = std::numeric_limits<long double>::max(), hi = 0;
  for (int k = 0; k < n; ++k) {
    const long double d = B(k, k);
    lo = std::min(lo, d);
    hi = std::max(hi, d);
    for (int i = k + 1; i < n; ++i)
      for (int j = k + 1; j < n; ++j) B(i, j) -= B(i, k) * B(k, j) / d;
  }
  return lo / hi;
}

class Status : public ::testing::TestWithParam<GeneratedSolver> {
 protected:
  void SetUp() override { robot_ = testing::read_model_case(testing::find_model_case(GetParam().model_case)); }
  ir::Robot robot_;
};

TEST_P(Status, NonFiniteStateGivesCode3NamingTheCoordinate) {
  const GeneratedSolver& s = GetParam();
  const Eigen::VectorXd q0 = reference::neutral_configuration(robot_);
  const Eigen::VectorXd v0 = Eigen::VectorXd::Constant(s.nv, 0.1), tau0 = Eigen::VectorXd::Constant(s.nv, 0.2);
  Eigen::VectorXd qdd(s.nv), lambda(std::max(s.nc, 1));
  const double bad_values[] = {std::nan(""), std::numeric_limits<double>::infinity(),
                               -std::numeric_limits<double>::infinity()};
  for (const char* what : {"q", "v", "tau"}) {
    const bool is_q = std::string(what) == "q";
    for (int i : sample(is_q ? s.nq : s.nv)) {
      // Every v[i] too, also one that no term reads (the IFToMM pendulum's
      // single revolute): forward_dynamics tests v up front.
      for (double bad : bad_values) {
        Eigen::VectorXd q = q0, v = v0, tau = tau0;
        (is_q ? q : std::string(what) == "v" ? v : tau)[i] = bad;
        EXPECT_EQ(s.forward_dynamics(q.data(), v.data(), tau.data(), qdd.data(), lambda.data()), 3)
            << what << "[" << i << "] = " << bad << ": " << s.last_error();
        const std::string joint = s.joint_names[joint_of(s, is_q ? s.joint_q_index : s.joint_v_index, i)];
        // Names print with at most 160 characters (the solvers' g_error).
        const std::string expected = std::string("non-finite input ") + what + "[" + std::to_string(i) +
                                     "] (joint '" + (joint.size() > 160 ? joint.substr(0, 160) : joint + "')");
        EXPECT_TRUE(contains(s.last_error(), expected)) << s.last_error() << "\nexpected: " << expected;
      }
    }
  }
  // And a finite state still succeeds, with the message cleared (icub's
  // neutral state is singular: SingularStates.Icub*).
  if (s.model_case == "ext_icub") return;
  EXPECT_EQ(s.forward_dynamics(q0.data(), v0.data(), tau0.data(), qdd.data(), lambda.data()), 0) << s.last_error();
  EXPECT_STREQ(s.last_error(), "");
}

TEST_P(Status, NonFiniteMatrixInputGivesCode3NamingTheEntry) {
  const GeneratedSolver& s = GetParam();
  std::mt19937_64 rng(3);
  const Eigen::VectorXd q = reference::neutral_configuration(robot_);
  const Eigen::MatrixXd M0 = reference::mass_matrix(robot_, q);
  Eigen::MatrixXd J0(s.nc, s.nv);
  if (s.nc > 0) s.constraint_jacobian(q.data(), J0.data());
  const Eigen::VectorXd Q0 = Eigen::VectorXd::Ones(s.nv), g0 = Eigen::VectorXd::Zero(s.nc);
  Eigen::VectorXd qdd(s.nv), lambda(std::max(s.nc, 1));
  auto run = [&](const Eigen::MatrixXd& M, const Eigen::VectorXd& Q, const Eigen::MatrixXd& J,
                 const Eigen::VectorXd& g, const std::string& expected) {
    EXPECT_EQ(s.solve_augmented(M.data(), Q.data(), s.nc ? J.data() : nullptr, s.nc ? g.data() : nullptr,
                                qdd.data(), s.nc ? lambda.data() : nullptr),
              3)
        << expected;
    EXPECT_TRUE(contains(s.last_error(), expected)) << s.last_error() << "\nexpected: " << expected;
  };
  for (int i : sample(s.nv)) {
    Eigen::MatrixXd M = M0;
    M(i, i) = std::nan("");  // a diagonal entry: always read
    run(M, Q0, J0, g0, "non-finite input M(" + std::to_string(i) + ", " + std::to_string(i) + ")");
    Eigen::VectorXd Q = Q0;
    Q[i] = std::numeric_limits<double>::infinity();
    run(M0, Q, J0, g0, "non-finite input Q[" + std::to_string(i) + "]");
  }
  for (int r = 0; r < s.nc; ++r) {
    Eigen::Index c = 0;
    J0.row(r).cwiseAbs().maxCoeff(&c);  // a structurally non-zero entry
    Eigen::MatrixXd J = J0;
    J(r, c) = std::nan("");
    run(M0, Q0, J, g0, "non-finite input Phiq(" + std::to_string(r) + ", " + std::to_string(c) + ")");
    Eigen::VectorXd g = g0;
    g[r] = -std::numeric_limits<double>::infinity();
    run(M0, Q0, J0, g, "non-finite input gamma at loop joint '");
  }
}

// No false alarm: the spread of M's pivots in a Lemma 2 order (the reversed
// user order: descendants first; a tree's pivots do not depend on which such
// order), at random states, stays well above the limit.  Printed.
TEST_P(Status, PivotSpreadOfMIsFarFromTheLimit) {
  const GeneratedSolver& s = GetParam();
  std::mt19937_64 rng(5);
  std::vector<int> order(s.nv);
  for (int i = 0; i < s.nv; ++i) order[i] = s.nv - 1 - i;
  long double worst = 1;
  for (int trial = 0; trial < 3; ++trial) {
    const Eigen::VectorXd q = reference::random_configuration(robot_, rng);
    const Eigen::MatrixXd M = reference::mass_matrix(robot_, q);
    worst = std::min(worst, pivot_spread(M.cast<long double>(), order));
  }
  std::printf("%s: spread of M's pivots %.2Le (limit %.0e)\n", s.target.c_str(), worst, kSpreadLimit);
  EXPECT_GT(worst, 1000 * kSpreadLimit);
}

std::string test_name(const ::testing::TestParamInfo<GeneratedSolver>& info) { return info.param.target; }

INSTANTIATE_TEST_SUITE_P(All, Status, ::testing::ValuesIn(testing::generated_solvers()), test_name);

// ---- The states of issue 19 that returned 0 without digits ---------------------

std::vector<GeneratedSolver> solvers_of(const std::string& model_case) {
  std::vector<GeneratedSolver> out;
  for (const GeneratedSolver& s : testing::generated_solvers())
    if (s.model_case == model_case && s.target.find("_proximal") == std::string::npos)
      out.push_back(s);  // --singular proximal solvers: tests/generated/singular_test.cpp
  return out;
}

// forward_dynamics at (q, v = 0, tau) must fail with `code`, naming `where`.
void expect_failure(const GeneratedSolver& s, const Eigen::VectorXd& q, int code, const std::string& where) {
  Eigen::VectorXd v = Eigen::VectorXd::Zero(s.nv), tau(s.nv), qdd(s.nv), lambda(std::max(s.nc, 1));
  for (int i = 0; i < s.nv; ++i) tau[i] = 0.3 * std::sin(1.0 + i);
  const int status = s.forward_dynamics(q.data(), v.data(), tau.data(), qdd.data(), lambda.data());
  std::printf("%s: status %d, %s\n", s.target.c_str(), status, s.last_error());
  EXPECT_EQ(status, code) << s.target;
  EXPECT_TRUE(contains(s.last_error(), "singular to working precision")) << s.last_error();
  EXPECT_TRUE(contains(s.last_error(), where)) << s.last_error();
}

// All bars 1 m: at q = (pi/2, -pi/2, pi/2) the bars lie on the x axis, the
// loop is closed (|Phi| ~ 1e-16), and Phiq's singular values are 2.45 and
// ~1e-17: T^T T's diagonal entry of the vanishing row is ~1e-32 of the other.
TEST(SingularStates, ParallelogramAtItsChangePointGivesCode2) {
  const std::vector<GeneratedSolver> solvers = solvers_of("loops_parallelogram");
  ASSERT_GE(solvers.size(), 8u);
  for (const GeneratedSolver& s : solvers) {
    const Eigen::Vector3d q(M_PI / 2, -M_PI / 2, M_PI / 2);
    Eigen::VectorXd phi(s.nc);
    s.constraints(q.data(), phi.data());
    EXPECT_LT(phi.cwiseAbs().maxCoeff(), 1e-15);
    Eigen::MatrixXd J(s.nc, s.nv);
    s.constraint_jacobian(q.data(), J.data());
    const Eigen::VectorXd sv = Eigen::JacobiSVD<Eigen::MatrixXd>(J).singularValues();
    EXPECT_LT(sv[1], 1e-15 * sv[0]);
    expect_failure(s, q, 2, "loop joint 'joint_D' row");
  }
}

// The crank-rocker four-bar with all three bars turned onto the x axis:
// D lands at x = 2.43 instead of 1.2 (not assembled), and the cut's x row
// has only rounding-level entries.
TEST(SingularStates, FourbarCollinearUnassembledGivesCode2) {
  const std::vector<GeneratedSolver> solvers = solvers_of("loops_fourbar");
  ASSERT_GE(solvers.size(), 4u);
  const double a = std::atan2(0.4, 0.3), b = std::atan2(0.5, 0.9);
  const Eigen::Vector3d q(-a, a - b, b + M_PI / 2);
  for (const GeneratedSolver& s : solvers) {
    Eigen::VectorXd phi(s.nc);
    s.constraints(q.data(), phi.data());
    EXPECT_GT(phi.cwiseAbs().maxCoeff(), 1.0);  // not assembled
    expect_failure(s, q, 2, "loop joint 'joint_D' row");
  }
}

// icub at its zero state: the neck's roll and yaw axes nearly coincide and
// the link between them (neck_2) has no rotational inertia: cond2(M) ~ 1e17,
// and the solve loses all but ~2 digits (0.45 % off a __float128 solve).
TEST(SingularStates, IcubAtItsZeroStateGivesCode1) {
  const std::vector<GeneratedSolver> solvers = solvers_of("ext_icub");
  ASSERT_GE(solvers.size(), 6u);
  for (const GeneratedSolver& s : solvers) {
    Eigen::VectorXd q = Eigen::VectorXd::Zero(s.nq);
    q[3] = 1.0;  // the floating base's quaternion w
    expect_failure(s, q, 1, "at joint 'neck_");
  }
}

// The dense Schur path (the HMMWV: every row reaches the chassis) and the
// table-driven Step 3: one constraint row scaled to rounding level, as a row
// that vanishes at a singular configuration leaves it (cos(pi/2) ~ 6e-17).
// The pivot of that row is as small as its own diagonal entry, so the
// per-pivot test passes; the spread test does not.
TEST(SingularStates, VanishingRowOnTheDenseAndTableSchurPathsGivesCode2) {
  for (const char* target : {"gen_loops_hmmwv14", "gen_loops_hmmwv14_ldlt", "gen_loops_hmmwv14_m15",
                             "gen_loops_hmmwv14_tables", "gen_loops_hmmwv14_tables_ldlt",
                             "gen_loops_hmmwv14_divide", "gen_loops_hmmwv14_tables124"}) {
    const GeneratedSolver* found = nullptr;
    for (const GeneratedSolver& s : testing::generated_solvers())
      if (s.target == target) found = &s;
    ASSERT_NE(found, nullptr) << target;
    const GeneratedSolver& s = *found;
    const ir::Robot robot = testing::read_model_case(testing::find_model_case(s.model_case));
    const Eigen::VectorXd q = reference::neutral_configuration(robot);
    const Eigen::MatrixXd M = reference::mass_matrix(robot, q);
    Eigen::MatrixXd J(s.nc, s.nv);
    s.constraint_jacobian(q.data(), J.data());
    const Eigen::VectorXd Q = Eigen::VectorXd::LinSpaced(s.nv, -1.0, 1.0), g = Eigen::VectorXd::Zero(s.nc);
    Eigen::VectorXd qdd(s.nv), lambda(s.nc);
    ASSERT_EQ(s.solve_augmented(M.data(), Q.data(), J.data(), g.data(), qdd.data(), lambda.data()), 0)
        << target << ": " << s.last_error();
    J.row(3) *= 1e-17;
    const int status = s.solve_augmented(M.data(), Q.data(), J.data(), g.data(), qdd.data(), lambda.data());
    std::printf("%s: status %d, %s\n", target, status, s.last_error());
    EXPECT_EQ(status, 2) << target;
    EXPECT_TRUE(contains(s.last_error(), "singular to working precision")) << s.last_error();
  }
}

// A link without inertia on a tree, as icub's neck_2 but in any solver: the
// row and column of the last dof (a leaf joint in user order) scaled by 1e-9,
// so its pivot is 1e-18 of its former value and of the largest, while equal
// to its own diagonal entry times the same factor as before.
TEST(SingularStates, ScaledDofOfATreeGivesCode1) {
  for (const GeneratedSolver& s : testing::generated_solvers(false)) {
    const ir::Robot robot = testing::read_model_case(testing::find_model_case(s.model_case));
    if (s.nv < 2 || s.model_case == "ext_icub") continue;
    std::mt19937_64 rng(2);
    Eigen::MatrixXd M = reference::mass_matrix(robot, reference::random_configuration(robot, rng));
    const int k = s.nv - 1;
    M.row(k) *= 1e-9;
    M.col(k) *= 1e-9;
    const Eigen::VectorXd Q = Eigen::VectorXd::Ones(s.nv);
    Eigen::VectorXd qdd(s.nv);
    EXPECT_EQ(s.solve_augmented(M.data(), Q.data(), nullptr, nullptr, qdd.data(), nullptr), 1) << s.target;
    EXPECT_TRUE(contains(s.last_error(), "mass matrix singular to working precision")) << s.target << ": "
                                                                                        << s.last_error();
  }
}

}  // namespace
}  // namespace jrgen
