// Tests of the URDF reader stage (generator/urdf/urdf_reader.cpp).
//
// Data: the real-world models in ../shared/models-external (read-only), small
// models written inline below, and the bad-input cases in tests/errors/:
//   <case>.urdf       read with read_robot();
//   <case>.cuts.xml   read with read_cuts() against kCutsBaseRobot below;
// each with <case>.expected holding a substring of the one-line message.
#include "urdf/urdf_reader.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "ir/error.hpp"

#ifndef JRGEN_SOURCE_DIR
#error "JRGEN_SOURCE_DIR must be defined (absolute path of the repository root)"
#endif

namespace jrgen::urdf {
namespace {

namespace fs = std::filesystem;
using ir::JointType;

const fs::path kSourceDir = JRGEN_SOURCE_DIR;
const fs::path kErrorsDir = kSourceDir / "tests" / "errors";
const fs::path kModelsDir = kSourceDir / ".." / "shared" / "models-external";

// One tolerance helper for every numeric check: absolute plus relative.
void expect_near(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& expected,
                 double tol = 1e-12) {
  ASSERT_EQ(actual.rows(), expected.rows());
  ASSERT_EQ(actual.cols(), expected.cols());
  for (Eigen::Index i = 0; i < actual.rows(); ++i)
    for (Eigen::Index j = 0; j < actual.cols(); ++j)
      EXPECT_NEAR(actual(i, j), expected(i, j), tol * (1.0 + std::abs(expected(i, j))))
          << "entry (" << i << "," << j << ")\nactual:\n"
          << actual << "\nexpected:\n"
          << expected;
}

Eigen::Matrix3d rot_x(double a) {
  Eigen::Matrix3d R;
  R << 1, 0, 0, 0, std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a);
  return R;
}
Eigen::Matrix3d rot_y(double a) {
  Eigen::Matrix3d R;
  R << std::cos(a), 0, std::sin(a), 0, 1, 0, -std::sin(a), 0, std::cos(a);
  return R;
}
Eigen::Matrix3d rot_z(double a) {
  Eigen::Matrix3d R;
  R << std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1;
  return R;
}

std::vector<std::string> joint_names(const ir::Robot& robot) {
  std::vector<std::string> names;
  for (const ir::Joint& j : robot.joints) names.push_back(j.name);
  return names;
}

const ir::Joint& joint_named(const ir::Robot& robot, const std::string& name) {
  for (const ir::Joint& j : robot.joints)
    if (j.name == name) return j;
  throw std::runtime_error("no joint " + name);
}

std::string slurp(const fs::path& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Message of the jrgen::Error thrown by `f`; fails the test when none is.
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "no jrgen::Error thrown";
  return {};
}

/// Checks the structural invariants every reader result must satisfy.
void check_invariants(const ir::Robot& robot) {
  const int nlinks = static_cast<int>(robot.links.size());
  ASSERT_GE(robot.root_link, 0);
  ASSERT_LT(robot.root_link, nlinks);
  EXPECT_EQ(robot.joints.size() + 1, robot.links.size());
  // Every link but the root is the child of exactly one joint, and joints
  // are in depth-first pre-order: a joint's parent link is the root or the
  // child of an earlier joint.
  std::vector<int> parent_count(nlinks, 0);
  std::vector<bool> reached(nlinks, false);
  reached[robot.root_link] = true;
  for (const ir::Joint& j : robot.joints) {
    ASSERT_GE(j.parent_link, 0);
    ASSERT_GE(j.child_link, 0);
    EXPECT_TRUE(reached[j.parent_link]) << j.name;
    reached[j.child_link] = true;
    ++parent_count[j.child_link];
    EXPECT_NEAR(j.axis.norm(), 1.0, 1e-12) << j.name;
    expect_near(j.origin.R.transpose() * j.origin.R, Eigen::Matrix3d::Identity());
    EXPECT_GT(j.where.line, 0) << j.name;
    EXPECT_GE(j.damping, 0.0);
  }
  for (int l = 0; l < nlinks; ++l) {
    EXPECT_EQ(parent_count[l], l == robot.root_link ? 0 : 1) << robot.links[l].name;
    EXPECT_GT(robot.links[l].where.line, 0);
    const ir::Inertial& in = robot.links[l].inertial;
    EXPECT_GE(in.mass, 0.0);
    expect_near(in.I_com, in.I_com.transpose(), 0.0);
  }
}

// ---------------------------------------------------------------------------
// Real-world models
// ---------------------------------------------------------------------------

struct ModelCounts {
  const char* file;
  const char* robot_name;
  int links, revolute, continuous, prismatic, fixed;
  int links_without_inertial;
  int mimics;  ///< <mimic> elements of joints: one constraint row each (docs/interface.md 2b)
};

// Counted independently (Python's xml.etree over the files).
const ModelCounts kModels[] = {
    {"allegro_right_hand.urdf", "allegro_hand_right", 21, 16, 0, 0, 4, 0, 0},
    {"anymal.urdf", "anymal", 78, 12, 0, 0, 65, 1, 0},
    {"baxter.urdf", "baxter", 57, 15, 0, 4, 37, 1, 2},
    {"double_pendulum.urdf", "2dof_planar", 3, 2, 0, 0, 0, 0, 0},
    {"go2.urdf", "go2_description", 31, 12, 0, 0, 18, 0, 0},
    {"icub.urdf", "iCub", 56, 32, 0, 0, 23, 0, 0},
    {"panda.urdf", "panda", 13, 7, 0, 2, 3, 0, 1},
    {"pr2.urdf", "pr2", 82, 25, 4, 1, 51, 14, 10},
    {"romeo.urdf", "romeo", 82, 55, 0, 0, 26, 0, 22},
    {"solo12.urdf", "solo", 17, 12, 0, 0, 4, 0, 0},
    {"talos_full_v2.urdf", "talos", 60, 44, 0, 0, 15, 0, 12},
    {"ur5_robot.urdf", "ur5", 11, 6, 0, 0, 4, 1, 0},
};

TEST(UrdfReader, EveryExternalModelIsCovered) {
  std::vector<std::string> on_disk;
  for (const auto& entry : fs::directory_iterator(kModelsDir))
    if (entry.path().extension() == ".urdf") on_disk.push_back(entry.path().filename().string());
  std::sort(on_disk.begin(), on_disk.end());
  std::vector<std::string> listed;
  for (const ModelCounts& m : kModels) listed.push_back(m.file);
  std::sort(listed.begin(), listed.end());
  EXPECT_EQ(on_disk, listed);
}

TEST(UrdfReader, ExternalModels) {
  for (const ModelCounts& m : kModels) {
    SCOPED_TRACE(m.file);
    const std::string path = (kModelsDir / m.file).string();
    testing::internal::CaptureStdout();
    testing::internal::CaptureStderr();
    ir::Robot robot;
    std::string error;
    try {
      robot = read_robot(path);
    } catch (const Error& e) {
      error = e.what();
    }
    const std::string out = testing::internal::GetCapturedStdout();
    const std::string err = testing::internal::GetCapturedStderr();
    ASSERT_EQ(error, "");
    EXPECT_EQ(out, "") << "the reader must not print";
    EXPECT_EQ(err, "") << "the reader must not print (console_bridge silenced)";

    EXPECT_EQ(robot.name, m.robot_name);
    EXPECT_EQ(robot.source_file, path);
    EXPECT_EQ(static_cast<int>(robot.links.size()), m.links);
    std::map<JointType, int> count;
    for (const ir::Joint& j : robot.joints) ++count[j.type];
    EXPECT_EQ(count[JointType::Revolute], m.revolute);
    EXPECT_EQ(count[JointType::Continuous], m.continuous);
    EXPECT_EQ(count[JointType::Prismatic], m.prismatic);
    EXPECT_EQ(count[JointType::Fixed], m.fixed);
    EXPECT_EQ(robot.nv(), m.revolute + m.continuous + m.prismatic);
    EXPECT_EQ(robot.nq(), robot.nv());
    int massless = 0;
    for (const ir::Link& l : robot.links)
      if (l.inertial.mass == 0.0 && l.inertial.I_com.isZero(0.0)) ++massless;
    EXPECT_GE(massless, m.links_without_inertial);
    int mimics = 0;
    for (const ir::CutJoint& c : robot.cuts) mimics += c.type == ir::CutType::Mimic;
    EXPECT_EQ(mimics, m.mimics);
    EXPECT_EQ(static_cast<int>(robot.cuts.size()), m.mimics);
    check_invariants(robot);
  }
}

TEST(UrdfReader, Ur5HasSixRevoluteJointsInChainOrder) {
  const ir::Robot robot = read_robot((kModelsDir / "ur5_robot.urdf").string());
  std::vector<std::string> moving;
  for (const ir::Joint& j : robot.joints)
    if (ir::joint_nv(j.type) > 0) moving.push_back(j.name);
  const std::vector<std::string> expected = {"shoulder_pan_joint", "shoulder_lift_joint",
                                             "elbow_joint",        "wrist_1_joint",
                                             "wrist_2_joint",      "wrist_3_joint"};
  EXPECT_EQ(moving, expected);
  EXPECT_EQ(robot.links[robot.root_link].name, "world");
}

TEST(UrdfReader, PandaArmThenFingers) {
  const ir::Robot robot = read_robot((kModelsDir / "panda.urdf").string());
  std::vector<std::string> moving;
  for (const ir::Joint& j : robot.joints)
    if (ir::joint_nv(j.type) > 0) moving.push_back(j.name);
  const std::vector<std::string> expected = {
      "panda_joint1", "panda_joint2", "panda_joint3",        "panda_joint4",       "panda_joint5",
      "panda_joint6", "panda_joint7", "panda_finger_joint1", "panda_finger_joint2"};
  EXPECT_EQ(moving, expected);
  EXPECT_EQ(joint_named(robot, "panda_finger_joint2").type, JointType::Prismatic);
  EXPECT_EQ(joint_named(robot, "panda_joint4").type, JointType::Revolute);
}

// ---------------------------------------------------------------------------
// Small hand-written models
// ---------------------------------------------------------------------------

// A branching tree whose joints are written out of tree order.
// base -+- j_b (doc 2) -> b -- j_e (doc 5) -> e
//       +- j_a (doc 3) -> a -+- j_c (doc 1) -> c
//                            +- j_d (doc 4) -> d
const char* const kBranchingTree = R"(<?xml version="1.0"?>
<robot name="branching">
  <link name="c"/>
  <link name="base"/>
  <link name="a"/>
  <link name="b"/>
  <link name="d"/>
  <link name="e"/>
  <joint name="j_c" type="revolute">
    <parent link="a"/><child link="c"/><axis xyz="0 0 1"/>
  </joint>
  <joint name="j_b" type="prismatic">
    <parent link="base"/><child link="b"/><axis xyz="0 2 0"/>
  </joint>
  <joint name="j_a" type="continuous">
    <parent link="base"/><child link="a"/>
  </joint>
  <joint name="j_d" type="fixed">
    <parent link="a"/><child link="d"/>
  </joint>
  <joint name="j_e" type="revolute">
    <parent link="b"/><child link="e"/>
    <dynamics damping="0.25" friction="1"/>
  </joint>
</robot>
)";

