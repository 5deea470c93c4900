// The specialized mass-matrix and bias-forces blocks (emit/mass_matrix.cpp,
// emit/bias_forces.cpp, issue 20 item 1) against the runtime's generic
// jr::mass_matrix_packed and jr::bias_forces on every model the kinematics
// block is tested on, evaluated at generation time (Program::evaluate, the
// operations of the emitted code in their order), at random states; and the
// operation counts that show what specialization removes.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "analysis/runtime_model.hpp"
#include "common/model_cases.hpp"
#include "emit/bias_forces.hpp"
#include "emit/kinematics.hpp"
#include "emit/mass_matrix.hpp"
#include "topology/topology.hpp"

namespace {

using jrgen::emit::Program;
using jrgen::emit::Value;
using jrgen::testing::ModelCase;

constexpr double kEps = std::numeric_limits<double>::epsilon();
const Eigen::Vector3d kGravity(0.0, 0.0, -9.81);

// A random state: angles and positions in [-2, 2], quaternions random unit
// ones scaled by 1 to 1.5 (the solver normalizes them), velocities in [-3, 3].
void random_state(const jrgen::topology::Tree& t, std::mt19937_64& rng, Eigen::VectorXd& q, Eigen::VectorXd& v) {
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  q = Eigen::VectorXd::NullaryExpr(t.nq, [&] { return u(rng); });
  v = 1.5 * Eigen::VectorXd::NullaryExpr(t.nv, [&] { return u(rng); });
  for (const auto& b : t.bodies) {
    const int first = b.type == jrgen::ir::JointType::Ball ? b.q_user
                      : b.type == jrgen::ir::JointType::Floating ? b.q_user + 3 : -1;
    if (first < 0) continue;
    Eigen::Vector4d quat = Eigen::Vector4d::NullaryExpr([&] { return u(rng); }).normalized();
    q.segment<4>(first) = (1.0 + 0.125 * (u(rng) + 2.0)) * quat;
  }
}

Eigen::VectorXd values(const std::vector<Value>& vs, const std::vector<double>& x) {
  Eigen::VectorXd out(static_cast<Eigen::Index>(vs.size()));
  for (std::size_t i = 0; i < vs.size(); ++i) out[static_cast<Eigen::Index>(i)] = Program::value(vs[i], x);
  return out;
}

bool has_damping(const jrgen::topology::Tree& t) {
  return std::any_of(t.bodies.begin(), t.bodies.end(), [](const auto& b) { return b.damping != 0.0; });
}

class DynamicsEmit : public ::testing::TestWithParam<ModelCase> {};

// Both sides evaluate the same sums (eq. 14, 18 and Newton-Euler) in a
// different association and with constants folded in a different order, so
// they differ by rounding only: each entry of M and h is a sum along a path
// of at most nv bodies of terms no larger than the norm of the result times
// the condition of that sum (the composite inertias and the forces are sums
// of positive-definite or similar-sized terms), each term off by a few eps.
// 100 nv eps of the norm covers that with room; a wrong term (a sign, a
// missing inertia, a missing gravity or damping term) is O(1) of it.
TEST_P(DynamicsEmit, MatchesTheRuntime) {
  const jrgen::topology::Tree tree = jrgen::topology::build_tree(jrgen::testing::read_model_case(GetParam()));
  jrgen::analysis::RuntimeModel rm(tree, kGravity);
  Program program("const double* q, const double* v");
  program.begin_function("dynamics", "test");
  program.begin_block("kinematics");
  const auto frames = jrgen::emit::joint_frames(program, tree);
  const auto motion = jrgen::emit::body_velocities(program, tree, frames);
  program.begin_block("M");
  const std::vector<Value> M = jrgen::emit::mass_matrix_packed(program, tree, frames);
  program.begin_block("h");
  const std::vector<Value> h = jrgen::emit::bias_forces(program, tree, frames, motion, kGravity);
  const std::vector<Value> h0 = jrgen::emit::bias_forces(program, tree, frames, motion, Eigen::Vector3d::Zero());
  ASSERT_EQ(M.size(), static_cast<std::size_t>(tree.nnz()));
  ASSERT_EQ(h.size(), static_cast<std::size_t>(tree.nv));
  const double tol = 100.0 * tree.nv * kEps;
  const bool damping = has_damping(tree);
  std::mt19937_64 rng(21);
  for (int trial = 0; trial < 3; ++trial) {
    Eigen::VectorXd q, v;
    random_state(tree, rng, q, v);
    const auto x = program.evaluate([&](const std::string& in) {
      const int i = std::stoi(in.substr(2, in.size() - 3));
      return in[0] == 'q' ? q[i] : v[i];
    });
    jr::kinematics(rm.model(), rm.workspace(), q.data());
    Eigen::VectorXd M_ref(tree.nnz()), h_ref(tree.nv), h0_ref(tree.nv);
    jr::mass_matrix_packed(rm.model(), rm.workspace(), M_ref.data());
    jr::bias_forces(rm.model(), rm.workspace(), v.data(), h_ref.data(), true, damping);
    jr::bias_forces(rm.model(), rm.workspace(), v.data(), h0_ref.data(), false, damping);
    // The force elements (docs/interface.md 2b: models/iftomm_a05_flyball.urdf,
    // andrews_squeezer.urdf) are in the emitted h, and jr::force_elements adds them.
    if (tree.has_force_elements()) {
      Eigen::VectorXd fe = Eigen::VectorXd::Zero(tree.nv);
      jr::force_elements(rm.model(), rm.forces(), rm.workspace(), q.data(), v.data(), fe.data());
      h_ref += fe;
      h0_ref += fe;
    }
    SCOPED_TRACE("trial " + std::to_string(trial));
    EXPECT_LE((values(M, x) - M_ref).norm(), tol * M_ref.norm()) << "|M| = " << M_ref.norm();
    EXPECT_LE((values(h, x) - h_ref).norm(), tol * h_ref.norm()) << "|h| = " << h_ref.norm();
    EXPECT_LE((values(h0, x) - h0_ref).norm(), tol * h0_ref.norm()) << "|h0| = " << h0_ref.norm();
  }
}

std::vector<ModelCase> cases() {
  std::vector<ModelCase> out = jrgen::testing::project_tree_models();
  for (const ModelCase& c : jrgen::testing::external_models()) out.push_back(c);
  const std::vector<ModelCase> random = jrgen::testing::random_trees();
  for (std::size_t i = 0; i < random.size() && i < 8; ++i) out.push_back(random[i]);
  for (const ModelCase& c : jrgen::testing::loop_models())
    if (c.name.find("train") == std::string::npos) out.push_back(c);
  return out;
}

INSTANTIATE_TEST_SUITE_P(All, DynamicsEmit, ::testing::ValuesIn(cases()),
                         [](const auto& info) { return info.param.name; });

// ---- What specialization removes ------------------------------------------------

// A chain of three revolute joints about `axis`, offsets along z, off-centre masses.
std::string chain_urdf(const std::string& axis) {
  std::string links = R"(<link name="base"/>)", joints;
  for (int i = 1; i <= 3; ++i) {
    const std::string parent = i == 1 ? "base" : "l" + std::to_string(i - 1), child = "l" + std::to_string(i);
    links += "<link name=\"" + child + R"("><inertial><origin xyz="0.1 0.02 0.2"/><mass value="1"/>)"
             R"(<inertia ixx="0.1" iyy="0.2" izz="0.3" ixy="0.01" ixz="0" iyz="0"/></inertial></link>)";
    joints += "<joint name=\"j" + std::to_string(i) + R"(" type="revolute"><parent link=")" + parent +
              R"("/><child link=")" + child + R"("/><origin xyz="0 0 0.5"/><axis xyz=")" + axis +
              R"("/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>)";
  }
  return "<robot name=\"chain\">" + links + joints + "</robot>";
}

