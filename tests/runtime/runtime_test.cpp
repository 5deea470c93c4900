// The runtime (6-D spatial algebra in body frames, Lemma 2 order, packed M)
// against the independent world-frame reference (tests/reference), on every
// tree model: M, h, the kinetic energy of Corollary 2, and the no-fill-in
// property of Lemma 2 on the computed factor.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <random>

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

std::string case_name(const ::testing::TestParamInfo<testing::ModelCase>& info) {
  std::string n = info.param.name;
  for (char& c : n)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return n;
}

INSTANTIATE_TEST_SUITE_P(AllTrees, RuntimeVsReference, ::testing::ValuesIn(testing::all_tree_models()),
                         case_name);

}  // namespace
}  // namespace jrgen
