// The runtime (6-D spatial algebra in body frames, Lemma 2 order, packed M)
// against the independent world-frame reference (tests/reference), on every
// tree model: M, h, the kinetic energy of Corollary 2, and the no-fill-in
// property of Lemma 2 on the computed factor.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "analysis/runtime_model.hpp"
#include "common/model_cases.hpp"
#include "common/tolerance.hpp"
#include "reference/reference_dynamics.hpp"
#include "topology/topology.hpp"
#include "urdf/urdf_reader.hpp"

namespace jrgen {
namespace {

using testing::kEps;
using testing::relative_error;

struct Fixture {
  ir::Robot robot;
  topology::Tree tree;
  std::unique_ptr<analysis::RuntimeModel> rt;
  Eigen::Vector3d gravity{0.3, -0.2, -9.81};  // off-axis, to exercise every component

  explicit Fixture(const testing::ModelCase& c)
      : robot(urdf::read_robot_string(c.urdf, c.name + ".urdf")), tree(topology::build_tree(robot)) {
    rt = std::make_unique<analysis::RuntimeModel>(tree, gravity);
  }

  Eigen::MatrixXd mass_matrix(const Eigen::VectorXd& q) {
    Eigen::VectorXd Mp(tree.nnz());
    Eigen::MatrixXd M(tree.nv, tree.nv);
    jr::kinematics(rt->model(), rt->workspace(), q.data());
    jr::mass_matrix_packed(rt->model(), rt->workspace(), Mp.data());
    jr::unpack_mass_matrix(rt->model(), Mp.data(), M.data());
    return M;
  }

