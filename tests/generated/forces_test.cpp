// Force elements (INTERFACE.md section 2b: springs, joint springs, joint
// forces) in h and in the potential energy, on the three routes of a tree's
// forward_dynamics: the specialized composite-rigid-body and articulated-body
// programs (JRGEN_TERMS_ROUTE) and the runtime's terms (JRGEN_TERMS_LIMIT=0),
// generated from tests/forces/*.urdf (tests/CMakeLists.txt).
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "frc_branched.hpp"
#include "frc_branched_aba.hpp"
#include "frc_branched_rt.hpp"
#include "frc_coincide.hpp"
#include "frc_coincide_rt.hpp"
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

}  // namespace
