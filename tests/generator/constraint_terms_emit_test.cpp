// The specialized constraint block (emit/constraint_terms.cpp, issue 20)
// against the runtime's generic jr::constraints and jr::constraint_terms on
// every closed-loop model of the suite (rows kept by the generator's own
// redundancy analysis), at assembled and at random states: the Program is
// evaluated at generation time (Program::evaluate, the operations of the
// emitted code in their order).  gamma is also checked against an
// independent reference, a central difference of Phiq v along v.
#include "emit/constraint_terms.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <limits>
#include <random>
#include <string>

#include "analysis/constraints.hpp"
#include "analysis/runtime_model.hpp"
#include "common/model_cases.hpp"
#include "emit/kinematics.hpp"
#include "topology/topology.hpp"

namespace {

using jrgen::emit::Program;
using jrgen::testing::ModelCase;
constexpr double kEps = std::numeric_limits<double>::epsilon();

// A loop model with its kept rows, and the constraint block built for it.
struct Block {
  jrgen::topology::Tree tree;
  jrgen::analysis::ConstraintAnalysis analysis;
  std::unique_ptr<jrgen::analysis::RuntimeModel> rt;
  Program program{"const double* q, const double* v"};
  jrgen::emit::ConstraintValues values;

  explicit Block(const ModelCase& c) {
    const jrgen::ir::Robot robot = jrgen::testing::read_model_case(c);
    tree = jrgen::topology::build_tree(robot);
    analysis = jrgen::analysis::analyze_constraints(robot, tree, /*strict=*/false);
    rt = std::make_unique<jrgen::analysis::RuntimeModel>(tree, Eigen::Vector3d::Zero());
    program.begin_function("terms", "test");
    program.begin_block("kinematics");
    const auto frames = jrgen::emit::joint_frames(program, tree);
    const auto motion = jrgen::emit::body_velocities(program, tree, frames);
    program.begin_block("constraints");
    values = jrgen::emit::constraint_terms(program, tree, frames, motion);
    for (std::size_t i = 0; i < values.phi.size(); ++i) {
      program.output("phi[" + std::to_string(i) + "]", values.phi[i]);
      program.output("gamma[" + std::to_string(i) + "]", values.gamma[i]);
    }
    for (std::size_t i = 0; i < values.phiq_packed.size(); ++i)
      program.output("Phiq[" + std::to_string(i) + "]", values.phiq_packed[i]);
  }

