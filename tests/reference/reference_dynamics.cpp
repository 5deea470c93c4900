// Reference tree dynamics in the world frame; see reference_dynamics.hpp.
//
// Notation (all vectors in world coordinates W unless suffixed otherwise):
//   P, J, C     parent link frame, joint frame (fixed on P), child link frame
//   R_WJ, p_WJ  placement of J in W;  R_JC, p_JC the joint's own motion X_JC(q)
//   w_P, a_P    angular velocity / angular acceleration of link P
//   v_P, acc_P  velocity / acceleration of P's origin
//   Cm          a link's centre of mass
//
// Derivation of the world-frame recursion used below (local numbers (a)-(f)).
// For a joint with parent P and child C, X_PC = X_PJ * X_JC(q) with
// X_JC = Trans(t_J(q)) Rot(R_JC(q)) (conventions.md, "translate then rotate"):
//
//   (a) p_WC = p_WJ + R_WJ t_J,   R_WC = R_WJ R_JC
//   (b) w_C  = w_P + w_rel,  w_rel = sum_i s_i v_i  (s_i the world direction of
//       the i-th angular coordinate: R_WJ axis for revolute/planar, R_WC e_i for
//       ball/floating, whose v is expressed in C)
//   (c) v_C  = v_P + w_P x (p_WC - p_WP) + R_WJ td_J,  td_J = sum_i l_i v_i (l_i
//       the joint-frame direction of the i-th translational coordinate: prismatic
//       axis, floating e_i, planar e1/e2; all constant in J)
//   (d) a_C  = a_P + w_P x w_rel + sum_i s_i qdd_i.  The w_P x w_rel term is the
//       time derivative of the directions s_i: for axes fixed in J, d s/dt =
//       w_P x s; for axes fixed in C, d s/dt = w_C x s and w_C x w_rel =
//       (w_P + w_rel) x w_rel = w_P x w_rel, so both cases give the same term.
//   (e) acc_C = acc_P + a_P x d + w_P x (w_P x d) + 2 w_P x (R_WJ td_J)
//               + R_WJ tdd_J,   d = p_WC - p_WP,  tdd_J = sum_i l_i qdd_i
//       (differentiate (c): d/dt d = w_P x d + R_WJ td_J, d/dt (R_WJ td_J) =
//       w_P x R_WJ td_J + R_WJ tdd_J).
//   (f) A point r fixed on C (world position p_r) moves with
//       v_r = v_C + w_C x (p_r - p_WC),
//       acc_r = acc_C + a_C x (p_r - p_WC) + w_C x (w_C x (p_r - p_WC)).
//
// Geometric Jacobian of a point r on link L (column k, velocity coordinate k of
// a joint on the path root -> L): an angular coordinate with world direction
// s_k rotates everything below about the child origin p_WC of its joint, so its
// column is [s_k x (p_r - p_WC); s_k]; a translational coordinate moves it
// along R_WJ l_k, column [R_WJ l_k; 0].  Coordinates of joints not on the path
// give zero columns.
//
// Dynamics (Newton-Euler in W, projected onto the generalized coordinates by
// the principle of virtual power):
//   M   = sum_L J_Cm^T diag(m I3, I_W) J_Cm,                    I_W = R_WL I_com R_WL^T
//   h   = sum_L J_Cm^T [m (acc_Cm - g); I_W a_L + w_L x I_W w_L]  (at qdd = 0)
//         + damping * v
#include "reference_dynamics.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <cmath>
#include <stdexcept>
#include <string>

