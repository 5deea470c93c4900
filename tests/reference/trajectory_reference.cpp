// Independent reference trajectories (issue 29, item 1; docs/testing.md, "References"):
// the published problems A02, A04, A05 and the extreme cases in time that had no exact
// solution, integrated by SUNDIALS CVODE from the dynamics of tests/reference/ alone.
//
//   trajectory_reference CASE -o FILE [--commit TEXT]     write the reference (minutes)
//   trajectory_reference CASE --reproduce FILE --rows K   recompute rows 0..K and compare
//   trajectory_reference --list                           the cases
//
// Nothing here comes from runtime/, generator/ (but the URDF reader, which builds the
// ir::Robot) or a generated solver:
//   M, h      tests/reference/reference_dynamics.cpp (world-frame Newton-Euler, user order);
//   springs   tests/reference/reference_forces.cpp (docs/forces.md's definitions);
//   cut rows  tests/reference/reference_constraints.cpp (Phi, Phiq, gamma, every row of
//             every cut: redundant ones included, none dropped);
//   time      SUNDIALS CVODE 6.4 (Debian libsundials-dev), its own error control:
//             Adams-Moulton with fixed-point iteration (non-stiff cases) or BDF with
//             Newton and SUNDIALS' dense LU on a difference-quotient Jacobian (stiff
//             ones), rtol = atol = 1e-14 (--rtol to change; --method adams|bdf).
// Form: the index-1 ODE y = (q, v), q' = configuration_rate(q, v) (quaternions in R^4,
// normalized where used), v' = qdd, where qdd minimizes (1/2) (qdd - a)^T M (qdd - a),
// a = M^{-1} (-h), subject to Phiq qdd = gamma (Gauss's principle; the same qdd as
// [M Phiq^T; Phiq 0] when Phiq has full row rank).  With M = L L^T and x = L^T qdd this
// is the minimum-norm correction x = x_a + B^+ (gamma - B x_a), B = Phiq L^{-T}, B^+ by a
// rank-revealing complete orthogonal decomposition (threshold 1e-8 of the largest
// pivot, kRankThreshold): dependent rows (Bricard's, the planar loops' out-of-plane rows, the N
// four-bar's at its flat configuration) cost nothing and no row is chosen.  No
// stabilization: the drift max |Phi|, max |Phiq v| over the output rows is written in
// the header, with the number of evaluations whose rank fell below the rank at t = 0.
// The start is projected as the simulator defines it (project_start).
// A second run at rtol = atol = 1e-13 estimates the error: the header gives the largest
// difference between the two over the rows.
#include <cvode/cvode.h>
#include <nvector/nvector_serial.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>
#include <sunnonlinsol/sunnonlinsol_fixedpoint.h>

#include <Eigen/Cholesky>
#include <Eigen/Dense>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <functional>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "reference/reference_constraints.hpp"
#include "reference/reference_dynamics.hpp"
#include "reference/reference_forces.hpp"
#include "urdf/urdf_reader.hpp"

