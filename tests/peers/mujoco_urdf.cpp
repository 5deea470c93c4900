#include "mujoco_urdf.hpp"

#include <mujoco/mujoco.h>
#include <tinyxml.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace jrgen::peers {

std::string mujoco_unsupported(const ir::Robot& robot) {
  if (!robot.cuts.empty()) return "closed loops (the peers run without constraints)";
  for (const ir::Joint& j : robot.joints) {
    if (j.type == ir::JointType::Ball || j.type == ir::JointType::Planar)
      return std::string("a ") + ir::joint_type_name(j.type) + " joint (" + j.name +
             "): not standard URDF, not mapped";
    if (j.type == ir::JointType::Floating &&
        (j.parent_link != robot.root_link || !j.origin.p.isZero(0) || !j.origin.R.isIdentity(0)))
      return "floating joint " + j.name + " not at the identity on the root link";
  }
  return "";
}

namespace {

Eigen::Vector3d read3(const TiXmlElement* e, const char* attr) {
  Eigen::Vector3d x = Eigen::Vector3d::Zero();
  if (const char* t = e ? e->Attribute(attr) : nullptr) std::istringstream(t) >> x[0] >> x[1] >> x[2];
  return x;
}

std::string num(double x) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

// Rewrites an <inertial> in its principal axes: <origin rpy> the rotation of
// the eigenvectors (computed here in double), <inertia> diagonal.  The same
// inertia, but MuJoCo then has nothing to diagonalize: its own iterative
// diagonalization of a full tensor stops near 1e-10 relative, and a tensor
// whose principal moments violate the triangle inequality by that much is
// rejected (URDF rpy: R = Rz(yaw) Ry(pitch) Rx(roll)).
void principal_axes(TiXmlElement* inertial) {
  TiXmlElement* origin = inertial->FirstChildElement("origin");
  TiXmlElement* inertia = inertial->FirstChildElement("inertia");
  if (!inertia) return;
  auto get = [&](const char* a) {
    double x = 0;
    inertia->QueryDoubleAttribute(a, &x);
    return x;
  };
  Eigen::Matrix3d I;
  I << get("ixx"), get("ixy"), get("ixz"), get("ixy"), get("iyy"), get("iyz"), get("ixz"), get("iyz"), get("izz");
  const Eigen::Vector3d rpy = read3(origin, "rpy");
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(R * I * R.transpose());
  Eigen::Matrix3d V = eig.eigenvectors();
  if (V.determinant() < 0) V.col(2) = -V.col(2);
  const Eigen::Vector3d ypr = V.eulerAngles(2, 1, 0);  // V = Rz(ypr0) Ry(ypr1) Rx(ypr2)
  TiXmlElement o("origin");
  const Eigen::Vector3d xyz = read3(origin, "xyz");
  o.SetAttribute("xyz", num(xyz[0]) + " " + num(xyz[1]) + " " + num(xyz[2]));
  o.SetAttribute("rpy", num(ypr[2]) + " " + num(ypr[1]) + " " + num(ypr[0]));
  if (origin) inertial->RemoveChild(origin);
  inertial->InsertEndChild(o);
  const char* names[6] = {"ixx", "iyy", "izz", "ixy", "ixz", "iyz"};
  for (int k = 0; k < 6; ++k) inertia->SetAttribute(names[k], k < 3 ? num(eig.eigenvalues()[k]) : "0");
}

}  // namespace

