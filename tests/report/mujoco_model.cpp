#include "mujoco_model.hpp"

#include <mujoco/mujoco.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace jrgen::report {

namespace {

std::string num(double x) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

std::string vec(const Eigen::Vector3d& v) { return num(v[0]) + " " + num(v[1]) + " " + num(v[2]); }

std::string quat(const Eigen::Matrix3d& R) {
  const Eigen::Quaterniond q(R);
  return num(q.w()) + " " + num(q.x()) + " " + num(q.y()) + " " + num(q.z());
}

std::string joint_name(int body_lem, const char* suffix = "") {
  std::string name = "b";
  name += std::to_string(body_lem);
  name += suffix;
  return name;
}

void write_body(const topology::Tree& tree, int b, int indent, std::ostringstream& out) {
  const topology::Body& body = tree.bodies[b];
  const std::string pad(indent, ' ');
  out << pad << "<body name=\"" << joint_name(b) << "\" pos=\"" << vec(body.X_PJ.p) << "\" quat=\""
      << quat(body.X_PJ.R) << "\">\n";
  // Principal axes computed here in double precision: MuJoCo's own
  // diagonalization of fullinertia (mju_eig3, iterative) stops at a relative
  // accuracy near 1e-10, which would dominate the comparison of M.
  const ir::Inertial& in = body.inertial;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(in.I_com);
  Eigen::Matrix3d R = eig.eigenvectors();
  if (R.determinant() < 0) R.col(2) = -R.col(2);
  out << pad << "  <inertial pos=\"" << vec(in.com) << "\" quat=\"" << quat(R) << "\" mass=\"" << num(in.mass)
      << "\" diaginertia=\"" << vec(eig.eigenvalues()) << "\"/>\n";
  const std::string common =
      "\" pos=\"0 0 0\" armature=\"0\" damping=\"" + num(body.damping) + "\" limited=\"false\"";
  switch (body.type) {
    case ir::JointType::Revolute:
    case ir::JointType::Continuous:
      out << pad << "  <joint name=\"" << joint_name(b) << "\" type=\"hinge\" axis=\"" << vec(body.axis) << common
          << "/>\n";
      break;
    case ir::JointType::Prismatic:
      out << pad << "  <joint name=\"" << joint_name(b) << "\" type=\"slide\" axis=\"" << vec(body.axis) << common
          << "/>\n";
      break;
    case ir::JointType::Ball:
      out << pad << "  <joint name=\"" << joint_name(b) << "\" type=\"ball" << common << "/>\n";
      break;
    case ir::JointType::Floating:
      // <joint type="free"> rather than <freejoint>: it takes damping.
      out << pad << "  <joint name=\"" << joint_name(b) << "\" type=\"free\" damping=\"" << num(body.damping)
          << "\"/>\n";
      break;
    case ir::JointType::Planar:
      out << pad << "  <joint name=\"" << joint_name(b, "_1") << "\" type=\"slide\" axis=\"" << vec(body.e1)
          << common << "/>\n";
      out << pad << "  <joint name=\"" << joint_name(b, "_2") << "\" type=\"slide\" axis=\"" << vec(body.e2)
          << common << "/>\n";
      out << pad << "  <joint name=\"" << joint_name(b) << "\" type=\"hinge\" axis=\"" << vec(body.axis) << common
          << "/>\n";
      break;
    case ir::JointType::Fixed:
      break;
  }
  for (int c : body.children_lem) write_body(tree, c, indent + 2, out);
  out << pad << "</body>\n";
}

}  // namespace

MujocoModel::MujocoModel(const topology::Tree& tree, const std::string& mjcf_path) : tree_(tree) {
  std::ostringstream out;
  // No geoms: inertias come from <inertial> only; no gravity or contacts
  // matter for M.
  out << "<mujoco model=\"jrgen_report\">\n"
         "  <compiler angle=\"radian\" inertiafromgeom=\"false\" balanceinertia=\"false\" boundmass=\"0\" "
         "boundinertia=\"0\"/>\n"
         "  <option timestep=\"0.001\"/>\n"
         "  <worldbody>\n";
  std::vector<int> roots;
  for (int b = 0; b < static_cast<int>(tree.bodies.size()); ++b)
    if (tree.bodies[b].parent_lem < 0) roots.push_back(b);
  std::sort(roots.begin(), roots.end(),
            [&](int a, int b) { return tree.bodies[a].joint_user < tree.bodies[b].joint_user; });
  for (int r : roots) write_body(tree, r, 4, out);
  out << "  </worldbody>\n</mujoco>\n";
  std::ofstream(mjcf_path) << out.str();

  char err[1000] = "";
  m_ = mj_loadXML(mjcf_path.c_str(), nullptr, err, sizeof err);
  if (!m_) {
    error_ = err;
    return;
  }
  bool damping = false;
  for (int i = 0; i < m_->nv; ++i) damping = damping || m_->dof_damping[i] != 0;
  m_->opt.disableflags = mjDSBL_CONSTRAINT | mjDSBL_EQUALITY | mjDSBL_FRICTIONLOSS | mjDSBL_LIMIT |
                         mjDSBL_CONTACT | mjDSBL_ACTUATION | mjDSBL_CLAMPCTRL | mjDSBL_SENSOR |
                         mjDSBL_WARMSTART | (damping ? 0 : mjDSBL_PASSIVE);
  d_ = mj_makeData(m_);
  // v_jrgen = P v_mujoco: a permutation, with the free joints' linear part
  // rotated from world to the joint frame.
  P_ = Eigen::MatrixXd::Zero(tree.nv, m_->nv);
  for (int b = 0; b < static_cast<int>(tree.bodies.size()); ++b) {
    const topology::Body& body = tree.bodies[b];
    if (body.type == ir::JointType::Planar) {
      const char* names[3] = {"_1", "_2", ""};
      for (int k = 0; k < 3; ++k) {
        const int j = mj_name2id(m_, mjOBJ_JOINT, joint_name(b, names[k]).c_str());
        P_(body.v_user + k, m_->jnt_dofadr[j]) = 1.0;
      }
      continue;
    }
    const int j = mj_name2id(m_, mjOBJ_JOINT, joint_name(b).c_str());
    const int dof = m_->jnt_dofadr[j];
    if (body.type == ir::JointType::Floating) {
      P_.block<3, 3>(body.v_user, dof) = body.X_PJ.R.transpose();
      P_.block<3, 3>(body.v_user + 3, dof + 3).setIdentity();
    } else {
      for (int k = 0; k < body.nv; ++k) P_(body.v_user + k, dof + k) = 1.0;
    }
  }
}

