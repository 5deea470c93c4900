// analysis::cut_against_definition: a body on a ball joint, closed to the
// world at the ball's centre by one cut of each type whose rows also vanish
// at reversed axes or half turns (reference_constraints_test,
// CutDefinitionResidual).  Quaternions chosen by hand: a half turn about x
// reverses the z axis; a half turn about z keeps it.
#include <gtest/gtest.h>

#include <string>

#include "analysis/cut_definitions.hpp"
#include "analysis/runtime_model.hpp"
#include "topology/topology.hpp"
#include "urdf/urdf_reader.hpp"

namespace jrgen {
namespace {

std::string ball_robot(const std::string& cut_type) {
  return R"(<robot name="ball">
  <link name="world"/>
  <link name="body"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <joint name="ball" type="ball"><parent link="world"/><child link="body"/></joint>
  <loop_joint name="cut" type=")" +
         cut_type + R"(">
    <parent link="body"/><child link="world"/><axis xyz="0 0 1"/>
  </loop_joint>
</robot>)";
}

// -1 or the index of the cut against its definition at quaternion (w, x, y, z).
int check(const std::string& cut_type, double w, double x, double y, double z) {
  const ir::Robot robot = urdf::read_robot_string(ball_robot(cut_type), "ball.urdf");
  const topology::Tree tree = topology::build_tree(robot);
  analysis::RuntimeModel rt(tree, Eigen::Vector3d::Zero());
  Eigen::VectorXd q(4);
  q << w, x, y, z;
  return analysis::cut_against_definition(tree, rt, q);
}

TEST(CutDefinitions, AxisCutsSeeAReversedAxis) {
  for (const char* type : {"revolute", "cylindrical", "prismatic"}) {
    SCOPED_TRACE(type);
    EXPECT_EQ(check(type, 1, 0, 0, 0), -1);
    EXPECT_EQ(check(type, 0, 1, 0, 0), 0);  // half turn about x: z reversed
    EXPECT_EQ(check(type, 0, 0, 1, 0), 0);  // half turn about y
    EXPECT_EQ(check(type, 0.8, 0.6, 0, 0), -1);  // 74 degrees: rows do not vanish, not this check's business
  }
  // About the axis itself the axis stays: revolute and cylindrical allow it.
  EXPECT_EQ(check("revolute", 0, 0, 0, 1), -1);
  EXPECT_EQ(check("cylindrical", 0, 0, 0, 1), -1);
}

TEST(CutDefinitions, OrientationCutsSeeAHalfTurn) {
  for (const char* type : {"fixed", "prismatic"}) {
    SCOPED_TRACE(type);
    EXPECT_EQ(check(type, 1, 0, 0, 0), -1);
    EXPECT_EQ(check(type, 0, 0, 0, 1), 0);  // half turn about the axis
    EXPECT_EQ(check(type, 0, 1, 0, 0), 0);
  }
}

TEST(CutDefinitions, OtherTypesHaveNothingHidden) {
  for (const char* type : {"spherical", "universal"})
    for (const Eigen::Vector4d& quat : {Eigen::Vector4d(1, 0, 0, 0), Eigen::Vector4d(0, 1, 0, 0)}) {
      SCOPED_TRACE(type);
      EXPECT_EQ(check(type, quat[0], quat[1], quat[2], quat[3]), -1);
    }
}

}  // namespace
}  // namespace jrgen