  std::vector<double> evaluate(const Eigen::VectorXd& q, const Eigen::VectorXd& v) const {
    return program.evaluate([&](const std::string& in) {
      const int i = std::stoi(in.substr(2, in.size() - 3));
      return in[0] == 'q' ? q[i] : v[i];
    });
  }
};

// A random state: angles and positions in [-2, 2], quaternions random unit
// ones scaled by 1 to 1.5 (the block normalizes them), velocities in [-3, 3].
void random_state(const jrgen::topology::Tree& t, std::mt19937_64& rng, Eigen::VectorXd& q, Eigen::VectorXd& v) {
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  q = Eigen::VectorXd::NullaryExpr(t.nq, [&] { return u(rng); });
  v = 1.5 * Eigen::VectorXd::NullaryExpr(t.nv, [&] { return u(rng); });
  for (const auto& b : t.bodies) {
    const int first = b.type == jrgen::ir::JointType::Ball ? b.q_user
                      : b.type == jrgen::ir::JointType::Floating ? b.q_user + 3 : -1;
    if (first < 0) continue;
    const Eigen::Vector4d quat = Eigen::Vector4d::NullaryExpr([&] { return u(rng); }).normalized();
    q.segment<4>(first) = (1.25 + 0.125 * u(rng)) * quat;
  }
}

double max_abs(const Eigen::VectorXd& x) { return x.size() ? x.cwiseAbs().maxCoeff() : 0.0; }

class ConstraintTermsEmit : public ::testing::TestWithParam<ModelCase> {};

// Both sides are the same few products and sums of unit vectors, lengths and
// velocities, composed along the cut's path from different frames (the
// runtime through the world, the block from the cut frame Fk): each result
// is a sum of terms no larger than L (positions: the largest world position
// of a body or frame, >= 1 m) for Phi and Phiq, and V^2 L for gamma (V the
// largest body speed, angular or linear, >= 1), each term carrying a few ulps
// per composed joint.  100 eps of that scale allows the paths of the suite
// (up to 12 distinct dofs per loop) with margin (the largest difference seen
// is 8 eps of the scale); a wrong sign or a missing term is of the size of
// the scale itself.
TEST_P(ConstraintTermsEmit, MatchesTheRuntime) {
  Block blk(GetParam());
  const jrgen::topology::Tree& tree = blk.tree;
  const jr::Model& model = blk.rt->model();
  const jr::ConstraintModel& cm = blk.rt->constraints();
  ASSERT_EQ(blk.values.phi.size(), static_cast<std::size_t>(cm.nc));
  ASSERT_EQ(blk.values.phiq_packed.size(), static_cast<std::size_t>(cm.phiq_nnz));
  std::mt19937_64 rng(20);
  std::vector<std::pair<Eigen::VectorXd, Eigen::VectorXd>> states;
  // The assembled configurations of the redundancy analysis (the first is
  // often q = 0, the others generic), with any v.
  const std::size_t assembled = blk.analysis.configurations.size();
  for (std::size_t s = 0; s < assembled; ++s) {
    Eigen::VectorXd q, v;
    random_state(tree, rng, q, v);
    states.emplace_back(blk.analysis.configurations[s], v);
  }
  for (int trial = 0; trial < 3; ++trial) {
    Eigen::VectorXd q, v;
    random_state(tree, rng, q, v);
    states.emplace_back(q, v);
  }
  for (std::size_t s = 0; s < states.size(); ++s) {
    const auto& [q, v] = states[s];
    SCOPED_TRACE("state " + std::to_string(s) + (s < assembled ? " (assembled)" : " (random)"));
    const std::vector<double> x = blk.evaluate(q, v);
    Eigen::VectorXd phi(cm.nc), phi2(cm.nc), gamma(cm.nc), Phiq = Eigen::VectorXd::Zero(cm.phiq_nnz);
    jr::constraints(model, cm, blk.rt->workspace(), q.data(), phi.data());
    jr::kinematics(model, blk.rt->workspace(), q.data());
    jr::constraint_terms(model, cm, blk.rt->workspace(), blk.rt->motion(), q.data(), v.data(), phi2.data(),
                         Phiq.data(), gamma.data());
    double L = 1.0, V = 1.0;
    for (int i = 0; i < model.nb; ++i) {
      L = std::max(L, blk.rt->motion()[i].p.norm());
      V = std::max({V, blk.rt->motion()[i].w.norm(), blk.rt->motion()[i].v.norm()});
    }
    L = std::max({L, max_abs(Phiq), max_abs(phi)});
    const double tol_pos = 100.0 * kEps * L, tol_gamma = 100.0 * kEps * std::max(V * V * L, max_abs(gamma));
    for (int r = 0; r < cm.nc; ++r) {
      EXPECT_NEAR(Program::value(blk.values.phi[r], x), phi[r], tol_pos) << "Phi row " << r;
      EXPECT_NEAR(Program::value(blk.values.gamma[r], x), gamma[r], tol_gamma) << "gamma row " << r;
    }
    for (int k = 0; k < cm.phiq_nnz; ++k)
      EXPECT_NEAR(Program::value(blk.values.phiq_packed[k], x), Phiq[k], tol_pos) << "packed Phiq entry " << k;
  }
}

// The four-bar closed the other way round: the cut frame on k fixed on the
// base (body_k = -1, which no model of the suite has) and both cut frames
// turned about the axis (constant rotations to fold).
ModelCase fourbar_from_the_base() {
  ModelCase c = jrgen::testing::find_model_case("loops_fourbar");
  const std::string new_cut = R"(<loop_joint name="joint_D" type="revolute">
    <parent link="world"/>
    <child link="rocker"/>
    <origin xyz="1.2 0 0" rpy="0 0 0.7"/>
    <child_origin xyz="0 -0.9 0" rpy="0 0 -0.4"/>
    <axis xyz="0 0 1"/>
  </loop_joint>
</robot>
)";
  c.name = "loops_fourbar_from_the_base";
  c.urdf = c.urdf.substr(0, c.urdf.find("<loop_joint")) + new_cut;
  return c;
}