namespace {

using Eigen::MatrixXd;
using Eigen::Vector3d;
using Eigen::VectorXd;
namespace ref = jrgen::reference;

double kRtol = 1e-14, kCheckRtol = 1e-13;
// Pivots of B's rank-revealing QR below 1e-8 of the largest count as zero.  Off the
// constraint manifold (drift |Phi| ~ 1e-12) a dependent row's pivot is of the size of
// the drift (Bricard: 1.5e-12 measured), and enforcing it would divide by it; the
// genuine pivots of these cases are above 1e-8 except within 1e-8 rad of a change
// point (A02 flat, the parallelogram), where the header counts the evaluations.
constexpr double kRankThreshold = 1e-8;

// ---- the cases ----------------------------------------------------------------------

struct CaseDef {
  std::string name;
  std::string what;       ///< what it is the reference for
  std::string urdf;       ///< relative to the source tree; empty: the scalar pendulum below
  Vector3d gravity = Vector3d(0, 0, -9.81);
  std::vector<double> q0, v0;
  double t_end = 1.0, dt_out = 0.05;
  bool stiff = false;     ///< BDF + Newton (dense) instead of Adams + fixed point
  std::vector<int> out_q; ///< q (and v) columns written; empty: all
  double pendulum_c = 0;  ///< scalar case: th'' = pendulum_c sin th, (th, th') = (q0, v0)
  bool parallelogram_defect = false;  ///< a column max_i |q_i -+ q_0| (0 on the parallelogram)
};

CaseDef make(std::string name, std::string what, std::string urdf, Vector3d gravity, std::vector<double> q0,
             std::vector<double> v0, double t_end, double dt_out) {
  CaseDef d;
  d.name = std::move(name);
  d.what = std::move(what);
  d.urdf = std::move(urdf);
  d.gravity = gravity;
  d.q0 = std::move(q0);
  d.v0 = std::move(v0);
  d.t_end = t_end;
  d.dt_out = dt_out;
  return d;
}

std::vector<CaseDef> cases() {
  std::vector<CaseDef> c;
  const double g = 9.81, N = 40;
  auto a02 = [&](CaseDef d) {
    d.q0.assign(81, 0.0);
    d.v0.resize(81);
    for (int i = 0; i < 81; ++i) d.v0[i] = (i % 2 == 0) ? -1.0 : 1.0;
    return d;
  };
  CaseDef d;
  d = a02(make("a02", "IFToMM A02 N four-bar (N = 40), the full 81-coordinate model, 0.7 s (the first flat configuration is at 0.7216 s)",
                "models/iftomm_a02_nfourbar.urdf", Vector3d(0, -9.81, 0), {}, {}, 0.7, 0.05));
  d.out_q = {0, 1, 80};
  d.parallelogram_defect = true;
  c.push_back(d);
  d = make("a02_reduced", "IFToMM A02 on its parallelogram: th'' = c sin th, c = g (N/2 + 1/2 + N) / ((N + 1)/3 + N), N = 40",
       "", Vector3d(0, -9.81, 0), {0.0}, {-1.0}, 20, 0.05);
  d.pendulum_c = g * (0.5 * (N + 1) + N) / ((N + 1) / 3.0 + N);
  c.push_back(d);
  d = make("a04", "IFToMM A04 Bricard, from the figure at rest, 10 s", "models/iftomm_a04_bricard.urdf",
       Vector3d(0, -9.81, 0), std::vector<double>(5, 0.0), std::vector<double>(5, 0.0), 10, 0.05);
  c.push_back(d);
  d = make("a05", "IFToMM A05 stiff flyball governor, the published start, 10 s", "models/iftomm_a05_flyball.urdf",
       Vector3d(0, 0, -9.81), {0, 0.5, M_PI / 6, M_PI / 6}, {2 * M_PI, 0, 0, 0}, 10, 0.05);
  d.stiff = true;
  c.push_back(d);
  const std::string x = "tests/simulate/extreme/";
  for (const char* m : {"dp_light_tip_1e6", "dp_light_tip_1e9", "dp_light_tip_1e12", "dp_heavy_tip_1e6",
                        "dp_heavy_tip_1e9"}) {
    d = make(m, std::string("extreme case ") + m + ".urdf, from (1, -0.5) at rest, 5 s", x + m + ".urdf",
         Vector3d(0, 0, -9.81), {1.0, -0.5}, {0.0, 0.0}, 5, 0.05);
    c.push_back(d);
  }
  d = make("point_spring_1e9", "extreme case point_spring_1e9.urdf (the 1e9 N/m elastic pendulum), 2 s",
       x + "point_spring_1e9.urdf", Vector3d(0, 0, -9.81), {-std::cos(0.5), std::sin(0.5), 0.0}, {0, 0, 1}, 2, 0.05);
  d.stiff = true;
  c.push_back(d);
  for (double angle : {1.0, M_PI / 2}) {
    d = make(angle == 1.0 ? "rope50" : "rope50_horizontal",
         std::string("extreme case rope50.urdf released straight at ") + (angle == 1.0 ? "1 rad" : "pi/2") + ", 0.5 s",
         x + "rope50.urdf", Vector3d(0, 0, -9.81), std::vector<double>(50, 0.0), std::vector<double>(50, 0.0), 0.5,
         0.01);
    d.q0[0] = angle;
    c.push_back(d);
  }
  d = make("near_toggle", "extreme case near_toggle.urdf, from (0.3, -0.3, 0.3) at (1, -1, 1) rad/s, 3 s",
       x + "near_toggle.urdf", Vector3d(0, -9.81, 0), {0.3, -0.3, 0.3}, {1, -1, 1}, 3, 0.05);
  c.push_back(d);
  d = make("parallelogram", "extreme case parallelogram.urdf (full model), from 0.3 rad at 1 rad/s, 0.45 s (its first change point is at 0.50 s)",
       x + "parallelogram.urdf", Vector3d(0, -9.81, 0), {0.3, -0.3, 0.3}, {1, -1, 1}, 0.45, 0.05);
  d.parallelogram_defect = true;
  c.push_back(d);
  for (double th0 : {0.3, M_PI / 2}) {
    d = make(th0 == 0.3 ? "parallelogram_reduced" : "parallelogram_reduced_flat",
         "parallelogram.urdf's reduced equation (5/3) th'' = 2 g sin th, from " +
             std::string(th0 == 0.3 ? "0.3" : "pi/2") + " rad at 1 rad/s, 3 s",
         "", Vector3d(0, -9.81, 0), {th0}, {1.0}, 3, 0.05);
    d.pendulum_c = 0.6 * 2 * 9.81;
    c.push_back(d);
  }
  for (double spin : {100.0, 1000.0, 10000.0}) {
    d = make("top_" + std::to_string(int(spin)),
         "extreme case top.urdf tilted 0.3 rad, spin " + std::to_string(int(spin)) + " rad/s, 1 s",
         x + "top.urdf", Vector3d(0, 0, -9.81), {std::cos(0.15), std::sin(0.15), 0.0, 0.0}, {0, 0, spin}, 1, 0.01);
    c.push_back(d);
  }
  return c;
}

// ---- the equations ------------------------------------------------------------------

/// y = (q, v) of one case and its right-hand side from tests/reference/ alone.
class Equations {
 public:
  Equations(const CaseDef& c, const std::string& source_dir) : c_(c) {
    if (c.urdf.empty()) {
      nq_ = nv_ = 1;
      return;
    }
    robot_ = jrgen::urdf::read_robot(source_dir + "/" + c.urdf);
    nq_ = robot_.nq();
    nv_ = robot_.nv();
    for (const jrgen::ir::CutJoint& cut : robot_.cuts) {
      Cut k;
      k.D = ref::cut_distance(robot_, cut);
      Vector3d axis;
      ref::axis_basis(cut, axis, k.u, k.w);
      cuts_.push_back(k);
    }
    if (int(c.q0.size()) != nq_ || int(c.v0.size()) != nv_) throw std::runtime_error(c.name + ": q0/v0 sizes");
    rank0_ = rank_at(Eigen::Map<const VectorXd>(c.q0.data(), nq_), Eigen::Map<const VectorXd>(c.v0.data(), nv_));
  }
  int nq() const { return nq_; }
  int nv() const { return nv_; }
  const jrgen::ir::Robot& robot() const { return robot_; }
  long rank_deficient = 0;  ///< evaluations whose rank of B fell below rank0_

