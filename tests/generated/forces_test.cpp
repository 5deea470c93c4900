// Force elements (docs/interface.md section 2b: springs, joint springs, joint
// forces) in h and in the potential energy, on the three routes of a tree's
// forward_dynamics: the specialized composite-rigid-body and articulated-body
// programs (JRGEN_TERMS_ROUTE) and the runtime's terms (JRGEN_TERMS_LIMIT=0),
// generated from tests/forces/*.urdf (tests/CMakeLists.txt).
#include <gtest/gtest.h>

#include <algorithm>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "frc_branched.hpp"
#include "frc_branched_aba.hpp"
#include "frc_branched_rt.hpp"
#include "frc_chain.hpp"
#include "frc_chain_mimic_rt.hpp"
#include "frc_chain_rt.hpp"
#include "frc_coincide.hpp"
#include "frc_coincide_rt.hpp"
#include "frc_gripper.hpp"
#include "frc_gripper_rt.hpp"
#include "frc_gripper_tables.hpp"
#include "frc_slider.hpp"
#include "frc_slider_aba.hpp"
#include "frc_slider_rt.hpp"
#include "ir/error.hpp"
#include "topology/topology.hpp"
#include "urdf/urdf_reader.hpp"

namespace {

constexpr double kEps = 2.220446049250313e-16;

struct Solver {
  const char* name;
  int nq, nv;
  int (*forward_dynamics)(const double*, const double*, const double*, double*, double*);
  void (*bias_forces)(const double*, const double*, double*);
  void (*mass_matrix)(const double*, double*);
  double (*potential_energy)(const double*);
};
#define JR_SOLVER(ns) \
  Solver { #ns, ns::nq, ns::nv, &ns::forward_dynamics, &ns::bias_forces, &ns::mass_matrix, &ns::potential_energy }

const std::vector<Solver> kSliders = {JR_SOLVER(frc_slider), JR_SOLVER(frc_slider_aba), JR_SOLVER(frc_slider_rt)};
const std::vector<Solver> kBranched = {JR_SOLVER(frc_branched), JR_SOLVER(frc_branched_aba),
                                       JR_SOLVER(frc_branched_rt)};
const std::vector<Solver> kCoincide = {JR_SOLVER(frc_coincide), JR_SOLVER(frc_coincide_rt)};

// tests/forces/slider_spring.urdf: a 2 kg block at x on a prismatic joint
// along x; a spring from the ground point (-1, 0, 0) to the block's origin
// (L = x + 1, dL/dt = v; k 300, c 7, L0 0.5), a joint spring (k 40, c 3,
// rest 0.2) and a joint force 1.5; gravity along -z does no work on x.
//   h = 300 (x + 1 - 0.5) + 7 v + 40 (x - 0.2) + 3 v - 1.5
//   V = 1/2 300 (x + 0.5)^2 + 1/2 40 (x - 0.2)^2
double slider_h(double x, double v) { return 300.0 * (x + 0.5) + 7.0 * v + 40.0 * (x - 0.2) + 3.0 * v - 1.5; }
double slider_V(double x) { return 0.5 * 300.0 * (x + 0.5) * (x + 0.5) + 0.5 * 40.0 * (x - 0.2) * (x - 0.2); }

// Each value is a handful of roundings of terms of size <= 400: 16 eps of that.
TEST(Forces, SliderMatchesHandDerivedForces) {
  for (const Solver& s : kSliders) {
    SCOPED_TRACE(s.name);
    for (const double x : {-0.7, 0.0, 0.3, 1.2})
      for (const double v : {0.0, 0.4, -2.0}) {
        double h = 0.0;
        s.bias_forces(&x, &v, &h);
        EXPECT_NEAR(h, slider_h(x, v), 16 * kEps * 400.0) << "x " << x << " v " << v;
        const double tau = 2.0;
        double qdd = 0.0;
        ASSERT_EQ(s.forward_dynamics(&x, &v, &tau, &qdd, nullptr), 0);
        EXPECT_NEAR(qdd, (tau - slider_h(x, v)) / 2.0, 16 * kEps * 400.0);
        EXPECT_NEAR(s.potential_energy(&x), slider_V(x), 16 * kEps * 400.0);
      }
  }
}

// The damping terms alone: h(x, v) - h(x, 0) = (7 + 3) v, the spring's
// c dL/dt (dL/dt = v) and the joint spring's c v.
TEST(Forces, SliderDampingIsTheHandDerivedTerm) {
  for (const Solver& s : kSliders) {
    SCOPED_TRACE(s.name);
    const double x = 0.25, v = -1.75, zero = 0.0;
    double h = 0.0, h0 = 0.0;
    s.bias_forces(&x, &v, &h);
    s.bias_forces(&x, &zero, &h0);
    EXPECT_NEAR(h - h0, 10.0 * v, 16 * kEps * 400.0);
  }
}

// tests/forces/slider_coincide.urdf: the spring's points coincide at x = 0.
// There the force has no direction and is zero (runtime.hpp, the length
// guard); on either side it pulls towards the rest length along +-x:
// h = s (300 (|x| - 0.5) + 7 s v), s = sign(x).
TEST(Forces, CoincidentPointsGiveZeroForceAndFiniteTerms) {
  for (const Solver& s : kCoincide) {
    SCOPED_TRACE(s.name);
    const double x0 = 0.0, v = 0.6, tau = 0.0;
    double h = 1.0, qdd = 1.0;
    s.bias_forces(&x0, &v, &h);
    EXPECT_EQ(h, 0.0);
    ASSERT_EQ(s.forward_dynamics(&x0, &v, &tau, &qdd, nullptr), 0);
    EXPECT_EQ(qdd, 0.0);
    EXPECT_EQ(s.potential_energy(&x0), 0.5 * 300.0 * 0.25);
    for (const double x : {1e-3, -1e-3, 1e-140, -1e-140}) {
      const double sign = x > 0 ? 1.0 : -1.0;
      s.bias_forces(&x, &v, &h);
      EXPECT_NEAR(h, sign * (300.0 * (std::abs(x) - 0.5) + 7.0 * sign * v), 16 * kEps * 200.0) << x;
    }
  }
}

// A configuration of branched_forces: q = (shoulder, elbow, rail, hang's
// quaternion w x y z), the quaternion random and unit.
Eigen::VectorXd random_q(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd q(7);
  q << 2 * u(rng), 2 * u(rng), 0.5 * u(rng), 0, 0, 0, 0;
  Eigen::Vector4d quat(u(rng), u(rng), u(rng), u(rng));
  q.tail<4>() = quat.normalized();
  return q;
}

// q moved by step e along velocity coordinate k: the one-dof joints' angle or
// travel, the ball's rotation about the child frame's axis k - 3 (its
// velocity coordinates are the angular velocity in the child frame).
Eigen::VectorXd moved(const Eigen::VectorXd& q, int k, double e) {
  Eigen::VectorXd out = q;
  if (k < 3) {
    out[k] += e;
    return out;
  }
  const Eigen::Quaterniond r(Eigen::AngleAxisd(e, Eigen::Vector3d::Unit(k - 3)));
  const Eigen::Quaterniond quat(q[3], q[4], q[5], q[6]);
  const Eigen::Quaterniond m = quat * r;
  out.tail<4>() << m.w(), m.x(), m.y(), m.z();
  return out;
}

// At v = 0 the velocity terms vanish and h = dV/dq - (the joint forces: 0.8
// on the elbow, v[1], and -2 on the rail, v[2]).  Central differences with
// step e = 1e-5: truncation e^2/6 |V'''| (V''' below 1e3 here: stiffnesses
// of 200 N/m times lever arms below 2 m) is below 2e-8, rounding
// eps |V| / e (|V| below 200 J) below 5e-9: 1e-7 holds both with margin,
// where a wrong sign or a missing term is off by O(1).
TEST(Forces, BiasForcesAtRestAreTheGradientOfThePotential) {
  std::mt19937_64 rng(21);
  const Eigen::VectorXd joint_force = (Eigen::VectorXd(6) << 0, 0.8, -2, 0, 0, 0).finished();
  const double e = 1e-5;
  for (const Solver& s : kBranched) {
    SCOPED_TRACE(s.name);
    for (int trial = 0; trial < 6; ++trial) {
      const Eigen::VectorXd q = random_q(rng);
      const Eigen::VectorXd v = Eigen::VectorXd::Zero(6);
      Eigen::VectorXd h(6);
      s.bias_forces(q.data(), v.data(), h.data());
      for (int k = 0; k < 6; ++k) {
        const double dV = (s.potential_energy(moved(q, k, e).data()) - s.potential_energy(moved(q, k, -e).data())) /
                          (2 * e);
        EXPECT_NEAR(h[k] + joint_force[k], dV, 1e-7) << "trial " << trial << " coordinate " << k;
      }
    }
  }
}

// The damping forces derive from a Rayleigh dissipation function: the part
// of h odd in v, D(v) = (h(q, v) - h(q, -v)) / 2 (Coriolis and centrifugal
// terms are even in v, gravity and springs do not depend on it), is B v with
// B = diag(joint damping) + sum over springs of c g g^T (g = dL/dq): linear,
// symmetric (v1 . D(v2) = v2 . D(v1)) and positive semi-definite.  A spring's
// damping applied with the wrong point velocity or sign breaks symmetry or
// sign at O(1); the bounds are 1e3 eps of the products' scale (sums of some
// hundred rounded terms of size |h|).
TEST(Forces, DampingDerivesFromADissipationFunction) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (const Solver& s : kBranched) {
    SCOPED_TRACE(s.name);
    for (int trial = 0; trial < 4; ++trial) {
      const Eigen::VectorXd q = random_q(rng);
      auto odd = [&](const Eigen::VectorXd& v) {
        Eigen::VectorXd hp(6), hm(6);
        const Eigen::VectorXd mv = -v;
        s.bias_forces(q.data(), v.data(), hp.data());
        s.bias_forces(q.data(), mv.data(), hm.data());
        return Eigen::VectorXd((hp - hm) / 2);
      };
      Eigen::VectorXd v1(6), v2(6);
      for (int k = 0; k < 6; ++k) v1[k] = u(rng), v2[k] = u(rng);
      const Eigen::VectorXd D1 = odd(v1), D2 = odd(v2);
      const double scale = std::max(1.0, std::max(D1.lpNorm<Eigen::Infinity>(), D2.lpNorm<Eigen::Infinity>()));
      EXPECT_NEAR(v1.dot(D2), v2.dot(D1), 1e3 * kEps * scale);
      EXPECT_LE((odd(v1 + v2) - D1 - D2).lpNorm<Eigen::Infinity>(), 1e3 * kEps * scale);
      EXPECT_GT(v1.dot(D1), 0.0);  // the joint dampers alone make it positive
    }
  }
}

// The specialized programs against the runtime's terms on the same model: the
// same formulas in another order of operations (and with constants folded), so
// a few roundings of the terms' scale.  Scale: the largest |h| and |M qdd|
// entries; bound 64 eps of it (sums of up to ~20 rounded products), where
// a wrong or missing term is off by O(1).
TEST(Forces, SpecializedRoutesAgreeWithTheRuntimeTerms) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Solver& rt = kBranched.back();
  for (int trial = 0; trial < 6; ++trial) {
    const Eigen::VectorXd q = random_q(rng);
    Eigen::VectorXd v(6), tau(6);
    for (int k = 0; k < 6; ++k) v[k] = 3 * u(rng), tau[k] = 5 * u(rng);
    Eigen::VectorXd h_rt(6), qdd_rt(6);
    rt.bias_forces(q.data(), v.data(), h_rt.data());
    ASSERT_EQ(rt.forward_dynamics(q.data(), v.data(), tau.data(), qdd_rt.data(), nullptr), 0);
    Eigen::MatrixXd M(6, 6);
    rt.mass_matrix(q.data(), M.data());
    const double scale = std::max(h_rt.lpNorm<Eigen::Infinity>(), tau.lpNorm<Eigen::Infinity>());
    for (std::size_t i = 0; i + 1 < kBranched.size(); ++i) {
      const Solver& s = kBranched[i];
      SCOPED_TRACE(s.name);
      Eigen::VectorXd h(6), qdd(6);
      s.bias_forces(q.data(), v.data(), h.data());
      ASSERT_EQ(s.forward_dynamics(q.data(), v.data(), tau.data(), qdd.data(), nullptr), 0);
      EXPECT_LE((h - h_rt).lpNorm<Eigen::Infinity>(), 64 * kEps * scale);
      // The accelerations through the residual of M qdd = tau - h, so that
      // M's conditioning does not enter.
      EXPECT_LE((M * (qdd - qdd_rt)).lpNorm<Eigen::Infinity>(), 64 * kEps * scale);
      EXPECT_EQ(s.potential_energy(q.data()), rt.potential_energy(q.data()));
    }
  }
}