  // h in user order.
  Eigen::VectorXd bias(const Eigen::VectorXd& q, const Eigen::VectorXd& v) {
    Eigen::VectorXd h_lem(tree.nv), h(tree.nv);
    jr::kinematics(rt->model(), rt->workspace(), q.data());
    jr::bias_forces(rt->model(), rt->workspace(), v.data(), h_lem.data(), true, true);
    for (int j = 0; j < tree.nv; ++j) h[tree.dof_user[j]] = h_lem[j];
    return h;
  }
};

class RuntimeVsReference : public ::testing::TestWithParam<testing::ModelCase> {};

// Same mathematics by two routes: both sum O(depth) products of O(1) terms,
// so they agree to a small multiple of depth * eps normwise; 1e-11 leaves a
// margin of ~1e3 over eps for the deepest (500-body) trees.
constexpr double kSameMath = 1e-11;

TEST_P(RuntimeVsReference, MassMatrixBiasForcesAndEnergy) {
  Fixture f(GetParam());
  std::mt19937_64 rng(42);
  for (int trial = 0; trial < 3; ++trial) {
    const Eigen::VectorXd q = reference::random_configuration(f.robot, rng);
    const Eigen::VectorXd v = reference::random_velocity(f.robot, rng);
    const Eigen::MatrixXd M = f.mass_matrix(q);
    const Eigen::MatrixXd M_ref = reference::mass_matrix(f.robot, q);
    EXPECT_LE(relative_error(M, M_ref), kSameMath) << "M, trial " << trial;
    EXPECT_EQ(M, M.transpose());

    const Eigen::VectorXd h = f.bias(q, v);
    const Eigen::VectorXd h_ref = reference::bias_forces(f.robot, q, v, f.gravity);
    EXPECT_LE(relative_error(h, h_ref, 1.0), kSameMath) << "h, trial " << trial;

    // Corollary 2: 1/2 v^T M v is the sum of the bodies' kinetic energies.
    const double T = 0.5 * v.dot(M * v);
    const double T_ref = reference::kinetic_energy(f.robot, q, v);
    EXPECT_NEAR(T, T_ref, kSameMath * std::max(1.0, T_ref)) << "kinetic energy, trial " << trial;
  }
}

TEST_P(RuntimeVsReference, PackedLayoutRoundTrip) {
  Fixture f(GetParam());
  std::mt19937_64 rng(7);
  const Eigen::MatrixXd M = f.mass_matrix(reference::random_configuration(f.robot, rng));
  Eigen::VectorXd Mp(f.tree.nnz());
  jr::pack_mass_matrix(f.rt->model(), M.data(), Mp.data());
  Eigen::MatrixXd back(f.tree.nv, f.tree.nv);
  jr::unpack_mass_matrix(f.rt->model(), Mp.data(), back.data());
  EXPECT_EQ(back, M);
}

// Lemma 2: with descendants numbered before ancestors the Cholesky factor of
// M has no fill-in.  A dense factorization of the permuted M must leave every
// entry outside the ancestor pattern exactly zero (0 * x and sums of zeros are
// exact), and M itself must be zero there (eq. 18).
TEST_P(RuntimeVsReference, Lemma2NoFillIn) {
  Fixture f(GetParam());
  std::mt19937_64 rng(11);
  const Eigen::MatrixXd M = f.mass_matrix(reference::random_configuration(f.robot, rng));
  const int nv = f.tree.nv;
  Eigen::MatrixXd M_lem(nv, nv);
  for (int r = 0; r < nv; ++r)
    for (int c = 0; c < nv; ++c) M_lem(r, c) = M(f.tree.dof_user[r], f.tree.dof_user[c]);
  Eigen::LLT<Eigen::MatrixXd> llt(M_lem);
  ASSERT_EQ(llt.info(), Eigen::Success);
  const Eigen::MatrixXd L = llt.matrixL();
  Eigen::MatrixXi pattern = Eigen::MatrixXi::Zero(nv, nv);
  for (int c = 0; c < nv; ++c) {
    pattern(c, c) = 1;
    for (int r : f.tree.ancestors(c)) pattern(r, c) = 1;
  }
  int fill = 0, stored = 0;
  for (int c = 0; c < nv; ++c)
    for (int r = c; r < nv; ++r) {
      if (pattern(r, c)) {
        ++stored;
      } else {
        EXPECT_EQ(M_lem(r, c), 0.0) << "M(" << r << "," << c << ")";
        if (L(r, c) != 0.0) ++fill;
      }
    }
  EXPECT_EQ(fill, 0);
  EXPECT_EQ(stored, f.tree.nnz());
}

// The table-driven Steps 1, 2, 4 of the runtime (factor_packed, and the row
// tables of fill_packed_rows for forward_packed / backward_packed) against a
// dense Eigen solve, in L L^T and L D L^T; the row tables against the
// topology's ancestor lists.
TEST_P(RuntimeVsReference, TableDrivenStepsMatchDenseSolve) {
  Fixture f(GetParam());
  std::mt19937_64 rng(13);
  const int nv = f.tree.nv, nnz = f.tree.nnz();
  const Eigen::MatrixXd M = f.mass_matrix(reference::random_configuration(f.robot, rng));
  const Eigen::VectorXd Q = Eigen::VectorXd::Random(nv);
  std::vector<std::int32_t> entry_row(nnz), row_start(nv + 1), row_entry(std::max(nnz - nv, 1)),
      row_col(row_entry.size());
  jr::fill_packed_rows(f.rt->model(), entry_row.data(), row_start.data(), row_entry.data(), row_col.data());
  // Column c stores rows c, then its ancestors in order; row r lists the
  // columns whose ancestor it is, ascending, with their positions.
  std::vector<std::vector<std::pair<int, int>>> by_row(nv);
  for (int c = 0; c < nv; ++c) {
    int k = f.tree.M_col_start[c];
    EXPECT_EQ(entry_row[k++], c);
    for (int r : f.tree.ancestors(c)) {
      EXPECT_EQ(entry_row[k], r);
      by_row[r].push_back({k++, c});
    }
  }
  ASSERT_EQ(row_start[0], 0);
  for (int r = 0; r < nv; ++r) {
    ASSERT_EQ(row_start[r + 1] - row_start[r], static_cast<int>(by_row[r].size())) << "row " << r;
    for (std::size_t i = 0; i < by_row[r].size(); ++i) {
      EXPECT_EQ(row_entry[row_start[r] + i], by_row[r][i].first);
      EXPECT_EQ(row_col[row_start[r] + i], by_row[r][i].second);
    }
  }
  const jr::PackedRows rows{entry_row.data(), row_start.data(), row_entry.data(), row_col.data()};
  Eigen::MatrixXd M_lem(nv, nv);
  Eigen::VectorXd Q_lem(nv);
  for (int r = 0; r < nv; ++r) {
    Q_lem[r] = Q[f.tree.dof_user[r]];
    for (int c = 0; c < nv; ++c) M_lem(r, c) = M(f.tree.dof_user[r], f.tree.dof_user[c]);
  }
  Eigen::LLT<Eigen::MatrixXd> llt(M_lem);
  ASSERT_EQ(llt.info(), Eigen::Success);
  const Eigen::VectorXd ref = llt.solve(Q_lem);
  // Both are backward-stable Cholesky solves: forward error <= c n eps cond(M).
  const double cond = M_lem.norm() * llt.solve(Eigen::MatrixXd::Identity(nv, nv)).norm();
  for (const bool ldlt : {false, true}) {
    Eigen::VectorXd L(nnz), Dinv(nv), z = Q_lem;
    jr::pack_mass_matrix(f.rt->model(), M.data(), L.data());
    double pivot = 0.0;
    ASSERT_EQ(jr::factor_packed(f.rt->model(), L.data(), Dinv.data(), ldlt, 1e-14, &pivot), -1);
    jr::forward_packed(f.rt->model(), rows, L.data(), Dinv.data(), ldlt, z.data());
    jr::backward_packed(f.rt->model(), rows, L.data(), Dinv.data(), ldlt, z.data());
    EXPECT_LE((z - ref).norm() / ref.norm(), 10.0 * nv * kEps * cond) << (ldlt ? "ldlt" : "llt");
  }
}

std::string case_name(const ::testing::TestParamInfo<testing::ModelCase>& info) {
  std::string n = info.param.name;
  for (char& c : n)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return n;
}

// jr::any_non_finite (the generated solvers' last check): true exactly when
// some entry is a NaN or an infinity, at every position of arrays of every
// length up to 9 (the SSE2 pairs and the odd last entry), against
// std::isfinite; the extreme finite values (the largest, the smallest
// subnormal, minus zero) never count.
TEST(AnyNonFinite, MatchesIsfiniteAtEveryPosition) {
  const double specials[] = {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::signaling_NaN(),
                             -std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                             -std::numeric_limits<double>::infinity(),  std::numeric_limits<double>::max(),
                             -std::numeric_limits<double>::max(),       std::numeric_limits<double>::denorm_min(),
                             -0.0,                                      1.0};
  for (int n = 0; n <= 9; ++n) {
    std::vector<double> x(n + 1, 0.5);  // one entry past n, never read as part of x[0..n)
    x[n] = std::numeric_limits<double>::infinity();
    EXPECT_FALSE(jr::any_non_finite(x.data(), n)) << "n " << n;
    for (int i = 0; i < n; ++i)
      for (double v : specials) {
        std::vector<double> y = x;
        y[i] = v;
        EXPECT_EQ(jr::any_non_finite(y.data(), n), !std::isfinite(v)) << "n " << n << ", x[" << i << "] = " << v;
      }
  }
}

INSTANTIATE_TEST_SUITE_P(AllTrees, RuntimeVsReference, ::testing::ValuesIn(testing::all_tree_models()),
                         case_name);

}  // namespace
}  // namespace jrgen