  void rhs(const double* y, double* dy) {
    if (c_.urdf.empty()) {
      dy[0] = y[1];
      dy[1] = c_.pendulum_c * std::sin(y[0]);
      return;
    }
    const Eigen::Map<const VectorXd> q(y, nq_), v(y + nq_, nv_);
    Eigen::Map<VectorXd>(dy, nq_) = ref::configuration_rate(robot_, q, v);
    Eigen::Map<VectorXd>(dy + nq_, nv_) = acceleration(q, v);
  }

  /// The start as the simulator defines it (docs/simulation.md, "Constraint
  /// stabilization"): q onto Phi(q) = 0 by Newton steps with the minimum-norm correction
  /// in the metric of M(q0) (kept from the first iterate), then v onto Phiq v = 0 in the
  /// metric of M(q).  Converged to 1e-15 (the simulator stops at 1e-14).
  void project_start(double* y) const {
    if (robot_.cuts.empty()) return;
    Eigen::Map<VectorXd> q(y, nq_), v(y + nq_, nv_);
    const Eigen::LLT<MatrixXd> M0(ref::mass_matrix(robot_, q));
    MatrixXd A;
    VectorXd Phi, gamma;
    for (int it = 0; it < 50; ++it) {
      rows(q, VectorXd(), A, Phi, gamma);
      if (Phi.cwiseAbs().maxCoeff() <= 1e-15) break;
      q = ref::integrate(robot_, q, min_norm_correction(M0, A, -Phi), 1.0);
    }
    rows(q, VectorXd(), A, Phi, gamma);
    const VectorXd dv = min_norm_correction(Eigen::LLT<MatrixXd>(ref::mass_matrix(robot_, q)), A, -(A * v));
    v += dv;
  }