TEST(UrdfReader, UserOrderIsDepthFirstWithSiblingsInDocumentOrder) {
  const ir::Robot robot = read_robot_string(kBranchingTree, "branching.urdf");
  EXPECT_EQ(robot.name, "branching");
  EXPECT_EQ(robot.source_file, "branching.urdf");
  // Links stay in document order.
  ASSERT_EQ(robot.links.size(), 6u);
  EXPECT_EQ(robot.links[0].name, "c");
  EXPECT_EQ(robot.links[1].name, "base");
  EXPECT_EQ(robot.root_link, 1);
  EXPECT_EQ(robot.links[0].where.file, "branching.urdf");
  EXPECT_EQ(robot.links[0].where.line, 3);
  // Joints in user order, fixed joints included.
  const std::vector<std::string> expected = {"j_b", "j_e", "j_a", "j_c", "j_d"};
  EXPECT_EQ(joint_names(robot), expected);
  EXPECT_EQ(joint_named(robot, "j_c").where.line, 9);
  EXPECT_EQ(joint_named(robot, "j_e").where.line, 21);
  EXPECT_EQ(joint_named(robot, "j_c").parent_link, robot.find_link("a"));
  EXPECT_EQ(joint_named(robot, "j_c").child_link, robot.find_link("c"));
  EXPECT_EQ(joint_named(robot, "j_a").type, JointType::Continuous);
  EXPECT_EQ(joint_named(robot, "j_d").type, JointType::Fixed);
  // Axes: normalized, URDF default 1 0 0.
  expect_near(joint_named(robot, "j_b").axis, Eigen::Vector3d::UnitY());
  expect_near(joint_named(robot, "j_a").axis, Eigen::Vector3d::UnitX());
  EXPECT_EQ(joint_named(robot, "j_e").damping, 0.25);
  EXPECT_EQ(joint_named(robot, "j_a").damping, 0.0);
  // Links without <inertial> are massless.
  EXPECT_EQ(robot.links[0].inertial.mass, 0.0);
  EXPECT_TRUE(robot.links[0].inertial.I_com.isZero(0.0));
  EXPECT_EQ(robot.nv(), 4);
  check_invariants(robot);
}

