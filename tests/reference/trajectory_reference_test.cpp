// jrgen's trajectories against the independent reference trajectories (issue 29 item 1;
// docs/testing.md, "References"): the committed files of tests/reference/trajectory_reference.cpp
// (SUNDIALS CVODE, rtol = atol = 1e-14, on the dynamics of tests/reference/; each file's
// header says how it was made).  For every case, the simulation layer's tight run (the
// method and tolerance the tests used as their reference before these files existed) is
// compared with the file at every output row (the whole span, the published check
// points included), max over rows and the written q and v columns.
//
// Bounds.  Each bound is the sum of the two errors the difference holds: jrgen's run at
// tol, 100 tol (its global error was measured at 0.3-50 x tol over these spans,
// docs/simulation.md, "Extreme cases in time"), and the reference's, its header's "error
// estimate" (the largest difference from the same CVODE run at 1e-13: the 1e-13 run's
// error, about 10 x the 1e-14 run's, so an estimate from above).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "extreme_cases.hpp"
#include "published_a02.hpp"
#include "published_a04.hpp"
#include "published_a05.hpp"
#include "reference/reference_dynamics.hpp"
#include "reference/reference_files.hpp"
#include "reference/reference_forces.hpp"
#include "urdf/urdf_reader.hpp"

namespace {

using jrgen::reference::ReferenceFile;
using jrgen::reference::read_reference_file;
using Vec = std::vector<double>;

ReferenceFile load(const std::string& relative) {
  return read_reference_file(std::string(JRGEN_SOURCE_DIR) + "/" + relative);
}

struct Compared {
  double q = 0, v = 0;  ///< max |jrgen - reference| over the rows, q and v columns
  std::size_t rows = 0;
};

/// 100 tol + the file's own error estimate (see "Bounds" above).
double bound(const ReferenceFile& ref, double tol) { return 100 * tol + ref.error_estimate(); }

/// Runs the mechanism with rows every `every` s and compares each row's q and v with
/// the file's columns q<i>, v<i> (those the file has).
Compared compare(const jrgen::sim::System& sys, const Vec& q0, const Vec& v0, double t_end, double every,
                 const std::string& method, double tol, const ReferenceFile& ref) {
  const jrgen::sim::Mechanism m(sys);
  Vec y = m.initial_state(q0.data(), v0.data());
  jrgen::sim::Settings s;
  s.method = method;
  s.rtol = s.atol = tol;
  s.every = every;
  Compared c;
  m.run(0.0, t_end, y, s, [&](double t, const double* yy) {
    const Vec& r = ref.row_at(t);
    for (std::size_t j = 1; j < ref.names.size(); ++j) {
      const std::string& n = ref.names[j];
      if (n[0] != 'q' && n[0] != 'v') continue;
      const int i = std::stoi(n.substr(1));
      const double x = n[0] == 'q' ? yy[i] : yy[sys.nq + i];
      (n[0] == 'q' ? c.q : c.v) = std::max(n[0] == 'q' ? c.q : c.v, std::abs(x - r[j]));
    }
    ++c.rows;
  });
  std::printf("%s %g: %zu rows, max |q - q_ref| %.2e, max |v - v_ref| %.2e\n", method.c_str(), tol, c.rows, c.q, c.v);
  return c;
}

// ---- the reference's force elements ------------------------------------------------------

// tests/reference/reference_forces: at rest the springs' part of h is the gradient of their
// potential (central differences, step 1e-6: truncation ~1e-13 x the third derivative of V,
// rounding ~eps V / 1e-6; bound 1e-7 of the largest term for the 8e5 and 1e9 N/m springs),
// on A05 and the point spring at states away from their starts.
TEST(TrajectoryReference, SpringForcesAreTheGradientOfTheirPotential) {
  const std::vector<std::pair<std::string, std::vector<double>>> models = {
      {"models/iftomm_a05_flyball.urdf", {0.3, 0.45, 0.4, 0.7}},
      {"tests/simulate/extreme/point_spring_1e9.urdf", {-0.8, 0.5, 0.2}}};
  for (const auto& [path, qs] : models) {
    const auto robot = jrgen::urdf::read_robot(std::string(JRGEN_SOURCE_DIR) + "/" + path);
    const Eigen::VectorXd q = Eigen::Map<const Eigen::VectorXd>(qs.data(), long(qs.size()));
    const Eigen::VectorXd h = jrgen::reference::force_element_bias(robot, q, Eigen::VectorXd::Zero(robot.nv()));
    for (int i = 0; i < robot.nv(); ++i) {
      Eigen::VectorXd qp = q, qm = q;
      qp[i] += 1e-6;
      qm[i] -= 1e-6;
      const double dV = (jrgen::reference::force_element_potential(robot, qp) -
                         jrgen::reference::force_element_potential(robot, qm)) / 2e-6;
      EXPECT_NEAR(h[i], dV, 1e-7 * h.cwiseAbs().maxCoeff()) << path << " coordinate " << i;
    }
  }
}

// ---- the published problems ------------------------------------------------------------

// A04 Bricard, 10 s from the figure at rest: dopri5 at 1e-12 (work_precision's reference
// before) against the file.
TEST(TrajectoryReference, A04) {
  const ReferenceFile ref = load("tests/published/reference/a04.tsv");
  const Compared c = compare(JRGEN_SIM_SYSTEM(published_a04), Vec(5, 0.0), Vec(5, 0.0), 10.0, 0.05, "dopri5", 1e-12, ref);
  EXPECT_EQ(c.rows, ref.rows.size());
  EXPECT_LE(c.q, bound(ref, 1e-12));  // measured 5.5e-11 (bound 1.0e-9)
  EXPECT_LE(c.v, bound(ref, 1e-12));  // measured 8.2e-11
}

// A05 flyball, 10 s from the published start: radau5 at 1e-12 (work_precision's reference
// before) against the file.
TEST(TrajectoryReference, A05) {
  const ReferenceFile ref = load("tests/published/reference/a05.tsv");
  const Compared c = compare(JRGEN_SIM_SYSTEM(published_a05), {0, 0.5, M_PI / 6, M_PI / 6}, {2 * M_PI, 0, 0, 0}, 10.0,
                             0.05, "radau5", 1e-12, ref);
  EXPECT_EQ(c.rows, ref.rows.size());
  EXPECT_LE(c.q, bound(ref, 1e-12));  // measured 5.8e-11 (bound 8.1e-10)
  EXPECT_LE(c.v, bound(ref, 1e-12));  // measured 3.5e-11
}

// A02, the full 81-coordinate model up to its first flat configuration (0.7216 s): jrgen's
// dopri5 at 1e-12 against the file; and the file's full model against the file's reduced
// equation (two references that share only the integrator): the full model stays on the
// parallelogram and moves as the pendulum th'' = c sin th.
TEST(TrajectoryReference, A02FullModelUpToTheFlatConfiguration) {
  const ReferenceFile full = load("tests/published/reference/a02.tsv");
  const ReferenceFile reduced = load("tests/published/reference/a02_reduced.tsv");
  Vec q0(81, 0.0), v0(81);
  for (int i = 0; i < 81; ++i) v0[i] = (i % 2 == 0) ? -1.0 : 1.0;
  const Compared c = compare(JRGEN_SIM_SYSTEM(published_a02), q0, v0, full.rows.back()[0], 0.05, "dopri5", 1e-12, full);
  EXPECT_EQ(c.rows, full.rows.size());
  EXPECT_LE(c.q, bound(full, 1e-12));  // measured 2.2e-12 (bound 1.2e-10)
  EXPECT_LE(c.v, bound(full, 1e-12));  // measured 8.0e-12
  double d = 0, defect = 0;
  for (const Vec& r : full.rows) {
    d = std::max(d, std::abs(r[full.column("q0")] - reduced.row_at(r[0])[reduced.column("th")]));
    defect = std::max(defect, r[full.column("defect")]);
  }
  std::printf("A02 full model vs reduced equation (both CVODE): %.2e, parallelogram defect %.2e\n", d, defect);
  // Both at 1e-14: their estimates (1.5e-11, 2.6e-9 for the 20 s of the reduced one;
  // measured 6.8e-14 over these 0.7 s) bound the difference; the full model's distance
  // from the parallelogram (measured 6.0e-14) is rounding of 81 angles (~100 eps).
  EXPECT_LE(d, full.error_estimate() + reduced.error_estimate());
  EXPECT_LE(defect, 1e-12);
}

// A02's reduced equation over the published 20 s, 401 rows: jrgen's dopri5 at 1e-13 on the
// 2-state ODE (published_test's reference before) against CVODE's.
TEST(TrajectoryReference, A02ReducedEquation) {
  const ReferenceFile ref = load("tests/published/reference/a02_reduced.tsv");
  const double c = 9.81 * (0.5 * 41 + 40) / (41 / 3.0 + 40);
  jrgen::sim::OdeProblem p;
  p.n = 2;
  p.rhs = [c](double, const double* y, double* dy, std::string&) {
    dy[0] = y[1];
    dy[1] = c * std::sin(y[0]);
    return 0;
  };
  Vec y = {0.0, -1.0};
  jrgen::sim::Settings s;
  s.method = "dopri5";
  s.rtol = s.atol = 1e-13;
  s.every = 0.05;
  double d = 0;
  std::size_t rows = 0;
  jrgen::sim::integrate(p, 0.0, 20.0, y, s, [&](double t, const double* yy) {
    d = std::max(d, std::abs(yy[0] - ref.row_at(t)[1]));
    ++rows;
  });
  std::printf("A02 reduced: dopri5 1e-13 vs CVODE: max |th - th_ref| %.2e over %zu rows\n", d, rows);
  EXPECT_EQ(rows, 401u);
  EXPECT_LE(d, bound(ref, 1e-13));  // measured 2.0e-10 (bound 2.6e-9)
}

// ---- the extreme cases in time -------------------------------------------------------------

struct ExtremeFile {
  jrgen::extreme::Case c;
  std::string file;
  double every;
};

// Every extreme case whose reference was a run of jrgen's own (extreme_cases.hpp,
// reference()), at that run's method and tolerance (1e-13; radau5 at 1e-12 for the
// point spring), against its file over the whole span.  At 1e-10 instead (4 x cheaper)
// dopri5's own error over the whole span reached 2.8e-7 on the heavy tips (2800 tol;
// the 0.3-50 tol of docs/simulation.md are at t_end): the check would measure dopri5.
TEST(TrajectoryReference, ExtremeCases) {
  namespace x = jrgen::extreme;
  const std::vector<ExtremeFile> cases = {
      {x::light_tip_1e6(), "dp_light_tip_1e6", 0.05},   {x::light_tip_1e9(), "dp_light_tip_1e9", 0.05},
      {x::light_tip_1e12(), "dp_light_tip_1e12", 0.05}, {x::heavy_tip_1e6(), "dp_heavy_tip_1e6", 0.05},
      {x::heavy_tip_1e9(), "dp_heavy_tip_1e9", 0.05},   {x::point_spring_1e9(), "point_spring_1e9", 0.05},
      {x::rope50(), "rope50", 0.01},                    {x::rope50(M_PI / 2), "rope50_horizontal", 0.01},
      {x::near_toggle(), "near_toggle", 0.05},          {x::top(100), "top_100", 0.01},
      {x::top(1000), "top_1000", 0.01}};
  for (const ExtremeFile& e : cases) {
    const ReferenceFile ref = load("tests/simulate/extreme/reference/" + e.file + ".tsv");
    std::printf("%s: ", e.file.c_str());
    const Compared c = compare(e.c.sys, e.c.q0, e.c.v0, e.c.t_end, e.every, e.c.ref_method, e.c.ref_tol, ref);
    EXPECT_EQ(c.rows, ref.rows.size()) << e.file;
    EXPECT_LE(c.q, bound(ref, e.c.ref_tol)) << e.file << ": estimate " << ref.error_estimate();
  }
}

}  // namespace
