// Pinocchio's cases of the peers benchmark (tests/peers, -DJRGEN_PINOCCHIO_SOURCE):
//
//   pinocchio/aba                  aba(q, v, tau - damping v)
//   pinocchio/crba+nle+cholesky    crba, nonLinearEffects, cholesky::decompose
//                                  and solve on tau - damping v - nle
//
// Pinocchio reads the URDF itself (pinocchio::urdf::buildModel); its
// algorithms leave joint damping out, so both timed calls subtract it first
// (jrgen's h holds URDF damping).  Coordinates, converted outside the timed
// calls (docs/interface.md section 3 for jrgen's):
//   revolute, prismatic       the same
//   continuous                Pinocchio q = (cos, sin) of the angle; v, qdd the same
//   floating (free flyer)     q = (p, quaternion x, y, z, w); v = (R^T p_dot, omega),
//                             tau = (R^T f, torque): linear parts in the body frame,
//                             jrgen's in the world (the joint frame at the identity);
//                             its acceleration is spatial: p_ddot = R (a + omega x v_lin).
#include <pinocchio/algorithm/aba.hpp>
#include <pinocchio/algorithm/cholesky.hpp>
#include <pinocchio/algorithm/crba.hpp>
#include <pinocchio/algorithm/rnea.hpp>
#include <pinocchio/multibody/data.hpp>
#include <pinocchio/multibody/model.hpp>
#include <pinocchio/parsers/urdf.hpp>

#include <Eigen/Geometry>
#include <memory>

#include "peers_core.hpp"

namespace jrgen::peers {

namespace {

namespace pin = pinocchio;
using Eigen::Vector3d;
using Eigen::VectorXd;

enum class Kind { One, Continuous, FreeFlyer };

struct PinState {
  pin::Model model;
  pin::Data data;
  VectorXd q, v, tau, damping, rhs, qdd;
  std::vector<Kind> kind;
  std::vector<int> qi, vi;  // per jrgen joint: its first coordinates in Pinocchio's q and v
  JointLayout jr;
};

// Pinocchio's joint of each jrgen joint, or why they do not match.
std::string map_joints(PinState& s) {
  for (std::size_t j = 0; j < s.jr.names.size(); ++j) {
    if (!s.model.existJointName(s.jr.names[j])) return "Pinocchio has no joint " + s.jr.names[j];
    const pin::JointIndex id = s.model.getJointId(s.jr.names[j]);
    const int nq = s.model.nqs[id], nv = s.model.nvs[id];
    Kind k;
    if (s.jr.nv[j] == 1 && nv == 1)
      k = nq == 1 ? Kind::One : Kind::Continuous;
    else if (s.jr.nq[j] == 7 && s.jr.nv[j] == 6 && nq == 7 && nv == 6)
      k = Kind::FreeFlyer;
    else
      return "joint " + s.jr.names[j] + ": Pinocchio nq/nv " + std::to_string(nq) + "/" + std::to_string(nv);
    s.kind.push_back(k);
    s.qi.push_back(s.model.idx_qs[id]);
    s.vi.push_back(s.model.idx_vs[id]);
  }
  return "";
}

void set_state(PinState& s, const State& st, const VectorXd& damping) {
  for (std::size_t j = 0; j < s.kind.size(); ++j) {
    const double* q = st.q.data() + s.jr.q0[j];
    const int a = s.jr.v0[j], qi = s.qi[j], vi = s.vi[j];
    const int nv = s.jr.nv[j];
    s.v.segment(vi, nv) = st.v.segment(a, nv);
    s.tau.segment(vi, nv) = st.tau.segment(a, nv);
    s.damping.segment(vi, nv) = damping.segment(a, nv);
    if (s.kind[j] == Kind::One) {
      s.q[qi] = q[0];
    } else if (s.kind[j] == Kind::Continuous) {
      s.q[qi] = std::cos(q[0]);
      s.q[qi + 1] = std::sin(q[0]);
    } else {
      const Eigen::Quaterniond quat = Eigen::Quaterniond(q[3], q[4], q[5], q[6]).normalized();
      const Eigen::Matrix3d R = quat.toRotationMatrix();
      s.q.segment<3>(qi) = Vector3d(q[0], q[1], q[2]);
      s.q.segment<4>(qi + 3) << quat.x(), quat.y(), quat.z(), quat.w();
      s.v.segment<3>(vi) = R.transpose() * st.v.segment<3>(a);
      s.tau.segment<3>(vi) = R.transpose() * st.tau.segment<3>(a);
    }
  }
}

// Pinocchio's acceleration a in jrgen's layout.
void to_jrgen(const PinState& s, const VectorXd& a, VectorXd& out) {
  out.resize(s.v.size());
  for (std::size_t j = 0; j < s.kind.size(); ++j) {
    const int o = s.jr.v0[j], vi = s.vi[j], nv = s.jr.nv[j];
    out.segment(o, nv) = a.segment(vi, nv);
    if (s.kind[j] != Kind::FreeFlyer) continue;
    const int qi = s.qi[j];
    const Eigen::Quaterniond quat(s.q[qi + 6], s.q[qi + 3], s.q[qi + 4], s.q[qi + 5]);
    const Vector3d v_lin = s.v.segment<3>(vi), omega = s.v.segment<3>(vi + 3);
    out.segment<3>(o) = quat.toRotationMatrix() * (a.segment<3>(vi) + omega.cross(v_lin));
  }
}

}  // namespace

std::string pinocchio_cases(const std::string& urdf, const JointLayout& joints, const VectorXd& damping,
                            const State& state, std::vector<Case>& cases) {
  auto s = std::make_shared<PinState>();
  s->jr = joints;
  try {
    pin::urdf::buildModel(urdf, s->model);
  } catch (const std::exception& e) {
    return std::string("buildModel: ") + e.what();
  }
  if (s->model.nv != state.v.size()) return "Pinocchio's nv " + std::to_string(s->model.nv) + " differs";
  const std::string why = map_joints(*s);
  if (!why.empty()) return why;
  s->data = pin::Data(s->model);
  s->q = pin::neutral(s->model);
  s->v = s->tau = s->damping = s->rhs = s->qdd = VectorXd::Zero(s->model.nv);
  set_state(*s, state, damping);
  cases.push_back({"pinocchio/aba",
                   [s] {
                     s->rhs = s->tau - s->damping.cwiseProduct(s->v);
                     pin::aba(s->model, s->data, s->q, s->v, s->rhs);
                   },
                   [s](VectorXd& out) { to_jrgen(*s, s->data.ddq, out); }});
  cases.push_back({"pinocchio/crba+nle+cholesky",
                   [s] {
                     pin::crba(s->model, s->data, s->q);
                     pin::nonLinearEffects(s->model, s->data, s->q, s->v);
                     pin::cholesky::decompose(s->model, s->data);
                     s->qdd = s->tau - s->damping.cwiseProduct(s->v) - s->data.nle;
                     pin::cholesky::solve(s->model, s->data, s->qdd);
                   },
                   [s](VectorXd& out) { to_jrgen(*s, s->qdd, out); }});
  return "ok";
}

}  // namespace jrgen::peers
