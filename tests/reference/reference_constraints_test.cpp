// The loop-closure constraints (Phi, Phiq, gamma of every cut type) against
// the independent reference of reference_constraints.hpp (issue 19, item 9),
// away from the assembled configuration: random q and v on every closed-loop
// model case (models/ with their cuts, random trees with random cuts of all
// seven types, vehicle trains).
//
//   ReferenceCuts.*             the reference itself against central finite
//                               differences of its own Phi and Phiq v;
//   RuntimeCuts.*               jr::constraint_terms / jr::constraints /
//                               jr::constraints_all_rows, all rows and the
//                               kept rows, row by row against the reference;
//   GeneratedCuts.*             every closed-loop solver of the test registry
//                               (constraints, constraint_jacobian,
//                               constraint_gamma), row by row;
//   CutDefinitions.*            row-choice free: on two floating bodies, the
//                               runtime's rows vanish on the configurations
//                               docs/interface.md section 2 defines for each type,
//                               and the null space of Phiq is exactly the
//                               relative motion the type allows;
//   CutDefinitionResidual.*     the reference's row-free distance from the
//                               defined set sees what rows cannot.
//
// Row by row: the rows are the scalar functions of the relative placement of
// the two joint frames that runtime.hpp documents (CutKind), so each solver
// row is compared with the same function evaluated by the reference.  The one
// free choice the documentation leaves open, the basis (u, w) completing a
// cut's axis, is fitted per cut and per solver as one angle about the axis
// (a right-handed basis is (u, w) rotated), from all samples at once; every
// row, Jacobian entry and gamma of every sample must then agree.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <cmath>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "analysis/constraints.hpp"
#include "analysis/runtime_model.hpp"
#include "common/model_cases.hpp"
#include "common/tolerance.hpp"
#include "generated/solver_registry.hpp"
#include "published/andrews_reference.hpp"
#include "reference/reference_constraints.hpp"
#include "reference/reference_dynamics.hpp"
#include "topology/topology.hpp"
#include "urdf/urdf_reader.hpp"