TEST(UrdfReader, SingleLinkRobot) {
  const ir::Robot robot =
      read_robot_string("<robot name=\"brick\"><link name=\"b\"/></robot>", "brick.urdf");
  EXPECT_EQ(robot.links.size(), 1u);
  EXPECT_EQ(robot.root_link, 0);
  EXPECT_TRUE(robot.joints.empty());
  EXPECT_EQ(robot.nv(), 0);
}

TEST(UrdfReader, OriginRpyIsRzRyRx) {
  const char* xml = R"(<robot name="r">
  <link name="p"/><link name="c"/>
  <joint name="j" type="revolute">
    <parent link="p"/><child link="c"/>
    <origin xyz="0.1 -0.2 0.3" rpy="0.3 -0.5 1.2"/>
    <axis xyz="0 0 1"/>
    <limit effort="1" velocity="1" lower="-1" upper="1"/>
  </joint>
</robot>)";
  const ir::Joint j = read_robot_string(xml, "rpy.urdf").joints.at(0);
  expect_near(j.origin.p, Eigen::Vector3d(0.1, -0.2, 0.3));
  expect_near(j.origin.R, rot_z(1.2) * rot_y(-0.5) * rot_x(0.3));
}

TEST(UrdfReader, KnownRotations) {
  const auto R_of = [](const std::string& rpy) {
    const std::string xml = R"(<robot name="r"><link name="p"/><link name="c"/>
      <joint name="j" type="fixed"><parent link="p"/><child link="c"/>
      <origin rpy=")" + rpy +
                            R"("/></joint></robot>)";
    return read_robot_string(xml, "known.urdf").joints.at(0).origin.R;
  };
  // Yaw of +90 degrees takes the child's x axis to the parent's y axis.
  expect_near(R_of("0 0 1.5707963267948966") * Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY());
  // Roll of +90 degrees takes y to z.
  expect_near(R_of("1.5707963267948966 0 0") * Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ());
  // Pitch of +90 degrees takes z to x.
  expect_near(R_of("0 1.5707963267948966 0") * Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitX());
  // Whitespace other than blanks between numbers is accepted.
  expect_near(R_of("0\t0\n 1.5707963267948966 ") * Eigen::Vector3d::UnitX(),
              Eigen::Vector3d::UnitY());
}