std::vector<ModelCase> cases() {
  std::vector<ModelCase> out = jrgen::testing::loop_models();
  out.push_back(fourbar_from_the_base());
  return out;
}

INSTANTIATE_TEST_SUITE_P(All, ConstraintTermsEmit, ::testing::ValuesIn(cases()),
                         [](const auto& info) { return info.param.name; });

// Without body motions (positions only, e.g. for a projection onto Phi = 0)
// the block gives Phi and Phiq and no gamma, and needs no input v.
TEST(ConstraintTermsEmitPositions, WithoutMotionGivesPhiAndPhiq) {
  for (const char* name : {"loops_hmmwv14", "loops_stewart"}) {
    SCOPED_TRACE(name);
    const jrgen::ir::Robot robot = jrgen::testing::read_model_case(jrgen::testing::find_model_case(name));
    jrgen::topology::Tree tree = jrgen::topology::build_tree(robot);
    jrgen::analysis::analyze_constraints(robot, tree, /*strict=*/false);
    jrgen::analysis::RuntimeModel rt(tree, Eigen::Vector3d::Zero());
    const jr::ConstraintModel& cm = rt.constraints();
    Program program("const double* q");
    program.begin_function("terms", "test");
    program.begin_block("constraints");
    const auto values = jrgen::emit::constraint_terms(program, tree, jrgen::emit::joint_frames(program, tree), {});
    EXPECT_TRUE(values.gamma.empty());
    std::mt19937_64 rng(3);
    Eigen::VectorXd q, v;
    random_state(tree, rng, q, v);
    const std::vector<double> x = program.evaluate([&](const std::string& in) {
      EXPECT_EQ(in[0], 'q') << in;
      return q[std::stoi(in.substr(2, in.size() - 3))];
    });
    Eigen::VectorXd phi(cm.nc), Phiq = Eigen::VectorXd::Zero(cm.phiq_nnz);
    jr::kinematics(rt.model(), rt.workspace(), q.data());
    jr::constraint_terms(rt.model(), cm, rt.workspace(), rt.motion(), q.data(), nullptr, phi.data(), Phiq.data(),
                         nullptr);
    double L = 1.0;  // as in MatchesTheRuntime
    for (int i = 0; i < rt.model().nb; ++i) L = std::max(L, rt.motion()[i].p.norm());
    L = std::max({L, max_abs(Phiq), max_abs(phi)});
    ASSERT_EQ(values.phi.size(), static_cast<std::size_t>(cm.nc));
    for (int r = 0; r < cm.nc; ++r) EXPECT_NEAR(Program::value(values.phi[r], x), phi[r], 100.0 * kEps * L);
    for (int k = 0; k < cm.phiq_nnz; ++k)
      EXPECT_NEAR(Program::value(values.phiq_packed[k], x), Phiq[k], 100.0 * kEps * L);
  }
}