namespace jrgen {
namespace {

using Eigen::MatrixXd;
using Eigen::Vector3d;
using Eigen::VectorXd;
using testing::kEps;
using testing::relative_error;

// ---- Comparison of a solver's rows with the reference ------------------------------

// One evaluation of a solver at (q, v): its kept rows, stacked cut by cut.
struct Sample {
  VectorXd q, v;
  VectorXd phi;
  MatrixXd Phiq;   ///< rows x nv, user order
  VectorXd gamma;  ///< empty when the solver was not asked for it
};

// Which rows of each cut (ir order) a solver keeps, in order.
using KeptRows = std::vector<std::vector<int>>;

KeptRows all_rows(const ir::Robot& robot) {
  KeptRows kept;
  for (const ir::CutJoint& cut : robot.cuts) {
    kept.emplace_back();
    for (int r = 0; r < ir::cut_rows(cut.type); ++r) kept.back().push_back(r);
  }
  return kept;
}

KeptRows kept_rows(const topology::Tree& tree) {
  KeptRows kept;
  for (const topology::Cut& cut : tree.cuts) kept.push_back(cut.kept_rows);
  return kept;
}

// One row of the reference or of a solver in one sample: value, Jacobian row,
// gamma, as one vector (the data the basis fit weighs).
VectorXd row_data(const VectorXd& phi, const MatrixXd& Phiq, const VectorXd& gamma, int r) {
  VectorXd d(Phiq.cols() + 2);
  d << phi[r], Phiq.row(r).transpose(), gamma.size() ? gamma[r] : 0.0;
  return d;
}

// The reference's basis (u, w) rotated about the axis by the angle that best
// matches the solver's u and w rows over all samples: a u row is c f(b1) +
// s f(b2), a w row -s f(b1) + c f(b2), with f(e) the row written with
// direction e, linear in e; (c, s) by linear least squares over every row,
// Jacobian entry and gamma of every sample, then theta = atan2(s, c).  Exact
// when a cut keeps only one row of a pair (the Bricard mechanism's J6), where
// maximizing the correlation alone is biased.  One angle per cut: it cannot
// absorb an error that varies with q, nor a left-handed (u, w) (a reflection).
void fit_basis(const ir::Robot& robot, int c, double D, const std::vector<int>& kept, int first,
               const std::vector<Sample>& samples, Vector3d& u, Vector3d& w) {
  const ir::CutJoint& cut = robot.cuts[c];
  Vector3d axis, b1, b2;
  reference::axis_basis(cut, axis, b1, b2);
  u = b1;
  w = b2;
  const std::vector<int> roles = reference::basis_row_roles(cut.type);
  Eigen::Matrix2d N = Eigen::Matrix2d::Zero();
  Eigen::Vector2d rhs = Eigen::Vector2d::Zero();
  for (const Sample& s : samples) {
    const reference::CutRows ref = reference::cut_rows(robot, cut, D, b1, b2, s.q, s.gamma.size() ? s.v : VectorXd());
    for (std::size_t i = 0; i < kept.size(); ++i) {
      const int r = kept[i], role = roles[r];
      if (role == 0) continue;
      const int ru = role > 0 ? r : r - 1;  // the pair's u row and w row
      const VectorXd y = row_data(s.phi, s.Phiq, s.gamma, first + static_cast<int>(i));
      const VectorXd xu = row_data(ref.phi, ref.Phiq, ref.gamma, ru);
      const VectorXd xw = row_data(ref.phi, ref.Phiq, ref.gamma, ru + 1);
      // y = c p + s r: a u row p = f(b1), r = f(b2); a w row p = f(b2), r = -f(b1).
      const VectorXd p = role > 0 ? xu : xw;
      const VectorXd q = role > 0 ? xw : VectorXd(-xu);
      N(0, 0) += p.dot(p);
      N(0, 1) += p.dot(q);
      N(1, 1) += q.dot(q);
      rhs[0] += y.dot(p);
      rhs[1] += y.dot(q);
    }
  }
  N(1, 0) = N(0, 1);
  if (rhs.isZero(0.0)) return;
  const Eigen::Vector2d cs = N.ldlt().solve(rhs);
  const double theta = std::atan2(cs[1], cs[0]);
  u = std::cos(theta) * b1 + std::sin(theta) * b2;
  w = axis.cross(u);
}

// Both sides are the same mathematics by different routes (body-frame
// spatial algebra and world-frame coefficient vectors in the runtime; world
// Jacobians and the relative placement (a)-(f) here), each a sum of
// O(depth) rounded products of O(1) quantities (lengths of order 1 m,
// velocities of order 1): they agree to a small multiple of depth * eps,
// normwise per cut.  Measured: at most 1.1e-14 (~50 eps, gamma; Phi and
// Phiq 3e-15) over all cases here (2026-12-03, x86-64, gcc -O3).  1e-12
// (~4500 eps) leaves a margin of ~100 for deeper paths and other compilers;
// an error in a row is of the order of the row itself.  The floor of 1 (m,
// 1/s^2) keeps rows that are legitimately small from asking for more than
// absolute accuracy.
constexpr double kSameMath = 1e-12;

// Every kept row of every cut of every sample against the reference.
void expect_rows_match_reference(const ir::Robot& robot, const KeptRows& kept, const std::vector<Sample>& samples,
                                 const std::string& what) {
  int first = 0;
  for (std::size_t c = 0; c < robot.cuts.size(); ++c) {
    const ir::CutJoint& cut = robot.cuts[c];
    const int m = static_cast<int>(kept[c].size());
    const double D = reference::cut_distance(robot, cut);
    Vector3d u, w;
    fit_basis(robot, static_cast<int>(c), D, kept[c], first, samples, u, w);
    for (std::size_t t = 0; t < samples.size(); ++t) {
      const Sample& s = samples[t];
      const bool with_gamma = s.gamma.size() != 0;
      const reference::CutRows ref = reference::cut_rows(robot, cut, D, u, w, s.q, with_gamma ? s.v : VectorXd());
      VectorXd phi_ref(m), gamma_ref(m);
      MatrixXd Phiq_ref(m, ref.Phiq.cols());
      for (int i = 0; i < m; ++i) {
        phi_ref[i] = ref.phi[kept[c][i]];
        gamma_ref[i] = ref.gamma[kept[c][i]];
        Phiq_ref.row(i) = ref.Phiq.row(kept[c][i]);
      }
      const std::string where = what + ", cut '" + cut.name + "' (" + ir::cut_type_name(cut.type) + "), sample " +
                                std::to_string(t);
      EXPECT_LE(relative_error(s.phi.segment(first, m), phi_ref, 1.0), kSameMath)
          << where << ": Phi\n  solver    " << s.phi.segment(first, m).transpose() << "\n  reference "
          << phi_ref.transpose();
      EXPECT_LE(relative_error(s.Phiq.middleRows(first, m), Phiq_ref, 1.0), kSameMath) << where << ": Phiq";
      if (with_gamma) {
        EXPECT_LE(relative_error(s.gamma.segment(first, m), gamma_ref, 1.0), kSameMath)
            << where << ": gamma\n  solver    " << s.gamma.segment(first, m).transpose() << "\n  reference "
            << gamma_ref.transpose();
      }
    }
    first += m;
  }
}

// Random (q, v) away from the assembled configuration: angles in [-1, 1],
// random unit quaternions, travels in [-0.3, 0.3] (reference_dynamics.hpp).
std::vector<std::pair<VectorXd, VectorXd>> random_states(const ir::Robot& robot, int n, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::vector<std::pair<VectorXd, VectorXd>> out;
  for (int i = 0; i < n; ++i) {
    VectorXd q = reference::random_configuration(robot, rng);
    out.emplace_back(q, reference::random_velocity(robot, rng));
  }
  return out;
}

// ---- The reference against its own finite differences -----------------------------

class ReferenceCuts : public ::testing::TestWithParam<testing::ModelCase> {};

// Central differences with step e: truncation ~ e^2 |Phi'''| / 6, rounding
// ~ eps |Phi| / e; e = 1e-6 balances them near 1e-10 for O(1) geometry.  The
// tolerance 1e-7 keeps a margin of ~1e3 (as in generated_loops_test).
TEST_P(ReferenceCuts, JacobianAndGammaMatchFiniteDifferences) {
  const ir::Robot robot = testing::read_model_case(GetParam());
  const double e = 1e-6;
  for (const auto& [q, v] : random_states(robot, 2, 11)) {
    for (const ir::CutJoint& cut : robot.cuts) {
      const double D = reference::cut_distance(robot, cut);
      Vector3d axis, u, w;
      reference::axis_basis(cut, axis, u, w);
      auto rows = [&](const VectorXd& qq, const VectorXd& vv) { return reference::cut_rows(robot, cut, D, u, w, qq, vv); };
      const reference::CutRows ref = rows(q, v);
      MatrixXd Phiq_fd(ref.Phiq.rows(), ref.Phiq.cols());
      for (int k = 0; k < robot.nv(); ++k) {
        const VectorXd dk = VectorXd::Unit(robot.nv(), k);
        Phiq_fd.col(k) = (rows(reference::integrate(robot, q, dk, e), VectorXd()).phi -
                          rows(reference::integrate(robot, q, dk, -e), VectorXd()).phi) /
                         (2 * e);
      }
      EXPECT_LE((ref.Phiq - Phiq_fd).cwiseAbs().maxCoeff(), 1e-7 * std::max(1.0, ref.Phiq.cwiseAbs().maxCoeff()))
          << "cut '" << cut.name << "' (" << ir::cut_type_name(cut.type) << ")";
      // gamma = -d/dt (Phiq(q(t)) v) along q(t) = q "+" v t at constant v.
      const VectorXd d_fd = (rows(reference::integrate(robot, q, v, e), VectorXd()).Phiq * v -
                             rows(reference::integrate(robot, q, v, -e), VectorXd()).Phiq * v) /
                            (2 * e);
      EXPECT_LE((ref.gamma + d_fd).cwiseAbs().maxCoeff(), 1e-7 * std::max(1.0, ref.gamma.cwiseAbs().maxCoeff()))
          << "cut '" << cut.name << "' (" << ir::cut_type_name(cut.type) << ")";
    }
  }
}

// Every model case here closes at the zero configuration: models/ are drawn
// assembled, the random cuts are built from one world frame there
// (random_cuts.hpp), the trains' hitches coincide there.  So the reference's
// rows must vanish at q0: a check that it reads the frames, axes and the
// default distance as the files mean them.
// Except Andrews' squeezer (models/andrews_squeezer.urdf), drawn with every angle 0 so
// that its coordinates are the IVP test set's angles: there the rows must vanish at the
// test set's consistent initial angles (tests/published/andrews_reference.hpp, published
// to 30 digits), in jrgen's order.
TEST_P(ReferenceCuts, RowsVanishAtTheZeroConfiguration) {
  const ir::Robot robot = testing::read_model_case(GetParam());
  VectorXd q0 = reference::neutral_configuration(robot);
  if (GetParam().name == "loops_andrews_squeezer") {
    ASSERT_EQ(q0.size(), 7);
    for (int i = 0; i < 7; ++i) q0[i] = andrews_ref::q0[andrews_ref::perm[i]];
  }
  for (const ir::CutJoint& cut : robot.cuts) {
    Vector3d axis, u, w;
    reference::axis_basis(cut, axis, u, w);
    const reference::CutRows ref =
        reference::cut_rows(robot, cut, reference::cut_distance(robot, cut), u, w, q0, VectorXd());
    // Frames written with 17 digits and rebuilt through rpy, placements of
    // O(1) m composed over the tree depth: ~1e-15; 1e-13 leaves ~100.
    EXPECT_LE(ref.phi.cwiseAbs().maxCoeff(), 1e-13) << "cut '" << cut.name << "' (" << ir::cut_type_name(cut.type)
                                                    << "): " << ref.phi.transpose();
  }
}

INSTANTIATE_TEST_SUITE_P(LoopModels, ReferenceCuts, ::testing::ValuesIn(testing::loop_models()),
                         [](const auto& info) { return info.param.name; });

// ---- The generic runtime -----------------------------------------------------------

// The runtime on a model case: the tree with its kept rows (after the
// generator's redundancy analysis) and the same tree with every row kept.
struct RuntimeFixture {
  ir::Robot robot;
  topology::Tree tree, tree_all;
  std::unique_ptr<analysis::RuntimeModel> kept, all;

