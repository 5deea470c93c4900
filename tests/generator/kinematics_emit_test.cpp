// The specialized kinematics block (emit/kinematics.cpp, issue 20) against
// the runtime's generic jr::kinematics and the forward sweep of
// jr::bias_forces, on every tree and loop model of the suite: the Program is
// evaluated at generation time (Program::evaluate, the operations of the
// emitted code in their order), at random states.
#include "emit/kinematics.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <string>

#include "analysis/runtime_model.hpp"
#include "common/model_cases.hpp"
#include "topology/topology.hpp"

namespace {

using jrgen::emit::Program;
using jrgen::testing::ModelCase;

// A random state: angles and positions in [-2, 2], quaternions random unit
// ones scaled by up to 1.5 (the solver normalizes them), velocities in [-3, 3].
void random_state(const jrgen::topology::Tree& t, std::mt19937_64& rng, Eigen::VectorXd& q, Eigen::VectorXd& v) {
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  q = Eigen::VectorXd::NullaryExpr(t.nq, [&] { return u(rng); });
  v = 1.5 * Eigen::VectorXd::NullaryExpr(t.nv, [&] { return u(rng); });
  for (const auto& b : t.bodies) {
    const int first = b.type == jrgen::ir::JointType::Ball ? b.q_user
                      : b.type == jrgen::ir::JointType::Floating ? b.q_user + 3 : -1;
    if (first < 0) continue;
    Eigen::Vector4d quat = Eigen::Vector4d::NullaryExpr([&] { return u(rng); }).normalized();
    q.segment<4>(first) = (1.0 + 0.25 * (u(rng) + 2.0) / 4.0 * 2.0) * quat;
  }
}

class KinematicsEmit : public ::testing::TestWithParam<ModelCase> {};

// Every value is a short sum of products of factors of size about 1 (unit
// vectors, cosines, lengths of a few metres, velocities of a few units), so
// the two evaluations differ by a few ulps of the largest term: 1e-12 of the
// scale (lengths and speeds of the models are below 1e2) allows 1e4 ulps.
TEST_P(KinematicsEmit, MatchesTheRuntime) {
  const jrgen::topology::Tree tree = jrgen::topology::build_tree(jrgen::testing::read_model_case(GetParam()));
  jrgen::analysis::RuntimeModel rm(tree, Eigen::Vector3d::Zero());
  Program program("const double* q, const double* v");
  program.begin_function("kinematics", "test");
  program.begin_block("kinematics");
  const auto frames = jrgen::emit::joint_frames(program, tree);
  const auto motion = jrgen::emit::body_velocities(program, tree, frames);
  std::mt19937_64 rng(20);
  for (int trial = 0; trial < 3; ++trial) {
    Eigen::VectorXd q, v;
    random_state(tree, rng, q, v);
    const auto x = program.evaluate([&](const std::string& in) {
      const int i = std::stoi(in.substr(2, in.size() - 3));
      return in[0] == 'q' ? q[i] : v[i];
    });
    jr::kinematics(rm.model(), rm.workspace(), q.data());
    Eigen::VectorXd h(tree.nv);
    jr::bias_forces<false, false>(rm.model(), rm.workspace(), v.data(), h.data());
    double scale = 1.0;
    for (std::size_t i = 0; i < tree.bodies.size(); ++i)
      scale = std::max({scale, rm.workspace()[i].p.norm(), rm.workspace()[i].v.norm(), rm.workspace()[i].a.norm()});
    const double tol = 1e-12 * scale;
    for (std::size_t i = 0; i < tree.bodies.size(); ++i) {
      const jr::BodyState& b = rm.workspace()[i];
      SCOPED_TRACE("body " + std::to_string(i) + " '" + tree.bodies[i].joint_name + "', trial " + std::to_string(trial));
      for (int r = 0; r < 3; ++r) {
        EXPECT_NEAR(Program::value(frames[i].p[r], x), b.p[r], tol);
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(Program::value(frames[i].R[3 * r + c], x), b.R(r, c), tol);
      }
      for (int k = 0; k < tree.bodies[i].nv; ++k)
        for (int r = 0; r < 6; ++r) EXPECT_NEAR(Program::value(frames[i].S[k][r], x), b.S(r, k), tol);
      for (int r = 0; r < 6; ++r) {
        EXPECT_NEAR(Program::value(motion[i].v[r], x), b.v[r], tol);
        EXPECT_NEAR(Program::value(motion[i].a[r], x), b.a[r], tol);
      }
    }
  }
}

// The kinematics of one revolute joint with the given <axis xyz> and <origin
// rpy> (its rotation R and position p as outputs): the emitted program.
Program::Emitted one_joint_kinematics(const std::string& axis, const std::string& rpy) {
  const ModelCase c{"one_joint", R"(<robot name="one">
  <link name="base"/><link name="a"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j" type="revolute"><parent link="base"/><child link="a"/><origin rpy=")" + rpy +
                                       R"("/><axis xyz=")" + axis + R"("/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>)", ""};
  const jrgen::topology::Tree tree = jrgen::topology::build_tree(jrgen::testing::read_model_case(c));
  Program program("const double* q");
  program.begin_function("kinematics", "test");
  program.begin_block("kinematics");
  const auto frames = jrgen::emit::joint_frames(program, tree);
  for (int k = 0; k < 9; ++k) program.output("R[" + std::to_string(k) + "]", frames[0].R[k]);
  for (int k = 0; k < 3; ++k) program.output("p[" + std::to_string(k) + "]", frames[0].p[k]);
  return program.emit();
}

// Folding works: an axis-aligned revolute joint with an identity fixed frame
// costs one sine, one cosine and nothing else for its rotation and position.
TEST(KinematicsEmitFolding, AxisAlignedRevoluteCostsOnlyItsSineAndCosine) {
  const auto e = one_joint_kinematics("0 0 1", "0 0 0");
  EXPECT_EQ(e.total.trig, 2) << e.definitions;
  EXPECT_EQ(e.total.add + e.total.mul + e.total.div, 0) << e.definitions;
}

// Exporters' residues below the unit roundoff (iCub's "0 1 6.12323e-17",
// rpy 1.11022e-16 = 2^-53 rounded down) fold like exact zeros
// (topology.cpp, snap_rounding_residues); a residue one ulp above 2^-53, or a
// small but real angle, does not.
TEST(KinematicsEmitFolding, ResiduesBelowRoundoffFoldRealSmallValuesDoNot) {
  const auto snapped = one_joint_kinematics("0 1 6.12323e-17", "1.11022e-16 0 0");
  EXPECT_EQ(snapped.total.trig, 2) << snapped.definitions;
  EXPECT_EQ(snapped.total.add + snapped.total.mul, 0) << snapped.definitions;
  const auto kept_axis = one_joint_kinematics("0 1 1.1102230246251568e-16", "0 0 0");
  EXPECT_GT(kept_axis.total.add + kept_axis.total.mul, 0) << kept_axis.definitions;
  const auto kept_angle = one_joint_kinematics("0 1 0", "1e-12 0 0");
  EXPECT_GT(kept_angle.total.add + kept_angle.total.mul, 0) << kept_angle.definitions;
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

INSTANTIATE_TEST_SUITE_P(All, KinematicsEmit, ::testing::ValuesIn(cases()),
                         [](const auto& info) { return info.param.name; });

}  // namespace
