// jrgen intermediate representation: the mechanism as the user wrote it.
//
// Plain structs, in *user order* (docs/interface.md section 3): links and joints as
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

/// Velocity coordinates of a joint (docs/interface.md section 3).
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

/// Mimic: the one row q_this - multiplier q_leader - offset = 0 of a URDF
/// <mimic> (docs/interface.md section 2b), placed among the cut joints.
enum class CutType { Spherical, Revolute, Prismatic, Cylindrical, Universal, Fixed, Distance, Mimic };

/// Constraint rows of a cut joint type (docs/interface.md section 2).
int cut_rows(CutType type);
const char* cut_type_name(CutType type);

/// A loop-closing joint: constraint between a frame on link k and one on link l.
/// A mimic row has link_k = the leader joint's child link, link_l = its own
/// joint's child link, and no frames.
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
  /// Mimic only: the joints (indices into Robot::joints), q_joint = multiplier q_leader + offset.
  int mimic_joint = -1, mimic_leader = -1;
  double multiplier = 1.0, offset = 0.0;
  SourceLocation where;
};

// ---- Force elements (docs/interface.md section 2b) -------------------------------------

/// <spring>: a force along the line between a point on link k (<parent>) and
/// one on link l (<child>), of magnitude stiffness (L - rest_length) + damping
/// dL/dt, pulling the points together when positive.
struct Spring {
  std::string name;
  int link_k = -1, link_l = -1;  ///< index into Robot::links (either may be the root)
  Eigen::Vector3d p_k = Eigen::Vector3d::Zero();  ///< attachment point in k's link frame
  Eigen::Vector3d p_l = Eigen::Vector3d::Zero();  ///< attachment point in l's link frame
  double stiffness = 0.0, damping = 0.0, rest_length = 0.0;
  bool rest_given = false;  ///< false: rest_length is the distance at the zero configuration
  SourceLocation where;
};

/// <joint_spring>: generalized force -stiffness (q - rest) - damping v on a
/// revolute, continuous or prismatic joint.
struct JointSpring {
  int joint = -1;  ///< index into Robot::joints
  double stiffness = 0.0, damping = 0.0, rest = 0.0;
  SourceLocation where;
};

/// <joint_force>: a constant generalized force on a one-dof joint (added to tau).
struct JointForce {
  int joint = -1;  ///< index into Robot::joints
  double value = 0.0;
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
  /// URDF <loop_joint> first, then the <mimic> rows (CutType::Mimic, named
  /// after their joints, user order), then the --cuts file.
  std::vector<CutJoint> cuts;
  std::vector<Spring> springs;             ///< document order
  std::vector<JointSpring> joint_springs;  ///< document order
  std::vector<JointForce> joint_forces;    ///< document order
  int root_link = -1;
  /// Notes of the readers for stderr: elements and attributes that look
  /// misspelled and are ignored ("<inertail>: did you mean <inertial>?").
  std::vector<std::string> notes;

  int find_link(const std::string& name) const;  ///< -1 when absent
  int nq() const;  ///< sum of joint_nq over joints
  int nv() const;  ///< sum of joint_nv over joints
};

}  // namespace jrgen::ir
