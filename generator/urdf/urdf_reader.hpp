// URDF reader: URDF (+ loop-closing cut joints) -> ir::Robot.
//
// The only stage that sees urdfdom and TinyXML.  A TinyXML pre-pass validates
// the document and records line numbers; urdfdom then reads the standard URDF
// content (links, inertials, joints) from a cleaned copy of the document.
// Extensions read by the pre-pass alone (docs/interface.md section 2):
//   - <joint type="ball"> and Drake's <drake:joint type="ball">: ball joints;
//   - <loop_joint> inside <robot>, and <loop_joints> files given with --cuts;
//   - Drake's <drake:ball_constraint>: a spherical cut joint.
//   - <mimic>: a one-row cut q_this = multiplier q_leader + offset (section 2b);
//   - <spring>, <joint_spring>, <joint_force> inside <robot> (section 2b).
// Transmissions, gazebo tags, visuals and collisions are ignored.
//
// Every error is a jrgen::Error whose what() is one line,
// "file:line: <element> 'name': what is wrong" (docs/conventions.md, "Errors").
#pragma once

#include <string>

#include "ir/ir.hpp"

namespace jrgen::urdf {

/// Optional checks.  The defaults accept every model in ../shared/models-external.
struct ReadOptions {
  /// Also require the principal moments of inertia of every link to satisfy
  /// the triangle inequality (largest <= sum of the other two, up to a
  /// relative 1e-6), i.e. a physically realizable mass distribution.  Off by
  /// default: many published URDFs violate it (5 of the 12 models in
  /// ../shared/models-external, e.g. pr2 and allegro), and the equations of
  /// motion need only positive semi-definite inertias, which is always checked.
  bool check_inertia_triangle = false;
};

/// Reads the URDF file at `urdf_path`.  Robot::source_file and every
/// SourceLocation::file hold `urdf_path` as given.
///
/// Result: links in document order; joints in user order (depth-first from
/// the root link, children visited in the document order of their joint
/// elements, fixed joints included); cuts from <loop_joint> and
/// <drake:ball_constraint> elements in document order.
/// Throws jrgen::Error on unreadable files and on any invalid content.
ir::Robot read_robot(const std::string& urdf_path, const ReadOptions& options = {});

/// As read_robot(), on URDF text held in memory; `display_name` stands for the
/// file name in SourceLocation and in error messages.
ir::Robot read_robot_string(const std::string& xml, const std::string& display_name,
                            const ReadOptions& options = {});

/// Reads a --cuts file (root element <loop_joints>, children <loop_joint>)
/// and appends its cut joints, in document order, to robot.cuts.  Links are
/// looked up in `robot`; cut names must be unique among robot.joints and
/// robot.cuts.  Throws jrgen::Error; on error `robot` is left unchanged.
void read_cuts(const std::string& cuts_path, ir::Robot& robot);

/// As read_cuts(), on text held in memory.
void read_cuts_string(const std::string& xml, const std::string& display_name, ir::Robot& robot);

}  // namespace jrgen::urdf