  explicit RuntimeFixture(const testing::ModelCase& c) : robot(testing::read_model_case(c)) {
    tree = topology::build_tree(robot);
    analysis::analyze_constraints(robot, tree, false);
    tree_all = tree;
    for (topology::Cut& cut : tree_all.cuts) {
      cut.kept_rows.clear();
      for (int r = 0; r < cut.rows; ++r) cut.kept_rows.push_back(r);
    }
    const Vector3d gravity(0.0, 0.0, -9.81);  // unused by the constraints
    kept = std::make_unique<analysis::RuntimeModel>(tree, gravity);
    all = std::make_unique<analysis::RuntimeModel>(tree_all, gravity);
  }

  // constraint_terms: Phi, Phiq (unpacked to user order) and gamma.
  static Sample terms(analysis::RuntimeModel& rt, const VectorXd& q, const VectorXd& v) {
    const jr::ConstraintModel& cm = rt.constraints();
    Sample s{q, v, VectorXd(cm.nc), MatrixXd(cm.nc, rt.model().nv), VectorXd(cm.nc)};
    VectorXd Phiq_p = VectorXd::Zero(cm.phiq_nnz);
    jr::kinematics(rt.model(), rt.workspace(), q.data());
    jr::constraint_terms(rt.model(), cm, rt.workspace(), rt.motion(), q.data(), v.data(), s.phi.data(),
                         Phiq_p.data(), s.gamma.data());
    jr::unpack_constraint_jacobian(rt.model(), cm, Phiq_p.data(), s.Phiq.data());
    return s;
  }
};

class RuntimeCuts : public ::testing::TestWithParam<testing::ModelCase> {};

TEST_P(RuntimeCuts, EveryRowMatchesReference) {
  RuntimeFixture f(GetParam());
  std::vector<Sample> samples;
  for (const auto& [q, v] : random_states(f.robot, 4, 21)) samples.push_back(RuntimeFixture::terms(*f.all, q, v));
  expect_rows_match_reference(f.robot, all_rows(f.robot), samples, "constraint_terms, all rows");
}

TEST_P(RuntimeCuts, KeptRowsMatchReference) {
  RuntimeFixture f(GetParam());
  std::vector<Sample> samples, phi_only;
  for (const auto& [q, v] : random_states(f.robot, 4, 22)) {
    samples.push_back(RuntimeFixture::terms(*f.kept, q, v));
    // jr::constraints (positions only, its own route through world_poses()).
    Sample s = samples.back();
    jr::constraints(f.kept->model(), f.kept->constraints(), f.kept->workspace(), q.data(), s.phi.data());
    s.gamma.resize(0);
    phi_only.push_back(s);
  }
  expect_rows_match_reference(f.robot, kept_rows(f.tree), samples, "constraint_terms, kept rows");
  expect_rows_match_reference(f.robot, kept_rows(f.tree), phi_only, "constraints, kept rows");
}

// constraints_all_rows (the generator's analysis reads it): every row, dense.
TEST_P(RuntimeCuts, AllRowsForAnalysisMatchReference) {
  RuntimeFixture f(GetParam());
  int rows = 0;
  for (const topology::Cut& cut : f.tree.cuts) rows += cut.rows;
  std::vector<Sample> samples;
  for (const auto& [q, v] : random_states(f.robot, 3, 23)) {
    Sample s{q, v, VectorXd(rows), MatrixXd(rows, f.tree.nv), VectorXd()};
    jr::constraints_all_rows(f.kept->model(), f.kept->constraints(), f.kept->workspace(), f.kept->motion(), q.data(),
                             s.phi.data(), s.Phiq.data());
    samples.push_back(s);
  }
  expect_rows_match_reference(f.robot, all_rows(f.robot), samples, "constraints_all_rows");
}

INSTANTIATE_TEST_SUITE_P(LoopModels, RuntimeCuts, ::testing::ValuesIn(testing::loop_models()),
                         [](const auto& info) { return info.param.name; });

// ---- Generated solvers -------------------------------------------------------------

class GeneratedCuts : public ::testing::TestWithParam<testing::GeneratedSolver> {};

TEST_P(GeneratedCuts, KeptRowsMatchReference) {
  const testing::GeneratedSolver& s = GetParam();
  const ir::Robot robot = testing::read_model_case(testing::find_model_case(s.model_case));
  // The rows the generator kept: the same analysis, deterministic.
  topology::Tree tree = topology::build_tree(robot);
  analysis::analyze_constraints(robot, tree, false);
  ASSERT_EQ(s.nc, tree.nc());
  std::vector<Sample> samples;
  for (const auto& [q, v] : random_states(robot, 4, 31)) {
    Sample x{q, v, VectorXd(s.nc), MatrixXd(s.nc, s.nv), VectorXd(s.nc)};
    s.constraints(q.data(), x.phi.data());
    s.constraint_jacobian(q.data(), x.Phiq.data());
    s.constraint_gamma(q.data(), v.data(), x.gamma.data());
    samples.push_back(x);
  }
  expect_rows_match_reference(robot, kept_rows(tree), samples, s.target);
}

INSTANTIATE_TEST_SUITE_P(Registry, GeneratedCuts, ::testing::ValuesIn(testing::generated_solvers(true)),
                         testing::solver_name);

// ---- The definitions, row-choice free -----------------------------------------------
//
// Two free bodies a and b (floating joints from the world) and one cut of
// each type, from a (or from the world) to b, with random frames and axes.
// Configurations are built directly on the set docs/interface.md section 2 defines
// for the type (the relative placement (R, p) of Fl in Fk drawn from it), and
// the motions the type allows are written down from the same definition:
//   spherical    p = 0                     any rotation
//   revolute     p = 0, R = rot(axis)      rotation about the axis
//   prismatic    R = I, p along the axis   translation along the axis
//   cylindrical  R = rot(axis), p along it both
//   universal    p = 0, axis . R child_axis = 0   rotation about either axis
//   fixed        R = I, p = 0              none
//   distance     |p| = D                   any rotation, translation normal to p
// The runtime's rows must vanish there, Phiq must annihilate every allowed
// motion, and have full row rank (so its null space is exactly the allowed
// motion, whatever rows were chosen and however scaled).

struct DefinitionCase {
  ir::CutType type;
  bool k_on_world;  ///< the frame on k is fixed to the world (body k = the base)
};

std::string definition_case_name(const ::testing::TestParamInfo<DefinitionCase>& info) {
  return std::string(ir::cut_type_name(info.param.type)) + (info.param.k_on_world ? "_from_world" : "_between_bodies");
}

std::string two_bodies_urdf() {
  std::string out = "<robot name=\"two_bodies\">\n  <link name=\"world\"/>\n";
  for (const char* b : {"a", "b"})
    out += std::string("  <link name=\"") + b +
           "\"><inertial><mass value=\"1\"/><inertia ixx=\"0.1\" iyy=\"0.2\" izz=\"0.25\" ixy=\"0\" ixz=\"0\" "
           "iyz=\"0\"/></inertial></link>\n  <joint name=\"j" + b + "\" type=\"floating\"><parent link=\"world\"/>"
           "<child link=\"" + b + "\"/></joint>\n";
  return out + "</robot>\n";
}

std::string random_cut_xml(const DefinitionCase& dc, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  auto triple = [&](double scale) {
    std::ostringstream s;
    s.precision(17);
    s << scale * U(rng) << ' ' << scale * U(rng) << ' ' << scale * U(rng);
    return s.str();
  };
  std::ostringstream x;
  x << "<loop_joints><loop_joint name=\"cut\" type=\"" << ir::cut_type_name(dc.type) << "\">"
    << "<parent link=\"" << (dc.k_on_world ? "world" : "a") << "\"/><child link=\"b\"/>"
    << "<origin xyz=\"" << triple(0.5) << "\" rpy=\"" << triple(3.0) << "\"/>"
    << "<child_origin xyz=\"" << triple(0.5) << "\" rpy=\"" << triple(3.0) << "\"/>"
    << "<axis xyz=\"" << triple(1.0) << "\"/><child_axis xyz=\"" << triple(1.0) << "\"/>";
  if (dc.type == ir::CutType::Distance) x << "<distance value=\"0.7\"/>";
  x << "</loop_joint></loop_joints>";
  return x.str();
}

Eigen::Matrix3d random_rotation(std::mt19937_64& rng) {
  std::normal_distribution<double> N;
  return Eigen::Quaterniond(N(rng), N(rng), N(rng), N(rng)).normalized().toRotationMatrix();
}

// A relative placement (R, p) of Fl in Fk on the type's set.
void placement_on_set(const ir::CutJoint& cut, std::mt19937_64& rng, Eigen::Matrix3d& R, Vector3d& p) {
  std::uniform_real_distribution<double> U(-3.0, 3.0);
  const Vector3d a = cut.axis.normalized(), c = cut.child_axis.normalized();
  const Eigen::Matrix3d about_axis = Eigen::AngleAxisd(U(rng), a).toRotationMatrix();
  R = Eigen::Matrix3d::Identity();
  p = Vector3d::Zero();
  switch (cut.type) {
    case ir::CutType::Spherical: R = random_rotation(rng); break;
    case ir::CutType::Revolute: R = about_axis; break;
    case ir::CutType::Prismatic: p = 0.2 * U(rng) * a; break;
    case ir::CutType::Cylindrical: R = about_axis, p = 0.2 * U(rng) * a; break;
    case ir::CutType::Universal: {
      // R c = about_axis (a unit vector normal to a): rotate c onto it, then about c.
      Vector3d n = a.unitOrthogonal();
      const Eigen::Matrix3d onto = Eigen::Quaterniond::FromTwoVectors(c, n).toRotationMatrix();
      R = about_axis * onto * Eigen::AngleAxisd(U(rng), c).toRotationMatrix();
      break;
    }
    case ir::CutType::Fixed: break;
    case ir::CutType::Distance: {
      R = random_rotation(rng);
      std::normal_distribution<double> N;
      p = cut.distance * Vector3d(N(rng), N(rng), N(rng)).normalized();
      break;
    }
    case ir::CutType::Mimic: break;  // not a frame constraint (forces_test covers it)
  }
}

// Velocity coordinates (12: a's floating joint, then b's) that move body X
// with world angular velocity omega and velocity vel of the world point o:
// floating joints from the world with identity origins take the origin's
// velocity in the world and omega in the child frame (docs/interface.md section 3).
void body_velocity(VectorXd& v, int first, const Eigen::Matrix3d& R_WX, const Vector3d& p_WX, const Vector3d& omega,
                   const Vector3d& o, const Vector3d& vel) {
  v.segment<3>(first) += vel + omega.cross(p_WX - o);
  v.segment<3>(first + 3) += R_WX.transpose() * omega;
}

// Sets body b's floating joint (q[7..13]) so that Fl sits at (R, p) in Fk.
void place_body_b(const ir::CutJoint& cut, const reference::FrameState& k, const Eigen::Matrix3d& R,
                  const Vector3d& p, VectorXd& q) {
  const Eigen::Matrix3d R_WB = k.R_WF * R * cut.frame_l.R.transpose();
  const Vector3d p_WB = k.p_WF + k.R_WF * p - R_WB * cut.frame_l.p;
  const Eigen::Quaterniond quat_WB(R_WB);
  q.segment<7>(7) << p_WB, quat_WB.w(), quat_WB.x(), quat_WB.y(), quat_WB.z();
}

class CutDefinitions : public ::testing::TestWithParam<DefinitionCase> {};

TEST_P(CutDefinitions, RowsVanishOnTheDefinedSetAndPhiqAnnihilatesExactlyTheAllowedMotion) {
  const DefinitionCase dc = GetParam();
  std::mt19937_64 rng(1000 + 2 * static_cast<int>(dc.type) + dc.k_on_world);
  for (int trial = 0; trial < 5; ++trial) {
    ir::Robot robot = urdf::read_robot_string(two_bodies_urdf(), "two_bodies.urdf");
    urdf::read_cuts_string(random_cut_xml(dc, rng), "two_bodies.cuts.xml", robot);
    const ir::CutJoint& cut = robot.cuts[0];
    const int a = robot.find_link("a"), b = robot.find_link("b");
    ASSERT_EQ(robot.nv(), 12);
    // Body a anywhere; Fl placed on the set relative to Fk; body b follows.
    VectorXd q = reference::random_configuration(robot, rng);
    const reference::FrameState k = reference::frame_state(robot, q, VectorXd(), cut.link_k, cut.frame_k);
    Eigen::Matrix3d R;
    Vector3d p;
    placement_on_set(cut, rng, R, p);
    place_body_b(cut, k, R, p, q);
    const std::vector<reference::LinkPose> poses = reference::link_poses(robot, q);
    const Eigen::Matrix3d R_WB = poses[b].R_WL, R_WFl = k.R_WF * R;
    const Vector3d p_WB = poses[b].p_WL, p_WFl = k.p_WF + k.R_WF * p;
    // The construction, seen by the reference's own definition test.
    ASSERT_LE(reference::definition_residual(robot, cut, cut.distance, q), 1e-13) << "trial " << trial;

    topology::Tree tree = topology::build_tree(robot);  // every row kept; D given
    analysis::RuntimeModel rt(tree, Vector3d::Zero());
    const Sample s = RuntimeFixture::terms(rt, q, VectorXd::Zero(12));
    // Placements composed in a few O(1) steps: |Phi| ~ 10 eps; 1e-13 ~ 450 eps.
    EXPECT_LE(s.phi.cwiseAbs().maxCoeff(), 1e-13) << "trial " << trial << ": Phi " << s.phi.transpose();

    // The allowed motions as velocity coordinates, one per column.
    std::vector<VectorXd> allowed;
    const Vector3d axis_W = k.R_WF * cut.axis.normalized(), child_axis_W = R_WFl * cut.child_axis.normalized();
    auto relative = [&](const Vector3d& omega, const Vector3d& vel) {  // b moves, Fk holds still
      VectorXd v = VectorXd::Zero(12);
      body_velocity(v, 6, R_WB, p_WB, omega, p_WFl, vel);
      allowed.push_back(v);
    };
    const Vector3d zero = Vector3d::Zero(), r = p_WFl - k.p_WF;
    switch (cut.type) {
      case ir::CutType::Spherical:
      case ir::CutType::Distance:
        for (int i = 0; i < 3; ++i) relative(Vector3d::Unit(i), zero);
        if (cut.type == ir::CutType::Distance) {
          relative(zero, r.unitOrthogonal());
          relative(zero, r.cross(r.unitOrthogonal()).normalized());
        }
        break;
      case ir::CutType::Revolute: relative(axis_W, zero); break;
      case ir::CutType::Prismatic: relative(zero, axis_W); break;
      case ir::CutType::Cylindrical: relative(axis_W, zero), relative(zero, axis_W); break;
      case ir::CutType::Universal: relative(axis_W, zero), relative(child_axis_W, zero); break;
      case ir::CutType::Fixed: break;
      case ir::CutType::Mimic: break;  // not a frame constraint
    }
    if (dc.k_on_world) {
      for (int i = 0; i < 6; ++i) allowed.push_back(VectorXd::Unit(12, i));  // a is not in the cut
    } else {
      // Both bodies moving together rigidly, by any twist.
      for (int i = 0; i < 6; ++i) {
        const Vector3d omega = i < 3 ? Vector3d::Unit(i) : zero, vel = i < 3 ? zero : Vector3d::Unit(i - 3);
        VectorXd v = VectorXd::Zero(12);
        body_velocity(v, 0, poses[a].R_WL, poses[a].p_WL, omega, Vector3d::Zero(), vel);
        body_velocity(v, 6, R_WB, p_WB, omega, Vector3d::Zero(), vel);
        allowed.push_back(v);
      }
    }
    MatrixXd A(12, static_cast<int>(allowed.size()));
    for (std::size_t i = 0; i < allowed.size(); ++i) A.col(static_cast<int>(i)) = allowed[i];
    const int rows = ir::cut_rows(cut.type);
    // The test's own bookkeeping: the allowed motions span 12 - rows dimensions.
    Eigen::JacobiSVD<MatrixXd> svd_A(A);
    ASSERT_EQ((svd_A.singularValues().array() > 1e-9).count(), 12 - rows) << "trial " << trial;
    // Phiq A = 0 up to rounding of O(1) entries (12-term sums): 1e-13 ~ 450 eps.
    EXPECT_LE((s.Phiq * A).cwiseAbs().maxCoeff(), 1e-13 * std::max(1.0, A.cwiseAbs().maxCoeff()))
        << "trial " << trial << ": Phiq A\n" << s.Phiq * A;
    // Full row rank, well away from rounding: the smallest singular value of
    // the rows above is of order 1 for these O(1) frames (rows are unit
    // directions or products of unit vectors; the distance row has |p| / D = 1).
    Eigen::JacobiSVD<MatrixXd> svd(s.Phiq);
    EXPECT_GE(svd.singularValues()(rows - 1), 1e-3) << "trial " << trial << ": singular values "
                                                    << svd.singularValues().transpose();
  }
}

std::vector<DefinitionCase> definition_cases() {
  std::vector<DefinitionCase> out;
  for (ir::CutType t : {ir::CutType::Spherical, ir::CutType::Revolute, ir::CutType::Prismatic,
                        ir::CutType::Cylindrical, ir::CutType::Universal, ir::CutType::Fixed, ir::CutType::Distance})
    for (bool w : {false, true}) out.push_back({t, w});
  return out;
}

INSTANTIATE_TEST_SUITE_P(AllTypes, CutDefinitions, ::testing::ValuesIn(definition_cases()), definition_case_name);

// Rows cannot tell every placement off the set: any 2 smooth functions that
// vanish where an axis keeps its direction also vanish somewhere else on the
// sphere, and any 3 that vanish at R = I somewhere else on the rotations (the
// signed count of zeros of a map from a closed manifold to R^n is 0).  The
// runtime's rows vanish (|Phi| ~ 1e-16, measured 2026-12-03) with a revolute
// or cylindrical cut's axis reversed (R axis = -axis) and with a prismatic or
// fixed cut's frames a half turn apart about x of Fk; an assembly that
// starts far from the drawn configuration (issue 19, item 3) can land there
// and must check the definition itself.  definition_residual() does.
TEST(CutDefinitionResidual, SeesReversedAxesAndHalfTurns) {
  std::mt19937_64 rng(77);
  for (ir::CutType type : {ir::CutType::Revolute, ir::CutType::Cylindrical, ir::CutType::Prismatic, ir::CutType::Fixed}) {
    ir::Robot robot = urdf::read_robot_string(two_bodies_urdf(), "two_bodies.urdf");
    urdf::read_cuts_string(random_cut_xml({type, false}, rng), "two_bodies.cuts.xml", robot);
    const ir::CutJoint& cut = robot.cuts[0];
    VectorXd q = reference::random_configuration(robot, rng);
    const reference::FrameState k = reference::frame_state(robot, q, VectorXd(), cut.link_k, cut.frame_k);
    Eigen::Matrix3d R;
    Vector3d p;
    placement_on_set(cut, rng, R, p);
    const bool axis_type = type == ir::CutType::Revolute || type == ir::CutType::Cylindrical;
    const Eigen::Matrix3d flip = axis_type ? Eigen::AngleAxisd(EIGEN_PI, cut.axis.normalized().unitOrthogonal()).toRotationMatrix()
                                           : Eigen::Matrix3d(Vector3d(1.0, -1.0, -1.0).asDiagonal());
    place_body_b(cut, k, axis_type ? Eigen::Matrix3d(R * flip) : flip, p, q);
    // |R axis - axis| = 2 with the axis reversed; ||R - I||_F = sqrt(8) for a half turn.
    EXPECT_GE(reference::definition_residual(robot, cut, cut.distance, q), 1.9) << ir::cut_type_name(type);
  }
}

}  // namespace
}  // namespace jrgen