// tests/forces/chain40_forces.urdf: the runtime's terms take its
// articulated-body route (jr::articulated_dynamics on tau - the force
// elements' part of h); against the specialized composite route.  The
// accelerations through the residual M (qdd - qdd_rt) (M's conditioning
// does not enter), bound 1e3 eps of the scale: sums over 40 bodies of
// rounded products; a lost force element is off by O(|force|).
TEST(Forces, RuntimeArticulatedRouteAgreesOnALongChain) {
  const Solver s = JR_SOLVER(frc_chain), rt = JR_SOLVER(frc_chain_rt);
  std::mt19937_64 rng(40);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 3; ++trial) {
    Eigen::VectorXd q(40), v(40), tau(40), qdd(40), qdd_rt(40), h(40);
    for (int k = 0; k < 40; ++k) q[k] = u(rng), v[k] = u(rng), tau[k] = 0.1 * u(rng);
    ASSERT_EQ(s.forward_dynamics(q.data(), v.data(), tau.data(), qdd.data(), nullptr), 0);
    ASSERT_EQ(rt.forward_dynamics(q.data(), v.data(), tau.data(), qdd_rt.data(), nullptr), 0);
    Eigen::MatrixXd M(40, 40);
    s.mass_matrix(q.data(), M.data());
    s.bias_forces(q.data(), v.data(), h.data());
    const double scale = std::max(h.lpNorm<Eigen::Infinity>(), tau.lpNorm<Eigen::Infinity>());
    EXPECT_LE((M * (qdd - qdd_rt)).lpNorm<Eigen::Infinity>(), 1e3 * kEps * scale);
  }
}