TEST(UrdfReader, InertiaIsRotatedIntoTheLinkFrame) {
  const char* xml = R"(<robot name="r">
  <link name="body">
    <inertial>
      <origin xyz="0.1 0.2 0.3" rpy="0 0 1.5707963267948966"/>
      <mass value="2.5"/>
      <inertia ixx="1" ixy="0" ixz="0" iyy="2" iyz="0" izz="3"/>
    </inertial>
  </link>
  <link name="tilted">
    <inertial>
      <origin rpy="0.4 0.7 -0.2"/>
      <mass value="1"/>
      <inertia ixx="0.5" ixy="0.01" ixz="-0.02" iyy="0.6" iyz="0.03" izz="0.7"/>
    </inertial>
  </link>
  <joint name="j" type="floating"><parent link="body"/><child link="tilted"/></joint>
</robot>)";
  const ir::Robot robot = read_robot_string(xml, "inertia.urdf");
  const ir::Inertial& a = robot.links[0].inertial;
  EXPECT_EQ(a.mass, 2.5);
  expect_near(a.com, Eigen::Vector3d(0.1, 0.2, 0.3));
  // A quarter turn about z swaps the x and y moments.
  expect_near(a.I_com, Eigen::Vector3d(2, 1, 3).asDiagonal().toDenseMatrix());

  const ir::Inertial& b = robot.links[1].inertial;
  Eigen::Matrix3d I_urdf;
  I_urdf << 0.5, 0.01, -0.02, 0.01, 0.6, 0.03, -0.02, 0.03, 0.7;
  const Eigen::Matrix3d R = rot_z(-0.2) * rot_y(0.7) * rot_x(0.4);
  expect_near(b.I_com, R * I_urdf * R.transpose());
  expect_near(b.com, Eigen::Vector3d::Zero());
  EXPECT_EQ(robot.joints.at(0).type, JointType::Floating);
  EXPECT_EQ(robot.nq(), 7);
  EXPECT_EQ(robot.nv(), 6);
}

TEST(UrdfReader, PlanarJointKeepsItsNormal) {
  const char* xml = R"(<robot name="r"><link name="p"/><link name="c"/>
  <joint name="j" type="planar"><parent link="p"/><child link="c"/><axis xyz="0 0 3"/></joint>
</robot>)";
  const ir::Joint j = read_robot_string(xml, "planar.urdf").joints.at(0);
  EXPECT_EQ(j.type, JointType::Planar);
  expect_near(j.axis, Eigen::Vector3d::UnitZ());
}

TEST(UrdfReader, IgnoresTransmissionGazeboVisuals) {
  const char* xml = R"(<robot name="r">
  <material name="blue"><color rgba="0 0 1 1"/></material>
  <link name="p"><visual><geometry><mesh filename="package://x.stl"/></geometry>
    <material name="blue"/></visual></link>
  <link name="c"><collision><geometry><box size="1 2 3"/></geometry></collision></link>
  <link name="d"/>
  <joint name="j1" type="revolute"><parent link="p"/><child link="c"/>
    <limit effort="10" velocity="2"/><safety_controller k_velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="c"/><child link="d"/>
    <mimic joint="j1" multiplier="-1" offset="0"/></joint>
  <transmission name="t"><type>transmission_interface/SimpleTransmission</type>
    <joint name="j1"/></transmission>
  <gazebo reference="p"><material>Gazebo/Blue</material></gazebo>
</robot>)";
  const ir::Robot robot = read_robot_string(xml, "ignored.urdf");
  EXPECT_EQ(joint_names(robot), (std::vector<std::string>{"j1", "j2"}));
  // docs/interface.md section 2b: the mimic joint keeps its coordinate and gets an
  // exact constraint row q_j2 = -1 q_j1 + 0, a cut named after it.
  EXPECT_EQ(robot.nv(), 2);
  ASSERT_EQ(robot.cuts.size(), 1u);
  const ir::CutJoint& mimic = robot.cuts[0];
  EXPECT_EQ(mimic.type, ir::CutType::Mimic);
  EXPECT_EQ(mimic.name, "j2");
  EXPECT_EQ(robot.joints[mimic.mimic_joint].name, "j2");
  EXPECT_EQ(robot.joints[mimic.mimic_leader].name, "j1");
  EXPECT_EQ(mimic.multiplier, -1.0);
  EXPECT_EQ(mimic.offset, 0.0);
  EXPECT_EQ(ir::cut_rows(mimic.type), 1);
  EXPECT_EQ(mimic.where.line, 10);  // the <mimic> element
}