namespace jrgen::reference {

namespace {

using Eigen::Matrix3d;
using Eigen::MatrixXd;
using Eigen::Quaterniond;
using Eigen::Vector3d;
using Eigen::VectorXd;
using ir::JointType;

/// Index maps of a robot, in user order.
struct Layout {
  std::vector<int> joint_q_index;        ///< first q coordinate of each joint
  std::vector<int> joint_v_index;        ///< first v coordinate of each joint
  std::vector<int> link_parent_joint;    ///< joint whose child is the link; -1 for the root
  std::vector<int> joint_parent_first;   ///< joint indices, every parent link's joint first
  int nq = 0;
  int nv = 0;
};

Layout make_layout(const ir::Robot& robot) {
  Layout layout;
  const int nlinks = static_cast<int>(robot.links.size());
  const int njoints = static_cast<int>(robot.joints.size());
  if (robot.root_link < 0 || robot.root_link >= nlinks)
    throw std::invalid_argument("reference: robot.root_link out of range");
  layout.link_parent_joint.assign(nlinks, -1);
  std::vector<std::vector<int>> link_child_joints(nlinks);
  // Offsets of q and v in user order (joint order as stored).
  for (int j = 0; j < njoints; ++j) {
    const ir::Joint& joint = robot.joints[j];
    if (joint.parent_link < 0 || joint.parent_link >= nlinks || joint.child_link < 0 ||
        joint.child_link >= nlinks)
      throw std::invalid_argument("reference: joint '" + joint.name + "' has a bad link index");
    if (joint.child_link == robot.root_link || layout.link_parent_joint[joint.child_link] != -1)
      throw std::invalid_argument("reference: link of joint '" + joint.name +
                                  "' has two parents or is the root");
    layout.link_parent_joint[joint.child_link] = j;
    link_child_joints[joint.parent_link].push_back(j);
    layout.joint_q_index.push_back(layout.nq);
    layout.joint_v_index.push_back(layout.nv);
    layout.nq += ir::joint_nq(joint.type);
    layout.nv += ir::joint_nv(joint.type);
  }
  // Processing order: depth-first from the root, so that a joint's parent link
  // is placed before the joint (does not rely on the stored order).
  std::vector<int> stack{robot.root_link};
  while (!stack.empty()) {
    const int link = stack.back();
    stack.pop_back();
    const std::vector<int>& kids = link_child_joints[link];
    for (auto it = kids.rbegin(); it != kids.rend(); ++it) {
      layout.joint_parent_first.push_back(*it);
      stack.push_back(robot.joints[*it].child_link);
    }
  }
  if (static_cast<int>(layout.joint_parent_first.size()) != njoints)
    throw std::invalid_argument("reference: joints do not form a tree from the root link");
  return layout;
}

void check_size(const VectorXd& x, int expected, const char* what) {
  if (x.size() != expected)
    throw std::invalid_argument(std::string("reference: ") + what + " has size " +
                                std::to_string(x.size()) + ", expected " +
                                std::to_string(expected));
}

/// Unit quaternion from 4 coordinates w, x, y, z (normalized before use).
Quaterniond quat_at(const VectorXd& q, int i) {
  Quaterniond quat(q[i], q[i + 1], q[i + 2], q[i + 3]);
  const double n = quat.norm();
  if (!(n > 0.0)) throw std::invalid_argument("reference: zero quaternion in q");
  quat.coeffs() /= n;
  return quat;
}

/// exp of the pure quaternion (0, phi / 2): rotation by |phi| about phi.
Quaterniond quat_exp(const Vector3d& phi) {
  const double half = 0.5 * phi.norm();
  // sin(half) / |phi| = 0.5 * sinc(half); Taylor series below 1e-4 (error < 1e-17).
  const double k = half < 1e-4 ? 0.5 * (1.0 - half * half / 6.0) : std::sin(half) / phi.norm();
  return Quaterniond(std::cos(half), k * phi.x(), k * phi.y(), k * phi.z());
}

/// Planar joints: normal n, in-plane e1, e2 of the joint frame (cyclic order,
/// picked by the dominant component of the axis).
void planar_basis(const Vector3d& axis, Vector3d& e1, Vector3d& e2) {
  int k = 0;
  axis.cwiseAbs().maxCoeff(&k);
  e1 = Vector3d::Unit((k + 1) % 3);
  e2 = Vector3d::Unit((k + 2) % 3);
}

/// Motion of one joint: X_JC(q) and the directions of its coordinates.
struct JointMotion {
  Vector3d t_J = Vector3d::Zero();  ///< p_JC, translation in J
  Matrix3d R_JC = Matrix3d::Identity();
  // For velocity coordinate i of the joint (i < nv):
  bool angular[6] = {false, false, false, false, false, false};
  Vector3d dir[6];                  ///< l_i in J (translational) or s_i in C or J (angular)
  bool dir_in_child[6] = {false, false, false, false, false, false};  ///< s_i given in C
};

JointMotion joint_motion(const ir::Joint& joint, const VectorXd& q, int iq) {
  JointMotion m;
  switch (joint.type) {
    case JointType::Fixed: break;
    case JointType::Revolute:
    case JointType::Continuous: {
      const Vector3d n = joint.axis.normalized();
      m.R_JC = Eigen::AngleAxisd(q[iq], n).toRotationMatrix();
      m.angular[0] = true;
      m.dir[0] = n;
      break;
    }
    case JointType::Prismatic: {
      const Vector3d n = joint.axis.normalized();
      m.t_J = n * q[iq];
      m.dir[0] = n;
      break;
    }
    case JointType::Ball: {
      m.R_JC = quat_at(q, iq).toRotationMatrix();
      for (int i = 0; i < 3; ++i) {
        m.angular[i] = true;
        m.dir[i] = Vector3d::Unit(i);
        m.dir_in_child[i] = true;
      }
      break;
    }
    case JointType::Floating: {
      m.t_J = q.segment<3>(iq);
      m.R_JC = quat_at(q, iq + 3).toRotationMatrix();
      for (int i = 0; i < 3; ++i) {
        m.dir[i] = Vector3d::Unit(i);
        m.angular[3 + i] = true;
        m.dir[3 + i] = Vector3d::Unit(i);
        m.dir_in_child[3 + i] = true;
      }
      break;
    }
    case JointType::Planar: {
      const Vector3d n = joint.axis.normalized();
      Vector3d e1, e2;
      planar_basis(n, e1, e2);
      m.t_J = q[iq] * e1 + q[iq + 1] * e2;
      m.R_JC = Eigen::AngleAxisd(q[iq + 2], n).toRotationMatrix();
      m.dir[0] = e1;
      m.dir[1] = e2;
      m.angular[2] = true;
      m.dir[2] = n;
      break;
    }
  }
  return m;
}

/// Per joint, world-frame quantities needed by the Jacobian.
struct JointPlacement {
  Matrix3d R_WJ = Matrix3d::Identity();
  Vector3d p_WC = Vector3d::Zero();  ///< child origin, the centre of the joint's rotations
  JointMotion motion;
  Matrix3d R_WC = Matrix3d::Identity();
};

/// Link poses (a) and the per-joint placements, from the root down.
void place(const ir::Robot& robot, const Layout& layout, const VectorXd& q,
           std::vector<LinkPose>& poses, std::vector<JointPlacement>& joints) {
  check_size(q, layout.nq, "q");
  poses.assign(robot.links.size(), LinkPose{});
  joints.assign(robot.joints.size(), JointPlacement{});
  for (int j : layout.joint_parent_first) {
    const ir::Joint& joint = robot.joints[j];
    const LinkPose& P = poses[joint.parent_link];
    JointPlacement& jp = joints[j];
    jp.motion = joint_motion(joint, q, layout.joint_q_index[j]);
    // X_WJ = X_WP X_PJ, then (a).
    jp.R_WJ = P.R_WL * joint.origin.R;
    const Vector3d p_WJ = P.p_WL + P.R_WL * joint.origin.p;
    jp.p_WC = p_WJ + jp.R_WJ * jp.motion.t_J;
    jp.R_WC = jp.R_WJ * jp.motion.R_JC;
    poses[joint.child_link] = LinkPose{jp.R_WC, jp.p_WC};
  }
}

/// World direction of velocity coordinate i of a placed joint: s_i (angular) or R_WJ l_i.
Vector3d world_direction(const JointPlacement& jp, int i) {
  return jp.motion.dir_in_child[i] ? Vector3d(jp.R_WC * jp.motion.dir[i])
                                   : Vector3d(jp.R_WJ * jp.motion.dir[i]);
}

/// Geometric Jacobian of world point p_r fixed on `link` (see the header comment).
MatrixXd jacobian_at(const ir::Robot& robot, const Layout& layout,
                     const std::vector<JointPlacement>& joints, int link, const Vector3d& p_r) {
  MatrixXd Jac = MatrixXd::Zero(6, layout.nv);
  for (int j = layout.link_parent_joint[link]; j >= 0;
       j = layout.link_parent_joint[robot.joints[j].parent_link]) {
    const JointPlacement& jp = joints[j];
    const int nvj = ir::joint_nv(robot.joints[j].type);
    for (int i = 0; i < nvj; ++i) {
      const int col = layout.joint_v_index[j] + i;
      const Vector3d s = world_direction(jp, i);
      if (jp.motion.angular[i]) {
        // Rotation about the axis s through the child origin.
        Jac.block<3, 1>(0, col) = s.cross(p_r - jp.p_WC);
        Jac.block<3, 1>(3, col) = s;
      } else {
        Jac.block<3, 1>(0, col) = s;
      }
    }
  }
  return Jac;
}

/// Recursion (a)-(e) from the root; qdd empty means zero.
std::vector<LinkMotion> motions(const ir::Robot& robot, const Layout& layout, const VectorXd& q,
                                const VectorXd& v, const VectorXd& qdd) {
  check_size(v, layout.nv, "v");
  if (qdd.size() != 0) check_size(qdd, layout.nv, "qdd");
  std::vector<LinkPose> poses;
  std::vector<JointPlacement> joints;
  place(robot, layout, q, poses, joints);
  std::vector<LinkMotion> out(robot.links.size());
  for (std::size_t l = 0; l < out.size(); ++l) {
    out[l].R_WL = poses[l].R_WL;
    out[l].p_WL = poses[l].p_WL;
  }
  for (int j : layout.joint_parent_first) {
    const ir::Joint& joint = robot.joints[j];
    const JointPlacement& jp = joints[j];
    const LinkMotion& P = out[joint.parent_link];
    LinkMotion& C = out[joint.child_link];
    // Sums over the joint's coordinates: w_rel (b), R_WJ td_J (c), and the qdd
    // parts of (d) and (e).
    Vector3d w_rel = Vector3d::Zero(), td_W = Vector3d::Zero();
    Vector3d a_qdd = Vector3d::Zero(), tdd_W = Vector3d::Zero();
    const int nvj = ir::joint_nv(joint.type);
    for (int i = 0; i < nvj; ++i) {
      const int k = layout.joint_v_index[j] + i;
      const Vector3d s = world_direction(jp, i);
      const double qdd_k = qdd.size() ? qdd[k] : 0.0;
      if (jp.motion.angular[i]) {
        w_rel += s * v[k];
        a_qdd += s * qdd_k;
      } else {
        td_W += s * v[k];
        tdd_W += s * qdd_k;
      }
    }
    const Vector3d d = C.p_WL - P.p_WL;
    C.omega = P.omega + w_rel;                                          // (b)
    C.vel = P.vel + P.omega.cross(d) + td_W;                            // (c)
    C.alpha = P.alpha + P.omega.cross(w_rel) + a_qdd;                   // (d)
    C.acc = P.acc + P.alpha.cross(d) + P.omega.cross(P.omega.cross(d))  // (e)
            + 2.0 * P.omega.cross(td_W) + tdd_W;
  }
  return out;
}

/// Newton-Euler sum_L J_Cm^T [m (acc_Cm - g); I_W a + w x I_W w] over non-root links.
VectorXd newton_euler(const ir::Robot& robot, const Layout& layout, const VectorXd& q,
                      const VectorXd& v, const VectorXd& qdd, const Vector3d& gravity) {
  const std::vector<LinkMotion> mo = motions(robot, layout, q, v, qdd);
  std::vector<LinkPose> poses;
  std::vector<JointPlacement> joints;
  place(robot, layout, q, poses, joints);
  VectorXd tau = VectorXd::Zero(layout.nv);
  for (std::size_t l = 0; l < robot.links.size(); ++l) {
    if (static_cast<int>(l) == robot.root_link) continue;
    const ir::Inertial& in = robot.links[l].inertial;
    const LinkMotion& L = mo[l];
    // COM acceleration by (f), rotational inertia about the COM in W.
    const Vector3d r = L.R_WL * in.com;
    const Vector3d acc_Cm = L.acc + L.alpha.cross(r) + L.omega.cross(L.omega.cross(r));
    const Matrix3d I_W = L.R_WL * in.I_com * L.R_WL.transpose();
    const Vector3d f = in.mass * (acc_Cm - gravity);
    const Vector3d n = I_W * L.alpha + L.omega.cross(I_W * L.omega);
    const MatrixXd Jac = jacobian_at(robot, layout, joints, static_cast<int>(l), L.p_WL + r);
    tau += Jac.topRows<3>().transpose() * f + Jac.bottomRows<3>().transpose() * n;
  }
  // Joint damping on every velocity coordinate.
  for (std::size_t j = 0; j < robot.joints.size(); ++j) {
    const int nvj = ir::joint_nv(robot.joints[j].type);
    const int k = layout.joint_v_index[j];
    tau.segment(k, nvj) += robot.joints[j].damping * v.segment(k, nvj);
  }
  return tau;
}

}  // namespace

VectorXd neutral_configuration(const ir::Robot& robot) {
  const Layout layout = make_layout(robot);
  VectorXd q = VectorXd::Zero(layout.nq);
  for (std::size_t j = 0; j < robot.joints.size(); ++j) {
    const int iq = layout.joint_q_index[j];
    if (robot.joints[j].type == JointType::Ball) q[iq] = 1.0;
    if (robot.joints[j].type == JointType::Floating) q[iq + 3] = 1.0;
  }
  return q;
}

VectorXd random_configuration(const ir::Robot& robot, std::mt19937_64& rng) {
  const Layout layout = make_layout(robot);
  constexpr double kPi = 3.14159265358979323846;
  std::uniform_real_distribution<double> sym(-1.0, 1.0), unit(0.0, 1.0);
  // Uniform unit quaternion (Shoemake 1992, "Uniform random rotations").
  auto random_quat = [&](VectorXd& q, int i) {
    const double u1 = unit(rng), u2 = 2.0 * kPi * unit(rng), u3 = 2.0 * kPi * unit(rng);
    const double a = std::sqrt(1.0 - u1), b = std::sqrt(u1);
    q[i] = b * std::cos(u3);  // w
    q[i + 1] = a * std::sin(u2);
    q[i + 2] = a * std::cos(u2);
    q[i + 3] = b * std::sin(u3);
  };
  VectorXd q = VectorXd::Zero(layout.nq);
  for (std::size_t j = 0; j < robot.joints.size(); ++j) {
    const int iq = layout.joint_q_index[j];
    switch (robot.joints[j].type) {
      case JointType::Fixed: break;
      case JointType::Revolute:
      case JointType::Continuous: q[iq] = sym(rng); break;
      case JointType::Prismatic: q[iq] = 0.3 * sym(rng); break;
      case JointType::Ball: random_quat(q, iq); break;
      case JointType::Floating:
        for (int i = 0; i < 3; ++i) q[iq + i] = 0.3 * sym(rng);
        random_quat(q, iq + 3);
        break;
      case JointType::Planar:
        q[iq] = 0.3 * sym(rng);
        q[iq + 1] = 0.3 * sym(rng);
        q[iq + 2] = sym(rng);
        break;
    }
  }
  return q;
}

VectorXd random_velocity(const ir::Robot& robot, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> sym(-1.0, 1.0);
  VectorXd v(robot.nv());
  for (Eigen::Index i = 0; i < v.size(); ++i) v[i] = sym(rng);
  return v;
}

VectorXd integrate(const ir::Robot& robot, const VectorXd& q, const VectorXd& v, double dt) {
  const Layout layout = make_layout(robot);
  check_size(q, layout.nq, "q");
  check_size(v, layout.nv, "v");
  VectorXd out = q;
  // Normalized quat times exp(omega dt / 2), written back as w, x, y, z.
  auto step_quat = [&](int iq, int iv) {
    const Quaterniond r = quat_at(q, iq) * quat_exp(v.segment<3>(iv) * dt);
    out[iq] = r.w();
    out[iq + 1] = r.x();
    out[iq + 2] = r.y();
    out[iq + 3] = r.z();
  };
  for (std::size_t j = 0; j < robot.joints.size(); ++j) {
    const int iq = layout.joint_q_index[j], iv = layout.joint_v_index[j];
    switch (robot.joints[j].type) {
      case JointType::Fixed: break;
      case JointType::Ball: step_quat(iq, iv); break;
      case JointType::Floating:
        out.segment<3>(iq) += dt * v.segment<3>(iv);
        step_quat(iq + 3, iv + 3);
        break;
      default: {
        const int n = ir::joint_nv(robot.joints[j].type);
        out.segment(iq, n) += dt * v.segment(iv, n);
      }
    }
  }
  return out;
}

VectorXd configuration_rate(const ir::Robot& robot, const VectorXd& q, const VectorXd& v) {
  const Layout layout = make_layout(robot);
  check_size(q, layout.nq, "q");
  check_size(v, layout.nv, "v");
  VectorXd qd = VectorXd::Zero(layout.nq);
  // quat_dot = 1/2 quat (x) (0, omega_C), on the quaternion as stored.
  auto quat_rate = [&](int iq, int iv) {
    const Quaterniond quat(q[iq], q[iq + 1], q[iq + 2], q[iq + 3]);
    const Quaterniond w(0.0, v[iv], v[iv + 1], v[iv + 2]);
    const Quaterniond r = quat * w;
    qd[iq] = 0.5 * r.w();
    qd[iq + 1] = 0.5 * r.x();
    qd[iq + 2] = 0.5 * r.y();
    qd[iq + 3] = 0.5 * r.z();
  };
  for (std::size_t j = 0; j < robot.joints.size(); ++j) {
    const int iq = layout.joint_q_index[j], iv = layout.joint_v_index[j];
    switch (robot.joints[j].type) {
      case JointType::Fixed: break;
      case JointType::Ball: quat_rate(iq, iv); break;
      case JointType::Floating:
        qd.segment<3>(iq) = v.segment<3>(iv);
        quat_rate(iq + 3, iv + 3);
        break;
      default: {
        const int n = ir::joint_nv(robot.joints[j].type);
        qd.segment(iq, n) = v.segment(iv, n);
      }
    }
  }
  return qd;
}

std::vector<LinkPose> link_poses(const ir::Robot& robot, const VectorXd& q) {
  const Layout layout = make_layout(robot);
  std::vector<LinkPose> poses;
  std::vector<JointPlacement> joints;
  place(robot, layout, q, poses, joints);
  return poses;
}

std::vector<LinkMotion> link_motions(const ir::Robot& robot, const VectorXd& q,
                                     const VectorXd& v, const VectorXd& qdd) {
  return motions(robot, make_layout(robot), q, v, qdd);
}

MatrixXd link_jacobian(const ir::Robot& robot, const VectorXd& q, int link,
                       const Vector3d& point_in_link) {
  const Layout layout = make_layout(robot);
  if (link < 0 || link >= static_cast<int>(robot.links.size()))
    throw std::invalid_argument("reference: link index out of range");
  std::vector<LinkPose> poses;
  std::vector<JointPlacement> joints;
  place(robot, layout, q, poses, joints);
  const Vector3d p_r = poses[link].p_WL + poses[link].R_WL * point_in_link;
  return jacobian_at(robot, layout, joints, link, p_r);
}

Vector3d point_bias_acceleration(const ir::Robot& robot, const VectorXd& q, const VectorXd& v,
                                 int link, const Vector3d& point_in_link) {
  if (link < 0 || link >= static_cast<int>(robot.links.size()))
    throw std::invalid_argument("reference: link index out of range");
  const LinkMotion L = link_motions(robot, q, v)[link];
  // (f) at qdd = 0.
  const Vector3d r = L.R_WL * point_in_link;
  return L.acc + L.alpha.cross(r) + L.omega.cross(L.omega.cross(r));
}

Vector3d angular_bias_acceleration(const ir::Robot& robot, const VectorXd& q, const VectorXd& v,
                                   int link) {
  if (link < 0 || link >= static_cast<int>(robot.links.size()))
    throw std::invalid_argument("reference: link index out of range");
  return link_motions(robot, q, v)[link].alpha;
}

MatrixXd mass_matrix(const ir::Robot& robot, const VectorXd& q) {
  const Layout layout = make_layout(robot);
  std::vector<LinkPose> poses;
  std::vector<JointPlacement> joints;
  place(robot, layout, q, poses, joints);
  MatrixXd M = MatrixXd::Zero(layout.nv, layout.nv);
  for (std::size_t l = 0; l < robot.links.size(); ++l) {
    if (static_cast<int>(l) == robot.root_link) continue;
    const ir::Inertial& in = robot.links[l].inertial;
    const LinkPose& L = poses[l];
    // J_Cm^T diag(m I3, I_W) J_Cm at the link COM.
    const Vector3d p_Cm = L.p_WL + L.R_WL * in.com;
    const MatrixXd Jac = jacobian_at(robot, layout, joints, static_cast<int>(l), p_Cm);
    const Matrix3d I_W = L.R_WL * in.I_com * L.R_WL.transpose();
    const MatrixXd Jv = Jac.topRows<3>(), Jw = Jac.bottomRows<3>();
    M.noalias() += in.mass * Jv.transpose() * Jv;
    M.noalias() += Jw.transpose() * I_W * Jw;
  }
  return M;
}

VectorXd bias_forces(const ir::Robot& robot, const VectorXd& q, const VectorXd& v,
                     const Vector3d& gravity) {
  return newton_euler(robot, make_layout(robot), q, v, VectorXd(), gravity);
}

VectorXd inverse_dynamics(const ir::Robot& robot, const VectorXd& q, const VectorXd& v,
                          const VectorXd& qdd, const Vector3d& gravity) {
  const Layout layout = make_layout(robot);
  check_size(qdd, layout.nv, "qdd");
  return newton_euler(robot, layout, q, v, qdd, gravity);
}

VectorXd forward_dynamics(const ir::Robot& robot, const VectorXd& q, const VectorXd& v,
                          const VectorXd& tau, const Vector3d& gravity) {
  check_size(tau, robot.nv(), "tau");
  const Eigen::LLT<MatrixXd> llt(mass_matrix(robot, q));
  if (llt.info() != Eigen::Success)
    throw std::runtime_error("reference: mass matrix is not positive definite");
  return llt.solve(tau - bias_forces(robot, q, v, gravity));
}

double kinetic_energy(const ir::Robot& robot, const VectorXd& q, const VectorXd& v) {
  const std::vector<LinkMotion> mo = link_motions(robot, q, v);
  double T = 0.0;
  for (std::size_t l = 0; l < robot.links.size(); ++l) {
    if (static_cast<int>(l) == robot.root_link) continue;
    const ir::Inertial& in = robot.links[l].inertial;
    const LinkMotion& L = mo[l];
    // 1/2 m |v_Cm|^2 + 1/2 w^T I_W w, v_Cm by (f).
    const Vector3d v_Cm = L.vel + L.omega.cross(L.R_WL * in.com);
    const Matrix3d I_W = L.R_WL * in.I_com * L.R_WL.transpose();
    T += 0.5 * in.mass * v_Cm.squaredNorm() + 0.5 * L.omega.dot(I_W * L.omega);
  }
  return T;
}

double potential_energy(const ir::Robot& robot, const VectorXd& q, const Vector3d& gravity) {
  const std::vector<LinkPose> poses = link_poses(robot, q);
  double V = 0.0;
  for (std::size_t l = 0; l < robot.links.size(); ++l) {
    if (static_cast<int>(l) == robot.root_link) continue;
    const ir::Inertial& in = robot.links[l].inertial;
    V -= in.mass * gravity.dot(poses[l].p_WL + poses[l].R_WL * in.com);
  }
  return V;
}

}  // namespace jrgen::reference