// A spring without rest_length whose points coincide at the zero
// configuration: the default rest length would leave the force's direction
// undefined at rest, which is an error naming the spring and the fix.
TEST(Forces, CoincidentDefaultRestLengthIsAnError) {
  const char* xml = R"(<robot name="r">
  <link name="ground"/>
  <link name="block"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="slide" type="prismatic"><parent link="ground"/><child link="block"/><origin xyz="1 0 0"/></joint>
  <spring name="tie" stiffness="10"><parent link="ground" xyz="1 0 0"/><child link="block"/></spring>
</robot>)";
  const jrgen::ir::Robot robot = jrgen::urdf::read_robot_string(xml, "coincide.urdf");
  try {
    jrgen::topology::build_tree(robot);
    FAIL() << "no error";
  } catch (const jrgen::Error& error) {
    EXPECT_STREQ(error.what(),
                 "coincide.urdf:5: <spring> 'tie': its two points coincide at the zero configuration, so "
                 "rest_length (by default their distance there) leaves the force's direction undefined at "
                 "rest; give rest_length");
  }
}

// ---- Mimic rows (tests/forces/gripper_mimic.urdf) ------------------------------
//
// q = (wrist, finger_left, knuckle, finger_right), user order.  Rows:
// knuckle = -0.5 wrist + 0.1 (its leader an ancestor) and finger_right =
// -finger_left (siblings).  With these linear rows q = G y + c for the free
// y = (wrist, finger_left), G constant, so the constrained accelerations are
// qdd = G a with (G^T M G) a = G^T (tau - h): an independent route through
// the reduced equations, from the solver's own M and h.
struct LoopSolver {
  const char* name;
  int nc;
  int (*forward_dynamics)(const double*, const double*, const double*, double*, double*);
  void (*bias_forces)(const double*, const double*, double*);
  void (*mass_matrix)(const double*, double*);
  void (*constraints)(const double*, double*);
  void (*constraint_jacobian)(const double*, double*);
  void (*constraint_gamma)(const double*, const double*, double*);
  int (*solve_augmented)(const double*, const double*, const double*, const double*, double*, double*);
  const char* (*last_error)();
};
#define JR_LOOP_SOLVER(ns)                                                                                  \
  LoopSolver {                                                                                              \
    #ns, ns::nc, &ns::forward_dynamics, &ns::bias_forces, &ns::mass_matrix, &ns::constraints,               \
        &ns::constraint_jacobian, &ns::constraint_gamma, &ns::solve_augmented, &ns::last_error              \
  }