TEST(UrdfReader, MimicDefaultsAreMultiplierOneOffsetZero) {
  const char* xml = R"(<robot name="r">
  <link name="p"/><link name="a"/><link name="b"/>
  <joint name="lead" type="prismatic"><parent link="p"/><child link="a"/></joint>
  <joint name="follow" type="continuous"><parent link="a"/><child link="b"/><mimic joint="lead"/></joint>
</robot>)";
  const ir::Robot robot = read_robot_string(xml, "mimic.urdf");
  ASSERT_EQ(robot.cuts.size(), 1u);
  EXPECT_EQ(robot.cuts[0].multiplier, 1.0);
  EXPECT_EQ(robot.cuts[0].offset, 0.0);
  EXPECT_EQ(robot.cuts[0].link_k, robot.find_link("a"));  // the leader's child link
  EXPECT_EQ(robot.cuts[0].link_l, robot.find_link("b"));
}

TEST(UrdfReader, BallJoints) {
  const char* xml = R"(<robot name="balls" xmlns:drake="http://drake.mit.edu">
  <link name="base"/><link name="a"/><link name="b"/><link name="c"/>
  <joint name="hip" type="ball">
    <parent link="base"/><child link="a"/>
    <origin xyz="0 0 1"/>
    <dynamics damping="0.5"/>
  </joint>
  <drake:joint name="knee" type="ball">
    <parent link="a"/><child link="b"/>
    <origin xyz="0 0 -0.5" rpy="0 0 0.1"/>
  </drake:joint>
  <joint name="ankle" type="revolute"><parent link="b"/><child link="c"/>
    <axis xyz="0 1 0"/></joint>
</robot>)";
  const ir::Robot robot = read_robot_string(xml, "balls.urdf");
  EXPECT_EQ(joint_names(robot), (std::vector<std::string>{"hip", "knee", "ankle"}));
  const ir::Joint& hip = robot.joints[0];
  EXPECT_EQ(hip.type, JointType::Ball);
  EXPECT_EQ(hip.damping, 0.5);
  expect_near(hip.origin.p, Eigen::Vector3d(0, 0, 1));
  const ir::Joint& knee = robot.joints[1];
  EXPECT_EQ(knee.type, JointType::Ball);
  EXPECT_EQ(knee.where.line, 8);
  expect_near(knee.origin.p, Eigen::Vector3d(0, 0, -0.5));
  expect_near(knee.origin.R, rot_z(0.1));
  EXPECT_EQ(robot.joints[2].type, JointType::Revolute);
  EXPECT_EQ(robot.nq(), 4 + 4 + 1);
  EXPECT_EQ(robot.nv(), 3 + 3 + 1);
}

// A four-bar with its cuts inline: one <loop_joint>, one Drake constraint.
const char* const kFourBar = R"(<?xml version="1.0"?>
<robot name="fourbar" xmlns:drake="http://drake.mit.edu">
  <link name="ground"/><link name="crank"/><link name="coupler"/><link name="rocker"/>
  <joint name="j_crank" type="continuous">
    <parent link="ground"/><child link="crank"/><axis xyz="0 0 1"/>
  </joint>
  <joint name="j_coupler" type="continuous">
    <parent link="crank"/><child link="coupler"/><origin xyz="1 0 0"/><axis xyz="0 0 1"/>
  </joint>
  <joint name="j_rocker" type="continuous">
    <parent link="ground"/><child link="rocker"/><origin xyz="3 0 0"/><axis xyz="0 0 1"/>
  </joint>
  <loop_joint name="close" type="revolute">
    <parent link="coupler"/>
    <child link="rocker"/>
    <origin xyz="2 0 0" rpy="0 0 0.5"/>
    <child_origin xyz="0 1 0"/>
    <axis xyz="0 0 5"/>
  </loop_joint>
  <drake:ball_constraint>
    <drake:ball_constraint_body_A name="crank"/>
    <drake:ball_constraint_body_B name="rocker"/>
    <drake:ball_constraint_p_AP value="0.5 0 0"/>
    <drake:ball_constraint_p_BQ value="0 0.25 0"/>
  </drake:ball_constraint>
