#include "common/random_cuts.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <stdexcept>
#include <vector>

#include "reference/reference_dynamics.hpp"
#include "urdf/urdf_reader.hpp"

namespace jrgen::testing {

namespace {

// Portable uniform numbers (the standard distributions differ between libraries).
struct Rng {
  std::uint64_t state;
  double uniform(double lo, double hi) {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return lo + (hi - lo) * static_cast<double>(state >> 11) * 0x1.0p-53;
  }
  int index(int n) { return std::min(n - 1, static_cast<int>(uniform(0.0, n))); }
  Eigen::Vector3d unit() {
    Eigen::Vector3d v;
    do v = Eigen::Vector3d(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1));
    while (v.norm() < 0.1 || v.norm() > 1.0);
    return v.normalized();
  }
  Eigen::Matrix3d rotation() {
    Eigen::Quaterniond q(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1), uniform(-1, 1));
    return q.normalized().toRotationMatrix();
  }
};

std::string xyz(const Eigen::Vector3d& v) { return fmt::format("{:.17g} {:.17g} {:.17g}", v.x(), v.y(), v.z()); }

std::string rpy(const Eigen::Matrix3d& R) {
  // URDF: R = Rz(yaw) Ry(pitch) Rx(roll).
  const double pitch = std::asin(std::clamp(-R(2, 0), -1.0, 1.0));
  const double roll = std::atan2(R(2, 1), R(2, 2));
  const double yaw = std::atan2(R(1, 0), R(0, 0));
  return fmt::format("{:.17g} {:.17g} {:.17g}", roll, pitch, yaw);
}

}  // namespace

std::string random_cuts_xml(const std::string& urdf_text, const RandomCutOptions& options) {
  const ir::Robot robot = urdf::read_robot_string(urdf_text, "random.urdf");
  const std::vector<reference::LinkPose> poses =
      reference::link_poses(robot, reference::neutral_configuration(robot));
  // Links carried directly by a moving joint (so k and l on different joints
  // are on different bodies), and the base.
  std::vector<int> candidates;
  for (const ir::Joint& j : robot.joints)
    if (j.type != ir::JointType::Fixed) candidates.push_back(j.child_link);
  if (candidates.empty()) throw std::invalid_argument("random_cuts_xml: no moving links");
  candidates.push_back(robot.root_link);
  static const char* kTypes[] = {"spherical", "revolute", "prismatic", "cylindrical", "universal", "fixed", "distance"};
  Rng rng{options.seed * 0x9E3779B97F4A7C15ULL + 1};
  std::string out = "<?xml version=\"1.0\"?>\n<loop_joints>\n";
  for (int c = 0; c < options.num_cuts; ++c) {
    const char* type = kTypes[(options.seed + c) % 7];
    int k = candidates[rng.index(static_cast<int>(candidates.size()))];
    int l = k;
    while (l == k) l = candidates[rng.index(static_cast<int>(candidates.size()))];
    if (k == robot.root_link) std::swap(k, l);  // keep the moving link as k when there is one
    const reference::LinkPose& Pk = poses[k];
    const reference::LinkPose& Pl = poses[l];
    // One world frame F between the two links; its placement on each.
    const Eigen::Vector3d p_WF = 0.5 * (Pk.p_WL + Pl.p_WL) +
                                 Eigen::Vector3d(rng.uniform(-0.2, 0.2), rng.uniform(-0.2, 0.2), rng.uniform(-0.2, 0.2));
    const Eigen::Matrix3d R_WF = rng.rotation();
    const Eigen::Matrix3d R_kF = Pk.R_WL.transpose() * R_WF, R_lF = Pl.R_WL.transpose() * R_WF;
    const Eigen::Vector3d p_kF = Pk.R_WL.transpose() * (p_WF - Pk.p_WL);
    Eigen::Vector3d p_lF = Pl.R_WL.transpose() * (p_WF - Pl.p_WL);
    out += fmt::format("  <loop_joint name=\"cut_{}\" type=\"{}\">\n", c, type);
    out += fmt::format("    <parent link=\"{}\"/>\n    <child link=\"{}\"/>\n", robot.links[k].name, robot.links[l].name);
    out += fmt::format("    <origin xyz=\"{}\" rpy=\"{}\"/>\n", xyz(p_kF), rpy(R_kF));
    if (std::string(type) == "distance") {
      // A second point on l, 0.3 to 0.6 m away from the first.
      const Eigen::Vector3d offset = rng.unit() * rng.uniform(0.3, 0.6);
      p_lF = Pl.R_WL.transpose() * (p_WF + offset - Pl.p_WL);
    }
    out += fmt::format("    <child_origin xyz=\"{}\" rpy=\"{}\"/>\n", xyz(p_lF), rpy(R_lF));
    const Eigen::Vector3d axis = rng.unit();  // in F, the same in both frames at q = 0
    out += fmt::format("    <axis xyz=\"{}\"/>\n", xyz(axis));
    if (std::string(type) == "universal") {
      const Eigen::Vector3d child_axis = axis.cross(rng.unit()).normalized();
      out += fmt::format("    <child_axis xyz=\"{}\"/>\n", xyz(child_axis));
    }
    out += "  </loop_joint>\n";
  }
  out += "</loop_joints>\n";
  return out;
}

}  // namespace jrgen::testing