  /// max |Phi|, max |Phiq v| over the rows of every cut.
  void drift(const double* y, double& phi, double& phiqv) const {
    phi = phiqv = 0.0;
    if (c_.urdf.empty()) return;
    const Eigen::Map<const VectorXd> q(y, nq_), v(y + nq_, nv_);
    MatrixXd A;
    VectorXd Phi, gamma;
    rows(q, VectorXd(), A, Phi, gamma);
    if (A.rows() == 0) return;
    phi = Phi.cwiseAbs().maxCoeff();
    phiqv = (A * v).cwiseAbs().maxCoeff();
  }

 private:
  struct Cut {
    double D = 0;
    Vector3d u, w;
  };

  void rows(const VectorXd& q, const VectorXd& v, MatrixXd& A, VectorXd& Phi, VectorXd& gamma) const {
    int m = 0;
    for (const auto& cut : robot_.cuts) m += jrgen::ir::cut_rows(cut.type);
    A.resize(m, nv_);
    Phi.resize(m);
    gamma.resize(m);
    int r = 0;
    for (std::size_t i = 0; i < cuts_.size(); ++i) {
      const ref::CutRows cr = ref::cut_rows(robot_, robot_.cuts[i], cuts_[i].D, cuts_[i].u, cuts_[i].w, q, v);
      const int k = int(cr.phi.size());
      A.middleRows(r, k) = cr.Phiq;
      Phi.segment(r, k) = cr.phi;
      gamma.segment(r, k) = cr.gamma;
      r += k;
    }
  }

  /// dx = -M^-1 A^T (A M^-1 A^T)^+ r... the smallest dx in the M-norm with A dx = rhs.
  static VectorXd min_norm_correction(const Eigen::LLT<MatrixXd>& M, const MatrixXd& A, const VectorXd& rhs) {
    const MatrixXd B = M.matrixL().solve(A.transpose()).transpose();
    Eigen::CompleteOrthogonalDecomposition<MatrixXd> cod;
    cod.setThreshold(kRankThreshold);
    cod.compute(B);
    return M.matrixU().solve(VectorXd(cod.solve(rhs)));
  }

  int rank_at(const VectorXd& q, const VectorXd& v) {
    long keep = rank_deficient;
    int rank = -1;
    acceleration(q, v, &rank);
    rank_deficient = keep;
    return rank;
  }

  /// Gauss's principle: qdd = L^{-T} (x_a + B^+ (gamma - B x_a)), x_a = L^{-1} (-h).
  VectorXd acceleration(const VectorXd& q, const VectorXd& v, int* rank_out = nullptr) {
    const MatrixXd M = ref::mass_matrix(robot_, q);
    const VectorXd h = ref::bias_forces(robot_, q, v, c_.gravity) + ref::force_element_bias(robot_, q, v);
    const Eigen::LLT<MatrixXd> llt(M);
    if (llt.info() != Eigen::Success) throw std::runtime_error(c_.name + ": M not positive definite");
    VectorXd x = llt.matrixL().solve(-h);
    if (!robot_.cuts.empty()) {
      MatrixXd A;
      VectorXd Phi, gamma;
      rows(q, v, A, Phi, gamma);
      const MatrixXd B = llt.matrixL().solve(A.transpose()).transpose();  // A L^{-T}
      Eigen::CompleteOrthogonalDecomposition<MatrixXd> cod;
      cod.setThreshold(kRankThreshold);
      cod.compute(B);
      x += cod.solve(gamma - B * x);
      if (rank_out) *rank_out = int(cod.rank());
      if (rank0_ >= 0 && cod.rank() < rank0_) ++rank_deficient;
    }
    return llt.matrixU().solve(x);
  }