</robot>
)";

TEST(UrdfReader, InlineLoopJointAndDrakeBallConstraint) {
  const ir::Robot robot = read_robot_string(kFourBar, "fourbar.urdf");
  ASSERT_EQ(robot.cuts.size(), 2u);
  const ir::CutJoint& close = robot.cuts[0];
  EXPECT_EQ(close.name, "close");
  EXPECT_EQ(close.type, ir::CutType::Revolute);
  EXPECT_EQ(close.link_k, robot.find_link("coupler"));
  EXPECT_EQ(close.link_l, robot.find_link("rocker"));
  expect_near(close.frame_k.p, Eigen::Vector3d(2, 0, 0));
  expect_near(close.frame_k.R, rot_z(0.5));
  expect_near(close.frame_l.p, Eigen::Vector3d(0, 1, 0));
  expect_near(close.frame_l.R, Eigen::Matrix3d::Identity());
  expect_near(close.axis, Eigen::Vector3d::UnitZ());
  EXPECT_FALSE(close.distance_given);
  EXPECT_EQ(close.where.file, "fourbar.urdf");
  EXPECT_EQ(close.where.line, 13);

  const ir::CutJoint& ball = robot.cuts[1];
  EXPECT_EQ(ball.name, "ball_constraint_1");
  EXPECT_EQ(ball.type, ir::CutType::Spherical);
  EXPECT_EQ(ball.link_k, robot.find_link("crank"));
  EXPECT_EQ(ball.link_l, robot.find_link("rocker"));
  expect_near(ball.frame_k.p, Eigen::Vector3d(0.5, 0, 0));
  expect_near(ball.frame_l.p, Eigen::Vector3d(0, 0.25, 0));
  expect_near(ball.frame_k.R, Eigen::Matrix3d::Identity());
  EXPECT_EQ(ball.where.line, 20);
}

TEST(UrdfReader, CutsFileAppendsAfterInlineCuts) {
  ir::Robot robot = read_robot_string(kFourBar, "fourbar.urdf");
  const std::string cuts = R"(<?xml version="1.0"?>
<loop_joints>
  <loop_joint name="span" type="distance">
    <parent link="crank"/><child link="rocker"/>
    <origin xyz="1 0 0"/>
    <distance value="2.5"/>
  </loop_joint>
  <loop_joint name="hinge" type="universal">
    <parent link="coupler"/><child link="rocker"/>
    <axis xyz="1 0 0"/><child_axis xyz="0 3 0"/>
  </loop_joint>
</loop_joints>
)";
  const fs::path path = fs::path(testing::TempDir()) / "urdf_reader_test.cuts.xml";
  {
    std::ofstream out(path);
    out << cuts;
  }
  read_cuts(path.string(), robot);
  fs::remove(path);
  ASSERT_EQ(robot.cuts.size(), 4u);
  EXPECT_EQ(robot.cuts[0].name, "close");
  EXPECT_EQ(robot.cuts[1].name, "ball_constraint_1");
  const ir::CutJoint& span = robot.cuts[2];
  EXPECT_EQ(span.name, "span");
  EXPECT_EQ(span.type, ir::CutType::Distance);
  EXPECT_TRUE(span.distance_given);
  EXPECT_EQ(span.distance, 2.5);
  EXPECT_EQ(span.where.file, path.string());
  EXPECT_EQ(span.where.line, 3);
  const ir::CutJoint& hinge = robot.cuts[3];
  EXPECT_EQ(hinge.type, ir::CutType::Universal);
  expect_near(hinge.axis, Eigen::Vector3d::UnitX());
  expect_near(hinge.child_axis, Eigen::Vector3d::UnitY());
  EXPECT_FALSE(hinge.distance_given);
  EXPECT_EQ(ir::cut_rows(hinge.type), 4);
}

TEST(UrdfReader, FailedCutsFileLeavesRobotUnchanged) {
  ir::Robot robot = read_robot_string(kFourBar, "fourbar.urdf");
  const std::string cuts = R"(<loop_joints>
  <loop_joint name="ok" type="spherical"><parent link="crank"/><child link="rocker"/></loop_joint>
  <loop_joint name="bad" type="spherical"><parent link="crank"/><child link="nope"/></loop_joint>
</loop_joints>)";
  const std::string message = error_of([&] { read_cuts_string(cuts, "x.cuts.xml", robot); });
  EXPECT_NE(message.find("x.cuts.xml:3: <loop_joint> 'bad': <child>: link 'nope'"),
            std::string::npos)
      << message;
  EXPECT_EQ(robot.cuts.size(), 2u);
}