// The operations of block "M", "h" or "kinematics" of the chain, or of all
// three (block "all": without gravity h uses the kinematics block's
// accelerations, so their cost moves between blocks).
long long dynamics_ops(const std::string& axis, const Eigen::Vector3d& gravity, const std::string& block) {
  const jrgen::topology::Tree tree =
      jrgen::topology::build_tree(jrgen::testing::read_model_case({"chain", chain_urdf(axis), ""}));
  Program program("const double* q, const double* v, double* M, double* h");
  program.begin_function("dynamics", "test");
  program.begin_block("kinematics");
  const auto frames = jrgen::emit::joint_frames(program, tree);
  const auto motion = jrgen::emit::body_velocities(program, tree, frames);
  program.begin_block("M");
  const std::vector<Value> M = jrgen::emit::mass_matrix_packed(program, tree, frames);
  for (std::size_t k = 0; k < M.size(); ++k) program.output("M[" + std::to_string(k) + "]", M[k]);
  program.begin_block("h");
  const std::vector<Value> h = jrgen::emit::bias_forces(program, tree, frames, motion, gravity);
  for (std::size_t k = 0; k < h.size(); ++k) program.output("h[" + std::to_string(k) + "]", h[k]);
  long long ops = 0;
  for (const auto& [name, c] : program.count())
    if (name == block || block == "all") ops += c.add + c.mul + c.div + c.sqrt + c.trig;
  return ops;
}

// Axis-aligned joints (most URDFs) make the rotations and the motion
// subspaces sparse: M and h cost fewer operations than about a skew axis.
TEST(DynamicsEmitFolding, AxisAlignedJointsCostLess) {
  for (const char* block : {"M", "all"}) {
    const long long aligned = dynamics_ops("0 1 0", kGravity, block), skew = dynamics_ops("0 0.6 0.8", kGravity, block);
    EXPECT_LT(aligned, skew) << block;
    EXPECT_GT(aligned, 0) << block;
  }
}

// At zero gravity the gravity terms vanish (and M does not change).
TEST(DynamicsEmitFolding, ZeroGravityRemovesTheGravityTerms) {
  EXPECT_LT(dynamics_ops("0 0.6 0.8", Eigen::Vector3d::Zero(), "all"), dynamics_ops("0 0.6 0.8", kGravity, "all"));
  EXPECT_EQ(dynamics_ops("0 0.6 0.8", Eigen::Vector3d::Zero(), "M"), dynamics_ops("0 0.6 0.8", kGravity, "M"));
}

}  // namespace
