// jrgen intermediate representation: the mechanism as the user wrote it.
//
// Plain structs, in *user order* (INTERFACE.md section 3): links and joints as
// they come out of the URDF, fixed joints included, nothing fused or renumbered.
// The topology stage (generator/topology) turns this into the Lemma 2 ordered
// body tree; the URDF reader (generator/urdf) is the only producer.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace jrgen::ir {

/// Where an element came from, for error messages ("file:line").
struct SourceLocation {
  std::string file;  ///< as given on the command line
  int line = 0;      ///< 1-based; 0 when unknown
};

/// A rigid placement X_PC: maps C coordinates into P.  p_PC is the position of
/// C's origin in P, R_PC the rotation from C to P.
struct Pose {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
};

/// Mass properties of a link, in the link frame.
struct Inertial {
  double mass = 0.0;
  Eigen::Vector3d com = Eigen::Vector3d::Zero();  ///< p_LoCm_L
  /// Rotational inertia about the centre of mass, expressed in the link frame
  /// (the URDF <inertial><origin rpy> is already applied).
  Eigen::Matrix3d I_com = Eigen::Matrix3d::Zero();
};

struct Link {
  std::string name;
  Inertial inertial;
  SourceLocation where;
};

enum class JointType { Fixed, Revolute, Continuous, Prismatic, Floating, Planar, Ball };

/// Velocity coordinates of a joint (INTERFACE.md section 3).
int joint_nv(JointType type);
/// Position coordinates of a joint (quaternions count 4).
int joint_nq(JointType type);
/// URDF spelling of a joint type ("revolute", "ball", ...).
const char* joint_type_name(JointType type);

struct Joint {
  std::string name;
  JointType type = JointType::Fixed;
  int parent_link = -1;  ///< index into Robot::links
  int child_link = -1;   ///< index into Robot::links
  Pose origin;           ///< X_PJ: joint frame J in the parent link frame P
  /// Unit axis in the joint frame: rotation/translation axis, or the plane
  /// normal for planar joints.  Unused for fixed, ball and floating.
  Eigen::Vector3d axis = Eigen::Vector3d::UnitX();
  double damping = 0.0;  ///< URDF <dynamics damping>, on every velocity coordinate
  SourceLocation where;
};

enum class CutType { Spherical, Revolute, Prismatic, Cylindrical, Universal, Fixed, Distance };

/// Constraint rows of a cut joint type (INTERFACE.md section 2).
int cut_rows(CutType type);
const char* cut_type_name(CutType type);

/// A loop-closing joint: constraint between a frame on link k and one on link l.
struct CutJoint {
  std::string name;
  CutType type = CutType::Spherical;
  int link_k = -1;          ///< <parent link>
  int link_l = -1;          ///< <child link>
  Pose frame_k;             ///< joint frame on k, in k's link frame (<origin>)
  Pose frame_l;             ///< joint frame on l, in l's link frame (<child_origin>)
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();        ///< <axis>, frame on k
  Eigen::Vector3d child_axis = Eigen::Vector3d::UnitZ();  ///< <child_axis>, frame on l
  double distance = 0.0;
  bool distance_given = false;  ///< false: distance taken at the zero configuration
  SourceLocation where;
};

/// The whole input.  Joints are stored in user order: depth-first from the
/// root link, siblings in document order.  Every link except the root is the
/// child of exactly one joint.
struct Robot {
  std::string name;         ///< <robot name>
  std::string source_file;  ///< the URDF path as given
  std::vector<Link> links;  ///< document order
  std::vector<Joint> joints;  ///< user order (depth-first, siblings in document order)
  std::vector<CutJoint> cuts;  ///< URDF <loop_joint> first, then --cuts file
  int root_link = -1;

  int find_link(const std::string& name) const;  ///< -1 when absent
  int nq() const;  ///< sum of joint_nq over joints
  int nv() const;  ///< sum of joint_nv over joints
};

}  // namespace jrgen::ir