TEST(UrdfReader, AllCutTypes) {
  const std::map<std::string, ir::CutType> types = {
      {"spherical", ir::CutType::Spherical}, {"revolute", ir::CutType::Revolute},
      {"prismatic", ir::CutType::Prismatic}, {"cylindrical", ir::CutType::Cylindrical},
      {"universal", ir::CutType::Universal}, {"fixed", ir::CutType::Fixed},
      {"distance", ir::CutType::Distance}};
  for (const auto& [name, type] : types) {
    ir::Robot robot = read_robot_string(kFourBar, "fourbar.urdf");
    read_cuts_string("<loop_joints><loop_joint name=\"x\" type=\"" + name +
                         "\"><parent link=\"crank\"/><child link=\"rocker\"/>"
                         "</loop_joint></loop_joints>",
                     "t.cuts.xml", robot);
    EXPECT_EQ(robot.cuts.back().type, type) << name;
    EXPECT_STREQ(ir::cut_type_name(type), name.c_str());
  }
}

// ---------------------------------------------------------------------------
// Bad input
// ---------------------------------------------------------------------------

TEST(UrdfReaderErrors, MissingFile) {
  const std::string path = (kErrorsDir / "does_not_exist.urdf").string();
  const std::string message = error_of([&] { read_robot(path); });
  EXPECT_EQ(message, path + ": cannot read file: No such file or directory; check the path (relative to the folder jrgen runs in)");
  ir::Robot robot;
  const std::string cuts = error_of([&] { read_cuts(path, robot); });
  EXPECT_EQ(cuts, path + ": cannot read file: No such file or directory; check the path (relative to the folder jrgen runs in)");
}

const char* const kCutsBaseRobotForNotes = R"(<robot name="ok">
  <link name="base"/><link name="a"><inertial><origin xyz="0 0 1" rpy="0 0 0"/><mass value="1"/>
    <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial><collision/></link>
  <joint name="j_a" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/>
    <limit lower="0" upper="1" effort="1" velocity="1"/><dynamics damping="0.1"/></joint>
  <transmission name="t"/><material name="m"/>
</robot>)";

// A <!DOCTYPE> with an internal subset: TinyXML alone lost the document
// after the subset's first '>' ("no <robot> element").  Lines stay right.
TEST(UrdfReader, DoctypeWithInternalSubset) {
  const char* xml = R"(<?xml version="1.0"?>
<!DOCTYPE robot [
  <!ENTITY len "1.0">
]>
<robot name="r">
  <link name="base"/>
  <link name="arm"/>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/></joint>
</robot>)";
  const ir::Robot robot = read_robot_string(xml, "doctype.urdf");
  ASSERT_EQ(robot.joints.size(), 1u);
  EXPECT_EQ(robot.joints[0].where.line, 8);
}

TEST(UrdfReaderErrors, FullMessageFormat) {
  // The full text once; the folder cases below check substrings.
  const std::string path = (kErrorsDir / "unknown_link.urdf").string();
  EXPECT_EQ(error_of([&] { read_robot(path); }),
            path + ":7: <joint> 'elbow': child link 'forearm' is not defined; add <link name=\"forearm\"> or "
                   "correct the name");
}

// What URDF parsers ignore silently but is most likely a typo becomes a note
// naming the element meant; correct spellings and unrelated extra elements
// give none.
TEST(UrdfReaderNotes, MisspelledElementsAndAttributes) {
  const char* xml = R"(<robot name="r">
  <link name="base"/>
  <link name="arm">
    <inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
    <visual><geometry><box size="1 1 1"/></geometry></visual>
    <my_extension foo="1"/>
  </link>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/>
    <axiss xyz="0 0 1"/><origin xzy="1 0 0"/></joint>
  <gazebo reference="arm"/>
</robot>)";
  const ir::Robot robot = read_robot_string(xml, "typo.urdf");
  ASSERT_EQ(robot.notes.size(), 2u);
  EXPECT_EQ(robot.notes[0],
            "typo.urdf:9: <joint> 'j': <axiss> is not a URDF element inside <joint> and is ignored; did you mean "
            "<axis>?");
  EXPECT_EQ(robot.notes[1],
            "typo.urdf:9: <joint> 'j': <origin> attribute 'xzy' is not read (ignored); did you mean 'xyz'?");
  EXPECT_TRUE(read_robot_string(kCutsBaseRobotForNotes, "ok.urdf").notes.empty());
}

TEST(UrdfReaderErrors, InertiaTriangleInequalityOnRequest) {
  const char* xml = R"(<robot name="r">
  <link name="base">
    <inertial>
      <mass value="1"/>
      <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="3"/>
    </inertial>
  </link>
</robot>)";
  ReadOptions strict;
  strict.check_inertia_triangle = true;
  EXPECT_NO_THROW(read_robot_string(xml, "triangle.urdf"));
  const std::string message = error_of([&] { read_robot_string(xml, "triangle.urdf", strict); });
  EXPECT_NE(message.find("triangle.urdf:5: <link> 'base': principal moments of inertia 1, 1, 3 "
                         "violate the triangle inequality"),
            std::string::npos)
      << message;
  // A violation below the relative tolerance (rounded numbers) passes.
  std::string rounded = xml;
  rounded.replace(rounded.find("izz=\"3\""), 7, "izz=\"2.0000001\"");
  EXPECT_NO_THROW(read_robot_string(rounded, "triangle.urdf", strict));
}