  CaseDef c_;
  jrgen::ir::Robot robot_;
  std::vector<Cut> cuts_;
  int nq_ = 0, nv_ = 0, rank0_ = -1;
};

/// Quaternions of ball and floating joints normalized (the state holds them in R^4).
void normalize_quaternions(const jrgen::ir::Robot& robot, double* q) {
  int i = 0;
  for (const auto& j : robot.joints) {
    const int off = j.type == jrgen::ir::JointType::Floating ? 3 : 0;
    if (j.type == jrgen::ir::JointType::Ball || j.type == jrgen::ir::JointType::Floating) {
      Eigen::Map<Eigen::Vector4d> quat(q + i + off);
      quat.normalize();
    }
    i += jrgen::ir::joint_nq(j.type);
  }
}

// ---- CVODE ----------------------------------------------------------------------------

struct Run {
  std::vector<std::vector<double>> rows;  ///< t, written columns
  long steps = 0, rhs_evals = 0, jac_evals = 0, rank_deficient = 0;
  double phi = 0, phiqv = 0, quat_norm = 0;  ///< drifts over the rows
  double cpu_s = 0;
};

int cvode_rhs(sunrealtype, N_Vector y, N_Vector dy, void* user) {
  try {
    static_cast<Equations*>(user)->rhs(N_VGetArrayPointer(y), N_VGetArrayPointer(dy));
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rhs: %s\n", e.what());
    return -1;
  }
}

void check(int flag, const char* what) {
  if (flag < 0) throw std::runtime_error(std::string("CVODE: ") + what + " failed, flag " + std::to_string(flag));
}

std::vector<double> columns(const CaseDef& c, const Equations& eq, const double* y, Run& run) {
  std::vector<double> out;
  const int nq = eq.nq(), nv = eq.nv();
  std::vector<double> q(y, y + nq);
  if (!c.urdf.empty()) {
    double qn = 0;
    normalize_quaternions(eq.robot(), q.data());
    for (int i = 0; i < nq; ++i) qn = std::max(qn, std::abs(q[i] - y[i]));
    run.quat_norm = std::max(run.quat_norm, qn);
  }
  if (c.out_q.empty()) {
    out.insert(out.end(), q.begin(), q.end());
    out.insert(out.end(), y + nq, y + nq + nv);
  } else {
    for (int i : c.out_q) out.push_back(q[i]);
    for (int i : c.out_q) out.push_back(y[nq + i]);
  }
  if (c.parallelogram_defect) {
    double e = 0;
    for (int i = 1; i < nq; ++i) e = std::max(e, std::abs(y[i] - ((i % 2 == 0) ? y[0] : -y[0])));
    out.push_back(e);
  }
  double phi, phiqv;
  eq.drift(y, phi, phiqv);
  run.phi = std::max(run.phi, phi);
  run.phiqv = std::max(run.phiqv, phiqv);
  return out;
}

Run integrate(const CaseDef& c, const std::string& source_dir, double rtol, int max_rows) {
  Equations eq(c, source_dir);
  const int n = eq.nq() + eq.nv();
  Run run;
  const std::clock_t c0 = std::clock();
  SUNContext ctx;
  check(SUNContext_Create(nullptr, &ctx), "SUNContext_Create");
  N_Vector y = N_VNew_Serial(n, ctx);
  double* yd = N_VGetArrayPointer(y);
  for (int i = 0; i < eq.nq(); ++i) yd[i] = c.q0[i];
  for (int i = 0; i < eq.nv(); ++i) yd[eq.nq() + i] = c.v0[i];
  eq.project_start(yd);
  void* mem = CVodeCreate(c.stiff ? CV_BDF : CV_ADAMS, ctx);
  check(CVodeInit(mem, cvode_rhs, 0.0, y), "CVodeInit");
  check(CVodeSStolerances(mem, rtol, rtol), "CVodeSStolerances");
  check(CVodeSetUserData(mem, &eq), "CVodeSetUserData");
  check(CVodeSetMaxNumSteps(mem, 100000000), "CVodeSetMaxNumSteps");
  SUNMatrix A = nullptr;
  SUNLinearSolver LS = nullptr;
  SUNNonlinearSolver NLS = nullptr;
  if (c.stiff) {
    A = SUNDenseMatrix(n, n, ctx);
    LS = SUNLinSol_Dense(y, A, ctx);
    check(CVodeSetLinearSolver(mem, LS, A), "CVodeSetLinearSolver");
  } else {
    NLS = SUNNonlinSol_FixedPoint(y, 0, ctx);
    check(CVodeSetNonlinearSolver(mem, NLS), "CVodeSetNonlinearSolver");
  }
  const int n_out = int(std::lround(c.t_end / c.dt_out));
  std::vector<double> row = {0.0};
  auto cols = columns(c, eq, yd, run);
  row.insert(row.end(), cols.begin(), cols.end());
  run.rows.push_back(row);
  for (int k = 1; k <= n_out && k <= max_rows; ++k) {
    const double t_out = k == n_out ? c.t_end : k * c.dt_out;
    double t = 0;
    check(CVode(mem, t_out, y, &t, CV_NORMAL), "CVode");
    row = {t_out};
    cols = columns(c, eq, yd, run);
    row.insert(row.end(), cols.begin(), cols.end());
    run.rows.push_back(row);
  }
  CVodeGetNumSteps(mem, &run.steps);
  CVodeGetNumRhsEvals(mem, &run.rhs_evals);
  if (c.stiff) {
    long fe_ls = 0;
    CVodeGetNumJacEvals(mem, &run.jac_evals);
    CVodeGetNumLinRhsEvals(mem, &fe_ls);
    run.rhs_evals += fe_ls;
  }
  run.rank_deficient = eq.rank_deficient;
  CVodeFree(&mem);
  if (LS) SUNLinSolFree(LS);
  if (A) SUNMatDestroy(A);
  if (NLS) SUNNonlinSolFree(NLS);
  N_VDestroy(y);
  SUNContext_Free(&ctx);
  run.cpu_s = double(std::clock() - c0) / CLOCKS_PER_SEC;
  return run;
}

// ---- files ----------------------------------------------------------------------------

std::vector<std::string> column_names(const CaseDef& c, const std::string& source_dir) {
  std::vector<std::string> names = {"t"};
  if (c.urdf.empty()) return {"t", "th", "thd"};
  const Equations eq(c, source_dir);
  std::vector<int> idx = c.out_q;
  if (idx.empty())
    for (int i = 0; i < eq.nq(); ++i) idx.push_back(i);
  for (int i : idx) names.push_back("q" + std::to_string(i));
  if (c.out_q.empty()) idx.clear();
  if (c.out_q.empty())
    for (int i = 0; i < eq.nv(); ++i) idx.push_back(i);
  for (int i : idx) names.push_back("v" + std::to_string(i));
  if (c.parallelogram_defect) names.push_back("defect");
  return names;
}

double max_difference(const Run& a, const Run& b) {
  double d = 0;
  for (std::size_t k = 0; k < std::min(a.rows.size(), b.rows.size()); ++k)
    for (std::size_t j = 1; j < a.rows[k].size(); ++j) d = std::max(d, std::abs(a.rows[k][j] - b.rows[k][j]));
  return d;
}

/// (a, b, ...) with 17 digits; "(x, ... n values)" when long.
std::string join(const std::vector<double>& x) {
  std::ostringstream o;
  o.precision(17);
  o << "(";
  for (std::size_t i = 0; i < x.size() && i < 8; ++i) o << (i ? ", " : "") << x[i];
  if (x.size() > 8) o << ", ... " << x.size() << " values: the case list of trajectory_reference.cpp";
  o << ")";
  return o.str();
}

std::string utc_now() {
  char buf[64];
  const std::time_t now = std::time(nullptr);
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
  return buf;
}

void write(const CaseDef& c, const std::string& source_dir, const std::string& path, const std::string& commit) {
  const Run run = integrate(c, source_dir, kRtol, 1 << 30);
  const Run chk = integrate(c, source_dir, kCheckRtol, 1 << 30);
  std::ofstream f(path);
  char buf[512];
  f << "# Independent reference trajectory (issue 29 item 1; docs/testing.md, \"References\").\n";
  f << "# case: " << c.name << ": " << c.what << "\n";
  if (c.urdf.empty())
    std::snprintf(buf, sizeof buf, "# equation: th'' = %.17g sin th, th(0) = %.17g, th'(0) = %.17g (a 2-state ODE)\n",
                  c.pendulum_c, c.q0[0], c.v0[0]);
  else
    std::snprintf(buf, sizeof buf, "# model: %s, gravity (%g, %g, %g); dynamics tests/reference/reference_dynamics.cpp, "
                  "reference_forces.cpp, reference_constraints.cpp (all cut rows)\n",
                  c.urdf.c_str(), c.gravity.x(), c.gravity.y(), c.gravity.z());
  f << buf;
  f << "# start: q0 = " << join(c.q0) << ", v0 = " << join(c.v0)
    << (c.urdf.empty() ? "" : ", projected onto Phi = 0, Phiq v = 0 as docs/simulation.md defines") << "\n";
  f << "# form: index-1 ODE, qdd by Gauss's principle (rank-revealing least squares, no row dropped), "
       "no stabilization\n";
  std::snprintf(buf, sizeof buf, "# integrator: SUNDIALS CVODE %s, %s, rtol = atol = %g\n", "6.4",
                c.stiff ? "BDF, Newton, dense LU (SUNLinSol_Dense), difference-quotient Jacobian"
                        : "Adams-Moulton, fixed-point iteration",
                kRtol);
  f << buf;
  std::snprintf(buf, sizeof buf, "# run: %ld steps, %ld right-hand sides, %ld Jacobians, %.2g s CPU\n", run.steps,
                run.rhs_evals, run.jac_evals, run.cpu_s);
  f << buf;
  std::snprintf(buf, sizeof buf, "# error estimate: the same at rtol = atol = %g differs by at most %.2e over the rows\n",
                kCheckRtol, max_difference(run, chk));
  f << buf;
  std::snprintf(buf, sizeof buf, "# drift over the rows: max |Phi| %.2e, max |Phiq v| %.2e, quaternion |n - 1| %.2e; "
                "evaluations below the rank at t = 0: %ld\n", run.phi, run.phiqv, run.quat_norm, run.rank_deficient);
  f << buf;
  f << "# made by: tests/reference/trajectory_reference.cpp (scripts/make_trajectory_references.sh), " << commit
    << ", " << utc_now() << "\n";
  const std::vector<std::string> names = column_names(c, source_dir);
  for (std::size_t i = 0; i < names.size(); ++i) f << (i ? "\t" : "") << names[i];
  f << "\n";
  for (const auto& row : run.rows) {
    for (std::size_t i = 0; i < row.size(); ++i) {
      std::snprintf(buf, sizeof buf, "%.17g", row[i]);
      f << (i ? "\t" : "") << buf;
    }
    f << "\n";
  }
  std::printf("%s: %zu rows, %ld steps, %.1f s; rtol %g vs %g: %.2e; drift %.2e %.2e; rank-deficient %ld\n",
              c.name.c_str(), run.rows.size(), run.steps, run.cpu_s, kRtol, kCheckRtol, max_difference(run, chk), run.phi, run.phiqv,
              run.rank_deficient);
}

std::vector<std::vector<double>> read_rows(const std::string& path, std::string& header) {
  std::ifstream f(path);
  if (!f) throw std::runtime_error("cannot read " + path);
  std::vector<std::vector<double>> rows;
  std::string line;
  bool names = false;
  while (std::getline(f, line)) {
    if (line.rfind("#", 0) == 0) {
      header += line + "\n";
      continue;
    }
    if (!names) {
      names = true;
      continue;
    }
    std::istringstream is(line);
    std::vector<double> row;
    double x;
    while (is >> x) row.push_back(x);
    rows.push_back(row);
  }
  return rows;
}

// Recomputes rows 0..K and compares them with the file: the same program at the same
// settings.  On the machine that wrote the file the rows agree bitwise; elsewhere libm
// and the compiler may round differently, and CVODE's error control then follows a
// slightly different path: the difference is then of the size of the reference's own
// error over rows 0..K (the first 0.05-0.1 s), below 1e-9 in every header's estimate
// over the whole spans but the 1e9 N/m spring's and the near-toggle four-bar's, whose
// estimates are reached only later in their spans.
int reproduce(const CaseDef& c, const std::string& source_dir, const std::string& path, int k) {
  std::string header;
  const auto rows = read_rows(path, header);
  if (header.find("# case: " + c.name + ":") == std::string::npos) {
    std::fprintf(stderr, "%s: not the reference of case %s\n", path.c_str(), c.name.c_str());
    return 1;
  }
  const Run run = integrate(c, source_dir, kRtol, k);
  double d = 0;
  for (std::size_t r = 0; r < run.rows.size(); ++r) {
    if (r >= rows.size() || rows[r].size() != run.rows[r].size()) {
      std::fprintf(stderr, "%s: row %zu has another shape\n", path.c_str(), r);
      return 1;
    }
    for (std::size_t j = 0; j < rows[r].size(); ++j) d = std::max(d, std::abs(rows[r][j] - run.rows[r][j]));
  }
  std::printf("%s: rows 0..%zu (t <= %g) recomputed: max difference %.2e (bound 1e-9)\n", c.name.c_str(),
              run.rows.size() - 1, run.rows.back()[0], d);
  return d <= 1e-9 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    std::vector<CaseDef> all = cases();
    if (argc == 2 && std::string(argv[1]) == "--list") {
      for (const auto& c : all) std::printf("%s\t%s\n", c.name.c_str(), c.what.c_str());
      return 0;
    }
    if (argc < 4) {
      std::fprintf(stderr,
                   "usage: trajectory_reference CASE -o FILE [--commit TEXT] [--rtol R] [--method adams|bdf] [--t-end T]\n"
                   "       trajectory_reference CASE --reproduce FILE --rows K\n"
                   "       trajectory_reference --list\n");
      return 2;
    }
    const std::string name = argv[1], source_dir = JRGEN_SOURCE_DIR;
    auto it = std::find_if(all.begin(), all.end(), [&](const CaseDef& c) { return c.name == name; });
    if (it == all.end()) throw std::runtime_error("no case '" + name + "' (--list)");
    std::string out, repro, commit = "commit not given";
    int rows = 0;
    for (int i = 2; i + 1 < argc; i += 2) {
      const std::string a = argv[i];
      if (a == "-o") out = argv[i + 1];
      else if (a == "--commit") commit = argv[i + 1];
      else if (a == "--reproduce") repro = argv[i + 1];
      else if (a == "--rows") rows = std::stoi(argv[i + 1]);
      else if (a == "--rtol") kRtol = std::stod(argv[i + 1]), kCheckRtol = 10 * kRtol;
      else if (a == "--method") it->stiff = std::string(argv[i + 1]) == "bdf";
      else if (a == "--t-end") it->t_end = std::stod(argv[i + 1]);
      else throw std::runtime_error("unknown option " + a);
    }
    if (!repro.empty()) return reproduce(*it, source_dir, repro, rows);
    if (out.empty()) throw std::runtime_error("no -o FILE");
    write(*it, source_dir, out, commit);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "trajectory_reference: %s\n", e.what());
    return 1;
  }
}