MujocoModel::~MujocoModel() {
  if (d_) mj_deleteData(d_);
  if (m_) mj_deleteModel(m_);
}

int MujocoModel::nv() const { return m_ ? m_->nv : 0; }

void MujocoModel::set_configuration(const Eigen::VectorXd& q) {
  set_qpos(q);
  for (int i = 0; i < m_->nv; ++i) d_->qvel[i] = 0;
  mj_forward(m_, d_);
}

void MujocoModel::set_state(const Eigen::VectorXd& q, const Eigen::VectorXd& v, const Eigen::VectorXd& tau) {
  set_qpos(q);
  Eigen::Map<Eigen::VectorXd>(d_->qvel, m_->nv) = P_.transpose() * v;
  Eigen::Map<Eigen::VectorXd>(d_->qfrc_applied, m_->nv) = P_.transpose() * tau;
}

void MujocoModel::forward() { mj_forward(m_, d_); }

Eigen::VectorXd MujocoModel::qdd() const { return P_ * Eigen::Map<const Eigen::VectorXd>(d_->qacc, m_->nv); }

void MujocoModel::set_qpos(const Eigen::VectorXd& q) {
  for (int b = 0; b < static_cast<int>(tree_.bodies.size()); ++b) {
    const topology::Body& body = tree_.bodies[b];
    const int j = mj_name2id(m_, mjOBJ_JOINT, joint_name(b).c_str());
    double* qpos = d_->qpos + m_->jnt_qposadr[j];
    const double* qj = q.data() + body.q_user;
    switch (body.type) {
      case ir::JointType::Floating: {
        // MuJoCo: world position and orientation of the body.
        const Eigen::Vector3d p = body.X_PJ.p + body.X_PJ.R * Eigen::Vector3d(qj[0], qj[1], qj[2]);
        const Eigen::Quaterniond rel = Eigen::Quaterniond(qj[3], qj[4], qj[5], qj[6]).normalized();
        const Eigen::Quaterniond w = Eigen::Quaterniond(body.X_PJ.R) * rel;
        qpos[0] = p[0], qpos[1] = p[1], qpos[2] = p[2];
        qpos[3] = w.w(), qpos[4] = w.x(), qpos[5] = w.y(), qpos[6] = w.z();
        break;
      }
      case ir::JointType::Ball: {
        const Eigen::Quaterniond rel = Eigen::Quaterniond(qj[0], qj[1], qj[2], qj[3]).normalized();
        qpos[0] = rel.w(), qpos[1] = rel.x(), qpos[2] = rel.y(), qpos[3] = rel.z();
        break;
      }
      case ir::JointType::Planar: {
        const int j1 = mj_name2id(m_, mjOBJ_JOINT, joint_name(b, "_1").c_str());
        const int j2 = mj_name2id(m_, mjOBJ_JOINT, joint_name(b, "_2").c_str());
        d_->qpos[m_->jnt_qposadr[j1]] = qj[0];
        d_->qpos[m_->jnt_qposadr[j2]] = qj[1];
        qpos[0] = qj[2];
        break;
      }
      default:
        qpos[0] = qj[0];
        break;
    }
  }
}

Eigen::MatrixXd MujocoModel::dense_mass_matrix() const {
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> M(m_->nv, m_->nv);
  mj_fullM(m_, M.data(), d_->qM);
  return M;
}

void MujocoModel::factor_and_solve(const double* rhs, double* x) {
  mj_factorM(m_, d_);
  mj_solveM(m_, d_, x, rhs, 1);
}

}  // namespace jrgen::report