// Published models that violate the triangle inequality: accepted by default,
// rejected with ReadOptions::check_inertia_triangle.
TEST(UrdfReaderErrors, ExternalModelsUnderStrictInertiaChecks) {
  ReadOptions strict;
  strict.check_inertia_triangle = true;
  const std::vector<std::string> violating = {"allegro_right_hand.urdf", "anymal.urdf", "icub.urdf",
                                              "pr2.urdf", "romeo.urdf"};
  for (const ModelCounts& m : kModels) {
    SCOPED_TRACE(m.file);
    const bool expect_error =
        std::find(violating.begin(), violating.end(), m.file) != violating.end();
    std::string message;
    try {
      read_robot((kModelsDir / m.file).string(), strict);
    } catch (const Error& e) {
      message = e.what();
    }
    if (expect_error)
      EXPECT_NE(message.find("violate the triangle inequality"), std::string::npos) << message;
    else
      EXPECT_EQ(message, "");
  }
}

// Base robot for the tests/errors/*.cuts.xml cases.
const char* const kCutsBaseRobot = R"(<robot name="cuts_base">
  <link name="base"/><link name="a"/><link name="b"/>
  <joint name="j_a" type="revolute"><parent link="base"/><child link="a"/></joint>
  <joint name="j_b" type="revolute"><parent link="base"/><child link="b"/></joint>
</robot>)";

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

TEST(UrdfReaderErrors, EveryCaseInTestsErrors) {
  int cases = 0;
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(kErrorsDir)) files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  for (const fs::path& file : files) {
    const std::string name = file.filename().string();
    const bool is_urdf = ends_with(name, ".urdf");
    const bool is_cuts = ends_with(name, ".cuts.xml");
    if (!is_urdf && !is_cuts) {
      EXPECT_TRUE(ends_with(name, ".expected")) << "unexpected file in tests/errors: " << name;
      continue;
    }
    SCOPED_TRACE(name);
    const std::string stem = name.substr(0, name.size() - (is_urdf ? 5 : 9));
    const fs::path expected_file = kErrorsDir / (stem + ".expected");
    ASSERT_TRUE(fs::exists(expected_file)) << "missing " << expected_file;
    std::string expected = slurp(expected_file);
    while (!expected.empty() && (expected.back() == '\n' || expected.back() == '\r'))
      expected.pop_back();
    ASSERT_FALSE(expected.empty());

    // overflow_*: every number is finite, so the reader accepts them; the
    // constants derived from them overflow in build_tree or the analysis.
    // tree_*: the reader accepts them too; build_tree refuses them (a loop
    // joint within one body, a link left without mass by a misspelling).
    // CliErrorFolder in cli_test checks those messages.
    if (name.rfind("overflow_", 0) == 0 || name.rfind("tree_", 0) == 0) {
      EXPECT_NO_THROW(read_robot(file.string()));
      ++cases;
      continue;
    }
    std::string message;
    testing::internal::CaptureStderr();
    if (is_urdf) {
      message = error_of([&] { read_robot(file.string()); });
    } else {
      ir::Robot robot = read_robot_string(kCutsBaseRobot, "cuts_base.urdf");
      message = error_of([&] { read_cuts(file.string(), robot); });
    }
    EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
    EXPECT_NE(message.find(expected), std::string::npos)
        << "message:  " << message << "\nexpected: " << expected;
    EXPECT_EQ(message.find('\n'), std::string::npos) << "not one line: " << message;
    EXPECT_EQ(message.rfind(file.string(), 0), 0u) << "must start with the file: " << message;
    ++cases;
  }
  EXPECT_GE(cases, 30);
}

// Each expected file starts with the case's file name, then (where the case
// has one) the line: "<case>.urdf:LINE: ...".
TEST(UrdfReaderErrors, ExpectedMessagesStartWithTheFileName) {
  for (const auto& entry : fs::directory_iterator(kErrorsDir)) {
    const std::string name = entry.path().filename().string();
    if (!ends_with(name, ".expected")) continue;
    const std::string stem = name.substr(0, name.size() - 9);
    const std::string text = slurp(entry.path());
    const bool names_file =
        text.rfind(stem + ".urdf:", 0) == 0 || text.rfind(stem + ".cuts.xml:", 0) == 0;
    EXPECT_TRUE(names_file) << name << ": " << text;
  }
}

}  // namespace
}  // namespace jrgen::urdf
