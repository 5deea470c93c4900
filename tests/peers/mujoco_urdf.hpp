// MuJoCo's mj_forward on the same URDF as a generated solver (tests/peers).
//
// MuJoCo reads the URDF itself (mj_loadXML), so this is also an independent
// reading of the model.  The copy it reads has <visual>, <collision>,
// <gazebo> and <transmission> removed (the meshes are not shipped), every
// <inertial> rewritten in its principal axes (the same inertia; see
// principal_axes in mujoco_urdf.cpp), and a
// <mujoco><compiler .../></mujoco> element added: discardvisual="true",
// fusestatic="true" (MuJoCo's default for URDF; jrgen fuses fixed joints too),
// plus the model's extra attributes (e.g. balanceinertia, boundmass) and
// those of the environment variable JRGEN_PEERS_MJ_COMPILER (peers_core.cpp).
//
// Options: contacts, joint limits, equality constraints, friction loss, the
// constraint solver, actuation and sensors disabled; passive forces (joint
// damping) kept when the model has damping, since jrgen's h holds URDF
// damping (docs/interface.md section 4).  tau goes into qfrc_applied.
//
// Coordinates (docs/interface.md section 3, docs/conventions.md): revolute,
// continuous and prismatic joints map one to one.  A floating joint whose
// origin is the identity has jrgen's coordinates exactly: position in the
// joint frame (= world) and quaternion w, x, y, z in qpos; linear velocity in
// the joint frame (MuJoCo: world) and angular velocity in the child frame
// (MuJoCo: body frame) in qvel.  Models with ball or planar joints, or a
// floating joint elsewhere, are not mapped (unsupported() says why).
#pragma once

#include <string>
#include <vector>

#include "ir/ir.hpp"
#include "peers_core.hpp"

struct mjModel_;
struct mjData_;

namespace jrgen::peers {

/// Why MuJoCo (or Pinocchio) cannot take this model with jrgen's
/// coordinates as mapped here, or "".
std::string mujoco_unsupported(const ir::Robot& robot);

/// The URDF text MuJoCo reads (see above); `compiler_extra` is a list of
/// key=value compiler attributes separated by spaces.
std::string mujoco_urdf_text(const std::string& urdf_path, const std::string& compiler_extra);

class MujocoForward {
 public:
  /// Writes mujoco_urdf_text() to `mj_urdf_path` and loads it; ok() false and
  /// error() set when MuJoCo rejects it or its layout differs from jrgen's.
  MujocoForward(const std::string& urdf_path, const std::string& compiler_extra, const std::string& mj_urdf_path,
                const JointLayout& layout);
  ~MujocoForward();
  MujocoForward(const MujocoForward&) = delete;
  MujocoForward& operator=(const MujocoForward&) = delete;

  bool ok() const { return d_ != nullptr; }
  const std::string& error() const { return error_; }
  bool passive() const { return passive_; }

  /// qpos, qvel, qfrc_applied from jrgen's q, v, tau.
  void set_state(const double* q, const double* v, const double* tau);
  /// The timed call.
  void forward();
  /// qacc of the last forward(), in jrgen's velocity layout.
  void qdd(double* out) const;

 private:
  mjModel_* m_ = nullptr;
  mjData_* d_ = nullptr;
  std::string error_;
  bool passive_ = false;
  JointLayout layout_;
  std::vector<int> qadr_, dadr_;  // per jrgen joint
};

}  // namespace jrgen::peers
