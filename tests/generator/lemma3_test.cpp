// Lemma 3 of Negrut, Serban & Potra (1997) on the computed T, for every loop
// model case (tests/common/model_cases: the project's mechanisms with their
// cuts and random trees with random cuts of every type).
//
// With the bodies in Lemma 2 order, M = L L^T has no fill-in and
// T = L^{-1} Phiq^T.  Lemma 3: the column of T belonging to a row of cut
// joint c can be non-zero only at the dofs on the paths from the cut's two
// bodies k and l to the base (topology::Cut::dofs).  Forward substitution on
// exact structural zeros yields exact zeros, so outside cut.dofs the entries
// must be 0.0 exactly, not merely small.
//
// The dofs on both paths (the common ancestors, cut.dofs[num_distinct..])
// move the two cut frames together rigidly, so the cut's Jacobian columns are
// zero there.  The runtime skips those entries in the packed path and in
// constraints_all_rows alike (runtime.cpp, evaluate_cuts), so the claim is
// checked independently by central differences of Phi (every row), and the
// same differences are checked to reproduce the computed entries at the
// distinct dofs (so the difference scheme is not vacuous).
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Dense>
#include <algorithm>
#include <memory>
#include <random>
#include <set>

#include "analysis/constraints.hpp"
#include "analysis/runtime_model.hpp"
#include "common/model_cases.hpp"
#include "topology/topology.hpp"
#include "urdf/urdf_reader.hpp"

namespace jrgen {
namespace {

struct LoopFixture {
  ir::Robot robot;
  topology::Tree tree;
  std::unique_ptr<analysis::RuntimeModel> rt;
  Eigen::VectorXd q;  // assembled configuration, user order
  int total_rows = 0;

  explicit LoopFixture(const testing::ModelCase& c) {
    robot = testing::read_model_case(c);
    tree = topology::build_tree(robot);
    analysis::analyze_constraints(robot, tree, /*strict=*/false);
    rt = std::make_unique<analysis::RuntimeModel>(tree, Eigen::Vector3d(0.0, 0.0, -9.81));
    for (const topology::Cut& cut : tree.cuts) total_rows += cut.rows;
    // An assembled state away from the zero configuration: a seeded step,
    // then Newton back onto Phi = 0.
    q = analysis::neutral_configuration(tree);
    std::mt19937_64 rng(17);
    std::uniform_real_distribution<double> u(-0.1, 0.1);
    Eigen::VectorXd dv(tree.nv);
    for (int i = 0; i < tree.nv; ++i) dv[i] = u(rng);
    analysis::integrate(tree, q, dv);
    residual = analysis::assemble(tree, *rt, q);
  }

  double residual = 0.0;

  // Dense M in Lemma 2 order.
  Eigen::MatrixXd mass_matrix_lem() {
    Eigen::VectorXd Mp(tree.nnz());
    Eigen::MatrixXd M_user(tree.nv, tree.nv);
    jr::kinematics(rt->model(), rt->workspace(), q.data());
    jr::mass_matrix_packed(rt->model(), rt->workspace(), Mp.data());
    jr::unpack_mass_matrix(rt->model(), Mp.data(), M_user.data());
    Eigen::MatrixXd M(tree.nv, tree.nv);
    for (int i = 0; i < tree.nv; ++i)
      for (int j = 0; j < tree.nv; ++j) M(i, j) = M_user(tree.dof_user[i], tree.dof_user[j]);
    return M;
  }

  // Dense Phiq of the kept rows (nc x nv), columns in Lemma 2 order.
  Eigen::MatrixXd jacobian_lem() {
    const int nc = tree.nc();
    Eigen::VectorXd Pp = Eigen::VectorXd::Constant(std::max(1, rt->constraints().phiq_nnz), 0.0);
    Eigen::MatrixXd P_user(nc, tree.nv);
    jr::kinematics(rt->model(), rt->workspace(), q.data());
    jr::constraint_terms(rt->model(), rt->constraints(), rt->workspace(), rt->motion(), q.data(), nullptr,
                         nullptr, Pp.data(), nullptr);
    jr::unpack_constraint_jacobian(rt->model(), rt->constraints(), Pp.data(), P_user.data());
    Eigen::MatrixXd P(nc, tree.nv);
    for (int j = 0; j < tree.nv; ++j) P.col(j) = P_user.col(tree.dof_user[j]);
    return P;
  }