const std::vector<LoopSolver> kGrippers = {JR_LOOP_SOLVER(frc_gripper), JR_LOOP_SOLVER(frc_gripper_tables),
                                           JR_LOOP_SOLVER(frc_gripper_rt)};

Eigen::Matrix<double, 4, 2> gripper_G() {
  Eigen::Matrix<double, 4, 2> G;
  G << 1, 0,  //
      0, 1,   //
      -0.5, 0,  //
      0, -1;
  return G;
}

// qdd agrees with the reduced route to eps times cond(G^T M G) (below 1e4
// here) times a few: 1e-10 relative to |qdd|; a free mimic joint (the old
// behaviour) or a wrong sign breaks qdd_right = -qdd_left at O(1).
TEST(Mimic, RowsAreCountedAndTheMimicPairsMoveTogether) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Eigen::Matrix<double, 4, 2> G = gripper_G();
  for (const LoopSolver& s : kGrippers) {
    SCOPED_TRACE(s.name);
    EXPECT_EQ(s.nc, 2);
    for (int trial = 0; trial < 5; ++trial) {
      const Eigen::Vector2d y(u(rng), 0.03 * u(rng)), yd(2 * u(rng), 0.1 * u(rng));
      const Eigen::Vector4d q = G * y + Eigen::Vector4d(0, 0, 0.1, 0), v = G * yd;
      const Eigen::Vector4d tau(u(rng), u(rng), u(rng), u(rng));
      Eigen::Vector4d qdd;
      Eigen::Vector2d lambda, phi, gamma;
      ASSERT_EQ(s.forward_dynamics(q.data(), v.data(), tau.data(), qdd.data(), lambda.data()), 0);
      s.constraints(q.data(), phi.data());
      EXPECT_LE(phi.lpNorm<Eigen::Infinity>(), 4 * kEps);
      s.constraint_gamma(q.data(), v.data(), gamma.data());
      EXPECT_EQ(gamma, Eigen::Vector2d::Zero());
      Eigen::Matrix<double, 2, 4> Phiq;
      s.constraint_jacobian(q.data(), Phiq.data());
      Eigen::Matrix<double, 2, 4> expected;
      expected << 0.5, 0, 1, 0,  // knuckle + 0.5 wrist - 0.1
          0, 1, 0, 1;            // finger_right + finger_left
      EXPECT_EQ(Phiq, expected);
      const double scale = qdd.lpNorm<Eigen::Infinity>();
      EXPECT_NEAR(qdd[3], -qdd[1], 1e-10 * scale);
      EXPECT_NEAR(qdd[2], -0.5 * qdd[0], 1e-10 * scale);
      Eigen::Matrix4d M;
      Eigen::Vector4d h;
      s.mass_matrix(q.data(), M.data());
      s.bias_forces(q.data(), v.data(), h.data());
      const Eigen::Vector2d a = (G.transpose() * M * G).ldlt().solve(G.transpose() * (tau - h));
      EXPECT_LE((qdd - G * a).lpNorm<Eigen::Infinity>(), 1e-10 * scale);
      // The spring between the fingers on the loops' routes: specialized
      // (one program with Phiq) and runtime h agree to a few roundings.
      Eigen::Vector4d h_rt;
      kGrippers.back().bias_forces(q.data(), v.data(), h_rt.data());
      EXPECT_LE((h - h_rt).lpNorm<Eigen::Infinity>(), 64 * kEps * std::max(1.0, h_rt.lpNorm<Eigen::Infinity>()));
    }
  }
}

