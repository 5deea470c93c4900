// topology::build_tree with MassBounds (--bound-mass, --bound-inertia;
// docs/interface.md section 1), against values worked out by hand:
//   - a body below the bounds is raised exactly to them, about its own
//     principal axes (the eigenvectors of I_com are kept);
//   - a body at or above the bounds is untouched, bit for bit;
//   - one note per raised body, naming its joint;
//   - without bounds a joint that moves no mass is an error naming the options.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <string>

#include "ir/error.hpp"
#include "topology/topology.hpp"
#include "urdf/urdf_reader.hpp"

namespace jrgen {
namespace {

// base -> j_heavy (1 kg, diag inertia) -> j_light (massless, no <inertial>)
// -> j_thin (2 kg, a rod: moments 1e-9, 0.5, 0.5 about axes turned by rpy).
const char* const kRobot = R"(<robot name="bounds">
  <link name="base"/>
  <link name="heavy"><inertial><mass value="1"/><inertia ixx="0.3" ixy="0" ixz="0" iyy="0.2" iyz="0" izz="0.1"/></inertial></link>
  <link name="light"/>
  <link name="thin"><inertial><origin rpy="0.3 -0.7 1.1"/><mass value="2"/><inertia ixx="1e-9" ixy="0" ixz="0" iyy="0.5" iyz="0" izz="0.5"/></inertial></link>
  <joint name="j_heavy" type="continuous"><parent link="base"/><child link="heavy"/><axis xyz="0 0 1"/></joint>
  <joint name="j_light" type="continuous"><parent link="heavy"/><child link="light"/><axis xyz="0 1 0"/></joint>
  <joint name="j_thin" type="continuous"><parent link="light"/><child link="thin"/><axis xyz="1 0 0"/></joint>
</robot>)";

const topology::Body& body_of(const topology::Tree& tree, const std::string& joint) {
  for (const topology::Body& b : tree.bodies)
    if (b.joint_name == joint) return b;
  throw std::runtime_error("no joint " + joint);
}

TEST(MassBounds, WithoutBoundsAMasslessChainEndIsAnErrorNamingTheOptions) {
  const char* const massless_tip = R"(<robot name="tip">
    <link name="base"/><link name="tip"/>
    <joint name="j_tip" type="continuous"><parent link="base"/><child link="tip"/></joint>
  </robot>)";
  const ir::Robot robot = urdf::read_robot_string(massless_tip, "tip.urdf");
  try {
    topology::build_tree(robot);
    FAIL() << "a joint that moves no mass must be an error";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("'j_tip'"), std::string::npos) << what;
    EXPECT_NE(what.find("--bound-mass"), std::string::npos) << what;
    EXPECT_NE(what.find("--bound-inertia"), std::string::npos) << what;
  }
  topology::MassBounds bounds;
  bounds.mass = 1e-3;
  bounds.inertia = 1e-6;
  const topology::Tree tree = topology::build_tree(robot, bounds);
  EXPECT_EQ(body_of(tree, "j_tip").inertial.mass, 1e-3);
  EXPECT_EQ(body_of(tree, "j_tip").inertial.I_com, 1e-6 * Eigen::Matrix3d::Identity());
}

TEST(MassBounds, RaisesOnlyWhatIsBelowTheBoundsAboutThePrincipalAxes) {
  const ir::Robot robot = urdf::read_robot_string(kRobot, "bounds.urdf");
  const topology::Tree plain = topology::build_tree(robot);
  topology::MassBounds bounds;
  bounds.mass = 0.01;
  bounds.inertia = 1e-4;
  const topology::Tree tree = topology::build_tree(robot, bounds);

  // Untouched: the heavy body, bit for bit.
  const ir::Inertial& heavy0 = body_of(plain, "j_heavy").inertial;
  const ir::Inertial& heavy = body_of(tree, "j_heavy").inertial;
  EXPECT_EQ(heavy.mass, heavy0.mass);
  EXPECT_EQ(heavy.com, heavy0.com);
  EXPECT_EQ(heavy.I_com, heavy0.I_com);

  // The massless body: exactly the bounds.
  const ir::Inertial& light = body_of(tree, "j_light").inertial;
  EXPECT_EQ(light.mass, 0.01);
  EXPECT_EQ(light.I_com, 1e-4 * Eigen::Matrix3d::Identity());

  // The rod: mass kept, its small moment raised to 1e-4 about the rod's own
  // axis (the x axis of its inertia frame), the two others kept.  Expected by
  // hand: R diag(1e-4, 0.5, 0.5) R^T; entries of order 0.5 carry a few
  // roundings of the eigen-decomposition and the products, so 1e-14 absolute
  // (about 50 eps x 0.5) bounds the difference.
  const ir::Inertial& thin = body_of(tree, "j_thin").inertial;
  EXPECT_EQ(thin.mass, 2.0);
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(1.1, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(-0.7, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  const Eigen::Matrix3d expected = R * Eigen::Vector3d(1e-4, 0.5, 0.5).asDiagonal() * R.transpose();
  EXPECT_LT((thin.I_com - expected).cwiseAbs().maxCoeff(), 1e-14) << thin.I_com << "\nexpected\n" << expected;
  EXPECT_EQ(thin.com, body_of(plain, "j_thin").inertial.com);

  // One note per raised body, in user order, naming the joint and the option.
  ASSERT_EQ(tree.notes.size(), 2u);
  EXPECT_NE(tree.notes[0].find("'j_light'"), std::string::npos) << tree.notes[0];
  EXPECT_NE(tree.notes[0].find("--bound-mass"), std::string::npos) << tree.notes[0];
  EXPECT_NE(tree.notes[0].find("--bound-inertia"), std::string::npos) << tree.notes[0];
  EXPECT_NE(tree.notes[1].find("'j_thin'"), std::string::npos) << tree.notes[1];
  EXPECT_EQ(tree.notes[1].find("--bound-mass"), std::string::npos) << tree.notes[1];
  EXPECT_TRUE(plain.notes.empty());
}

}  // namespace
}  // namespace jrgen