// gamma = -(d/dt Phiq) v at qdd = 0: along q(t) = q "+" t v (constant v in
// the velocity coordinates, analysis::integrate), Phi_ddot = d/dt (Phiq v),
// so gamma = -(Phiq(q "+" h v) v - Phiq(q "-" h v) v) / (2 h) + O(h^2), with
// Phiq from the runtime (dense, unpacked): independent of both gammas.  With
// h = 1e-4 / V the truncation error is ~ h^2 V^3 L ~ 1e-8 V L and the
// rounding ~ eps L V / h ~ 1e-12 V^2 L: 1e-6 V^2 L is far above both and
// far below a wrong term.
TEST(ConstraintTermsEmitGamma, MatchesCentralDifferenceOfPhiqV) {
  for (const char* name : {"loops_hmmwv14", "loops_stewart"}) {
    SCOPED_TRACE(name);
    Block blk(jrgen::testing::find_model_case(name));
    const jrgen::topology::Tree& tree = blk.tree;
    const jr::Model& model = blk.rt->model();
    const jr::ConstraintModel& cm = blk.rt->constraints();
    std::mt19937_64 rng(7);
    Eigen::VectorXd q0, v;
    random_state(tree, rng, q0, v);
    const Eigen::VectorXd q = blk.analysis.configurations.back();  // assembled, not q = 0
    const double V = std::max(1.0, max_abs(v));
    const double h = 1e-4 / V;
    auto phiq_v = [&](double t) {
      Eigen::VectorXd qt = q;
      jrgen::analysis::integrate(tree, qt, t * v);
      Eigen::VectorXd Pp = Eigen::VectorXd::Zero(cm.phiq_nnz);
      Eigen::MatrixXd P(cm.nc, tree.nv);
      jr::kinematics(model, blk.rt->workspace(), qt.data());
      jr::constraint_terms(model, cm, blk.rt->workspace(), blk.rt->motion(), qt.data(), nullptr, nullptr, Pp.data(),
                           nullptr);
      jr::unpack_constraint_jacobian(model, cm, Pp.data(), P.data());
      return Eigen::VectorXd(P * v);
    };
    const Eigen::VectorXd reference = -(phiq_v(h) - phiq_v(-h)) / (2.0 * h);
    const std::vector<double> x = blk.evaluate(q, v);
    double L = 1.0;
    for (int i = 0; i < model.nb; ++i) L = std::max(L, blk.rt->motion()[i].p.norm());
    const double tol = 1e-6 * V * V * L;
    double largest = 0.0;
    for (int r = 0; r < cm.nc; ++r) {
      EXPECT_NEAR(Program::value(blk.values.gamma[r], x), reference[r], tol) << "row " << r;
      largest = std::max(largest, std::abs(reference[r]));
    }
    EXPECT_GT(largest, 1e3 * tol) << "the reference is too small to tell";
  }
}

// Operation counts of the block, printed for --report comparisons, and a
// guard on the folding: at the time of writing the HMMWV's block (16 rows,
// 8 cuts) costs 962 multiplications and 890 additions, the Stewart
// platform's (18 rows, 6 cuts) 1080 and 939; the runtime's generic pass
// (world poses and motions of every body, 6-vector twists, every row
// coefficient) costs several thousand of each.  A lost fold (a constant
// cut frame, a zero of an axis, a unit direction of a point row) costs
// hundreds: the bounds leave 10 %.
TEST(ConstraintTermsEmitCounts, FoldingKeepsTheBlockSmall) {
  const struct {
    const char* name;
    long long mul, add;
  } bounds[] = {{"loops_hmmwv14", 1060, 980}, {"loops_stewart", 1190, 1035}};
  for (const auto& b : bounds) {
    SCOPED_TRACE(b.name);
    Block blk(jrgen::testing::find_model_case(b.name));
    const auto counts = blk.program.count();
    ASSERT_EQ(counts.size(), 2u);
    ASSERT_EQ(counts[1].first, "constraints");
    const jrgen::emit::OpCount& ops = counts[1].second;
    std::cout << b.name << " constraint block: " << ops.mul << " mul, " << ops.add << " add, " << ops.div
              << " div, " << ops.sqrt << " sqrt, " << ops.trig << " sin/cos\n";
    EXPECT_LE(ops.mul, b.mul);
    EXPECT_LE(ops.add, b.add);
    EXPECT_EQ(ops.sqrt + ops.trig, 0);
  }
}

}  // namespace