// tests/forces/chain80_mimic.urdf on the runtime's articulated-body route for
// loops (jr::articulated_closed, with tau - h_forces): j79 = 0.5 j0 + 0.2
// (leader an ancestor) and j40 = -2 j41 (leader a descendant), against the
// reduced equations as above (G: 80 x 78, constant).  The reduced matrix of
// 80 light links is ill-conditioned (cond 2e6-3e6 at these states: eps cond
// = 7e-10), so the bound is 1e-8 relative to |qdd| (measured: 2e-11); a
// wrong mimic entry is off by O(1).
TEST(Mimic, RuntimeArticulatedRouteForLoopsOnALongChain) {
  const int n = 80;
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(n, n - 2);
  std::vector<int> free;
  for (int k = 0; k < n; ++k)
    if (k != 79 && k != 40) free.push_back(k);
  for (int c = 0; c < n - 2; ++c) G(free[c], c) = 1.0;
  G(79, 0) = 0.5;                             // j79 = 0.5 j0 + 0.2
  G(40, std::find(free.begin(), free.end(), 41) - free.begin()) = -2.0;  // j40 = -2 j41
  std::mt19937_64 rng(80);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 3; ++trial) {
    Eigen::VectorXd y(n - 2), yd(n - 2), tau(n);
    for (int k = 0; k < n - 2; ++k) y[k] = 0.3 * u(rng), yd[k] = u(rng);
    for (int k = 0; k < n; ++k) tau[k] = 0.05 * u(rng);
    Eigen::VectorXd q = G * y, v = G * yd, qdd(n), h(n), lambda(2);
    q[79] += 0.2;
    ASSERT_EQ(frc_chain_mimic_rt::forward_dynamics(q.data(), v.data(), tau.data(), qdd.data(), lambda.data()), 0)
        << frc_chain_mimic_rt::last_error();
    Eigen::MatrixXd M(n, n);
    frc_chain_mimic_rt::mass_matrix(q.data(), M.data());
    frc_chain_mimic_rt::bias_forces(q.data(), v.data(), h.data());
    const Eigen::VectorXd a = (G.transpose() * M * G).ldlt().solve(G.transpose() * (tau - h));
    const double scale = qdd.lpNorm<Eigen::Infinity>();
    EXPECT_NEAR(qdd[79], 0.5 * qdd[0], 1e-12 * scale);
    EXPECT_NEAR(qdd[40], -2.0 * qdd[41], 1e-12 * scale);
    EXPECT_LE((qdd - G * a).lpNorm<Eigen::Infinity>(), 1e-8 * scale);
  }
}