  // Phi of every row of every cut at q "+" dv.
  Eigen::VectorXd phi_all(const Eigen::VectorXd& q_at) {
    Eigen::VectorXd phi(total_rows);
    jr::constraints_all_rows(rt->model(), rt->constraints(), rt->workspace(), rt->motion(), q_at.data(),
                             phi.data(), nullptr);
    return phi;
  }
};

class Lemma3 : public ::testing::TestWithParam<testing::ModelCase> {};

TEST_P(Lemma3, TIsExactlyZeroOutsideTheCutPattern) {
  LoopFixture f(GetParam());
  ASSERT_LT(f.residual, 1e-10) << "could not assemble";
  const int nv = f.tree.nv;
  const Eigen::MatrixXd M = f.mass_matrix_lem();
  const Eigen::MatrixXd P = f.jacobian_lem();
  ASSERT_EQ(P.rows(), f.tree.nc());

  Eigen::LLT<Eigen::MatrixXd> llt(M);
  ASSERT_EQ(llt.info(), Eigen::Success);
  const Eigen::MatrixXd L = llt.matrixL();
  // Precondition (Lemma 2, no fill-in): L(i, j) is exactly zero unless i is j
  // or an ancestor of j.  Without it the zeros of T below would be luck.
  for (int j = 0; j < nv; ++j) {
    std::set<int> anc;
    for (int a : f.tree.ancestors(j)) anc.insert(a);
    for (int i = j + 1; i < nv; ++i)
      if (!anc.count(i)) ASSERT_EQ(L(i, j), 0.0) << "fill-in at L(" << i << ", " << j << ")";
  }
  const Eigen::MatrixXd T = L.triangularView<Eigen::Lower>().solve(P.transpose());  // nv x nc

  int row = 0;
  for (const topology::Cut& cut : f.tree.cuts) {
    SCOPED_TRACE("loop joint '" + cut.name + "'");
    const std::set<int> pattern(cut.dofs.begin(), cut.dofs.end());
    ASSERT_TRUE(std::is_sorted(cut.dofs.begin(), cut.dofs.end())) << "cut.dofs must be in increasing Lemma 2 order";
    ASSERT_LE(cut.num_distinct, static_cast<int>(cut.dofs.size()));
    ASSERT_GT(cut.num_distinct, 0) << "k and l are different bodies, so some dof moves one frame only";
    for (std::size_t r = 0; r < cut.kept_rows.size(); ++r, ++row) {
      int inside_nonzero = 0;
      for (int i = 0; i < nv; ++i) {
        if (pattern.count(i)) {
          inside_nonzero += T(i, row) != 0.0;
        } else {
          EXPECT_EQ(T(i, row), 0.0) << "T(" << i << ", " << row << "), dof outside Lemma 3's pattern, kept row "
                                    << cut.kept_rows[r];
          EXPECT_EQ(P(row, i), 0.0) << "Phiq(" << row << ", " << i << ") outside the pattern";
        }
      }
      EXPECT_GT(inside_nonzero, 0) << "column of T for kept row " << cut.kept_rows[r] << " is all zero";
    }
  }
  EXPECT_EQ(row, f.tree.nc());
}

// Central differences with step e of a function that is constant along the
// common-ancestor directions: no truncation error, only rounding ~ eps |p| / e.
// Along the distinct dofs the truncation is ~ e^2 |Phi'''| ~ 1e-10.
TEST_P(Lemma3, JacobianIsZeroAtCommonAncestorDofs) {
  LoopFixture f(GetParam());
  ASSERT_LT(f.residual, 1e-10) << "could not assemble";
  const int nv = f.tree.nv;
  Eigen::MatrixXd P_all(f.total_rows, nv);  // user columns; common-ancestor entries left 0 by the runtime
  Eigen::VectorXd phi0(f.total_rows);
  jr::constraints_all_rows(f.rt->model(), f.rt->constraints(), f.rt->workspace(), f.rt->motion(), f.q.data(),
                           phi0.data(), P_all.data());
  const double scale = std::max(1.0, P_all.cwiseAbs().maxCoeff());
  const double e = 1e-5;
  auto fd_column = [&](int dof_lem) {
    const Eigen::VectorXd d = Eigen::VectorXd::Unit(nv, f.tree.dof_user[dof_lem]);
    Eigen::VectorXd qp = f.q, qm = f.q;
    analysis::integrate(f.tree, qp, e * d);
    analysis::integrate(f.tree, qm, -e * d);
    return Eigen::VectorXd((f.phi_all(qp) - f.phi_all(qm)) / (2 * e));
  };
  int offset = 0;
  for (const topology::Cut& cut : f.tree.cuts) {
    SCOPED_TRACE("loop joint '" + cut.name + "'");
    for (std::size_t idx = 0; idx < cut.dofs.size(); ++idx) {
      const int dof = cut.dofs[idx];
      const Eigen::VectorXd fd = fd_column(dof).segment(offset, cut.rows);
      if (static_cast<int>(idx) >= cut.num_distinct) {
        EXPECT_LE(fd.cwiseAbs().maxCoeff(), 1e-8 * scale)
            << "common-ancestor dof " << dof << " (user " << f.tree.dof_user[dof] << ") moves the cut: " << fd.transpose();
      } else {
        const Eigen::VectorXd computed = P_all.col(f.tree.dof_user[dof]).segment(offset, cut.rows);
        EXPECT_LE((fd - computed).cwiseAbs().maxCoeff(), 1e-6 * scale)
            << "distinct dof " << dof << ": fd " << fd.transpose() << " vs " << computed.transpose();
      }
    }
    offset += cut.rows;
  }
}

// The common-ancestor check above must run somewhere: some case has a cut
// whose two bodies share moving ancestors.
TEST(Lemma3Coverage, SomeCutHasCommonAncestors) {
  int with_common = 0, cuts = 0;
  for (const testing::ModelCase& c : testing::loop_models()) {
    ir::Robot robot = testing::read_model_case(c);
    const topology::Tree tree = topology::build_tree(robot);
    for (const topology::Cut& cut : tree.cuts) {
      ++cuts;
      with_common += cut.num_distinct < static_cast<int>(cut.dofs.size());
    }
  }
  EXPECT_GT(cuts, 0);
  EXPECT_GT(with_common, 0);
}

std::string case_name(const ::testing::TestParamInfo<testing::ModelCase>& info) { return info.param.name; }

INSTANTIATE_TEST_SUITE_P(LoopModels, Lemma3, ::testing::ValuesIn(testing::loop_models()), case_name);

}  // namespace
}  // namespace jrgen