std::string mujoco_urdf_text(const std::string& urdf_path, const std::string& compiler_extra) {
  TiXmlDocument doc(urdf_path.c_str());
  if (!doc.LoadFile()) return "";
  TiXmlElement* robot = doc.RootElement();
  for (TiXmlElement* link = robot->FirstChildElement("link"); link; link = link->NextSiblingElement("link"))
  {
    for (const char* tag : {"visual", "collision"})
      while (TiXmlElement* e = link->FirstChildElement(tag)) link->RemoveChild(e);
    if (TiXmlElement* inertial = link->FirstChildElement("inertial")) principal_axes(inertial);
  }
  for (const char* tag : {"gazebo", "transmission"})
    while (TiXmlElement* e = robot->FirstChildElement(tag)) robot->RemoveChild(e);
  TiXmlElement compiler("compiler");
  compiler.SetAttribute("discardvisual", "true");
  compiler.SetAttribute("fusestatic", "true");
  std::istringstream extra(compiler_extra);
  for (std::string kv; extra >> kv;) {
    const auto eq = kv.find('=');
    if (eq != std::string::npos) compiler.SetAttribute(kv.substr(0, eq), kv.substr(eq + 1));
  }
  TiXmlElement mujoco("mujoco");
  mujoco.InsertEndChild(compiler);
  if (robot->FirstChild())
    robot->InsertBeforeChild(robot->FirstChild(), mujoco);
  else
    robot->InsertEndChild(mujoco);
  TiXmlPrinter printer;
  doc.Accept(&printer);
  return printer.CStr();
}

MujocoForward::MujocoForward(const std::string& urdf_path, const std::string& compiler_extra,
                             const std::string& mj_urdf_path, const JointLayout& layout)
    : layout_(layout) {
  const std::string text = mujoco_urdf_text(urdf_path, compiler_extra);
  if (text.empty()) {
    error_ = "cannot read " + urdf_path;
    return;
  }
  std::ofstream(mj_urdf_path) << text;
  char err[1000] = "";
  m_ = mj_loadXML(mj_urdf_path.c_str(), nullptr, err, sizeof err);
  if (!m_) {
    error_ = std::string("mj_loadXML: ") + err;
    return;
  }
  int nq = 0, nv = 0;
  for (std::size_t j = 0; j < layout.names.size(); ++j) {
    nq += layout.nq[j], nv += layout.nv[j];
    const int id = mj_name2id(m_, mjOBJ_JOINT, layout.names[j].c_str());
    if (id < 0) {
      error_ = "MuJoCo has no joint " + layout.names[j];
      return;
    }
    qadr_.push_back(m_->jnt_qposadr[id]);
    dadr_.push_back(m_->jnt_dofadr[id]);
  }
  if (m_->nq != nq || m_->nv != nv) {
    error_ = "MuJoCo's nq/nv " + std::to_string(m_->nq) + "/" + std::to_string(m_->nv) + " differ from jrgen's";
    return;
  }
  for (int i = 0; i < m_->nv; ++i) {
    passive_ = passive_ || m_->dof_damping[i] != 0;
    if (m_->dof_armature[i] != 0) {
      error_ = "MuJoCo's model has armature (jrgen's has none)";
      return;
    }
  }
  m_->opt.disableflags = mjDSBL_CONSTRAINT | mjDSBL_EQUALITY | mjDSBL_FRICTIONLOSS | mjDSBL_LIMIT |
                         mjDSBL_CONTACT | mjDSBL_ACTUATION | mjDSBL_CLAMPCTRL | mjDSBL_SENSOR |
                         mjDSBL_WARMSTART | (passive_ ? 0 : mjDSBL_PASSIVE);
  m_->opt.enableflags = 0;
  d_ = mj_makeData(m_);
}

MujocoForward::~MujocoForward() {
  if (d_) mj_deleteData(d_);
  if (m_) mj_deleteModel(m_);
}

void MujocoForward::set_state(const double* q, const double* v, const double* tau) {
  for (std::size_t j = 0; j < qadr_.size(); ++j) {
    for (int k = 0; k < layout_.nq[j]; ++k) d_->qpos[qadr_[j] + k] = q[layout_.q0[j] + k];
    for (int k = 0; k < layout_.nv[j]; ++k) {
      d_->qvel[dadr_[j] + k] = v[layout_.v0[j] + k];
      d_->qfrc_applied[dadr_[j] + k] = tau[layout_.v0[j] + k];
    }
  }
}

void MujocoForward::forward() { mj_forward(m_, d_); }

void MujocoForward::qdd(double* out) const {
  for (std::size_t j = 0; j < dadr_.size(); ++j)
    for (int k = 0; k < layout_.nv[j]; ++k) out[layout_.v0[j] + k] = d_->qacc[dadr_[j] + k];
}

}  // namespace jrgen::peers