// Status 2 names the mimic row by its joint: solve_augmented on a Phiq whose
// two rows are equal (both rows' Lemma 3 dofs include the wrist and the left
// finger: the knuckle hangs below the left finger).
TEST(Mimic, DependentRowsNameTheMimicJoint) {
  for (const LoopSolver& s : kGrippers) {
    SCOPED_TRACE(s.name);
    const Eigen::Vector4d q(0.2, 0.01, 0.0, -0.01), v = Eigen::Vector4d::Zero();
    Eigen::Matrix4d M;
    s.mass_matrix(q.data(), M.data());
    Eigen::Matrix<double, 2, 4> Phiq;
    Phiq << 0.5, 1, 0, 0,  // the wrist and the left finger are on both rows' paths (Lemma 3)
        0.5, 1, 0, 0;
    const Eigen::Vector4d Q(1, 2, 3, 4);
    const Eigen::Vector2d gamma = Eigen::Vector2d::Zero();
    Eigen::Vector4d qdd;
    Eigen::Vector2d lambda;
    EXPECT_EQ(s.solve_augmented(M.data(), Q.data(), Phiq.data(), gamma.data(), qdd.data(), lambda.data()), 2);
    EXPECT_NE(std::string(s.last_error()).find("mimic joint '"), std::string::npos) << s.last_error();
  }
}

}  // namespace
