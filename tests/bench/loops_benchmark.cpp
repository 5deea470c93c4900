// Closed loops (issue 3): the HMMWV 14-body model with its 16 cut-joint rows
// (models/hmmwv14.urdf + hmmwv14.cuts.xml; nv = 27, nc = 16, the augmented
// system (17) is 43 x 43).  One process, one assembled state, every method on
// the same M, Q = tau - h, Phiq and gamma (built once, outside the timed loops):
//
//   gen_llt_solve_augmented    generated solve_augmented (default --method llt)
//   gen_ldlt_solve_augmented   generated solve_augmented (--method ldlt)
//   gauss_partial_lu/<fixed>   the paper's Gauss: Eigen::PartialPivLU of the
//                              43 x 43 augmented matrix, compute + solve
//                              (0: dynamic MatrixXd, 1: fixed 43 x 43)
//   alg_d/<fixed>              the paper's Alg-D: Steps 1-4 of Section 4.3 with
//                              dense Eigen matrices (LLT of M, T = L^-1 Phiq^T,
//                              W = T^T T, LLT of W), preallocated, no allocation
//                              in the loop (0: dynamic, 1: fixed-size)
//   alg_d_step/<step>          Alg-D (fixed-size) one step at a time, Table 5
//   gen_*_forward_dynamics     the full generated pipeline (kinematics, M, h,
//                              Phiq, gamma, solve) on the same q, v, tau
//
// The state: the zero configuration moved by a seeded random step, Newton-
// projected until |Phi(q)|_inf < 1e-12, v random and projected onto Phiq v = 0,
// tau random (as examples/demo/demo.cpp).  Accuracy counters of every solve
// (computed on its own output, after timing): err_qdd = |qdd - qdd_ref| /
// |qdd_ref|, err_f = |Phiq^T (lambda - lambda_ref)| / |Phiq^T lambda_ref|, and
// res17 = |b - A x| / (|A|_F |x| + |b|), the normwise backward error of eq. (17),
// evaluated in long double.  The reference solves the same system with
// PartialPivLU in long double and two steps of iterative refinement whose
// residual is taken in __float128.
#include <benchmark/benchmark.h>

#include <Eigen/Cholesky>
#include <Eigen/Dense>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "bench_gen_hmmwv14_loops.hpp"
#include "bench_gen_hmmwv14_loops_ldlt.hpp"

namespace gl = bench_gen_hmmwv14_loops;
namespace gd = bench_gen_hmmwv14_loops_ldlt;

namespace {

constexpr int N = gl::nv;  // 27
constexpr int C = gl::nc;  // 16
constexpr int K = N + C;   // 43
static_assert(gd::nv == N && gd::nc == C && gd::nq == gl::nq, "llt and ldlt solvers of one model");
static_assert(C > 0, "the HMMWV with its cuts has constraint rows");

using VectorXld = Eigen::Matrix<long double, Eigen::Dynamic, 1>;
using MatrixXld = Eigen::Matrix<long double, Eigen::Dynamic, Eigen::Dynamic>;

// ---- the assembled state (examples/demo/demo.cpp) ---------------------------

// q <- q "+" dv: plain addition, quaternions by the exponential map.
void integrate(Eigen::VectorXd& q, const Eigen::VectorXd& dv) {
  for (int j = 0; j < gl::njoints; ++j) {
    const int q0 = gl::joint_q_index[j], v0 = gl::joint_v_index[j];
    const int q1 = j + 1 < gl::njoints ? gl::joint_q_index[j + 1] : gl::nq;
    const int v1 = j + 1 < gl::njoints ? gl::joint_v_index[j + 1] : gl::nv;
    if (q1 - q0 == v1 - v0) {
      q.segment(q0, q1 - q0) += dv.segment(v0, v1 - v0);
      continue;
    }
    q.segment(q0, q1 - q0 - 4) += dv.segment(v0, v1 - v0 - 3);
    const Eigen::Vector3d w = dv.segment<3>(v1 - 3);
    Eigen::Quaterniond quat(q[q1 - 4], q[q1 - 3], q[q1 - 2], q[q1 - 1]);
    if (w.norm() > 0) quat = quat * Eigen::Quaterniond(Eigen::AngleAxisd(w.norm(), w.normalized()));
    quat.normalize();
    q.segment<4>(q1 - 4) << quat.w(), quat.x(), quat.y(), quat.z();
  }
}

struct Problem {
  Eigen::VectorXd q, v, tau;
  double phi_inf = 0, phiq_v_inf = 0;
  // The pieces, from the generated functions.
  Eigen::MatrixXd M, Phiq;  // N x N, C x N, column-major
  Eigen::VectorXd h, Q, gamma;
  // Eq. (17): A x = b, x = (qdd, lambda).
  Eigen::MatrixXd A;
  Eigen::VectorXd b;
  // Reference.
  VectorXld x_ref;
  long double A_fro = 0, b_norm = 0, f_ref_norm = 0;
  double ref_update = 0;  // relative size of the last refinement update
  double cond1 = 0;       // 1-norm condition estimate of A
  Eigen::VectorXd f_ref;  // Phiq^T lambda_ref (double)
};

// b - A x with the products in __float128.
VectorXld residual_q(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, const VectorXld& x) {
  VectorXld r(b.size());
  for (int i = 0; i < A.rows(); ++i) {
    __float128 s = b[i];
    for (int j = 0; j < A.cols(); ++j) s -= static_cast<__float128>(A(i, j)) * static_cast<__float128>(x[j]);
    r[i] = static_cast<long double>(s);
  }
  return r;
}

Problem make_problem() {
  Problem p;
  std::mt19937_64 rng(20240603);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  p.q = Eigen::VectorXd::Zero(gl::nq);
  for (int j = 0; j < gl::njoints; ++j) {
    const int q1 = j + 1 < gl::njoints ? gl::joint_q_index[j + 1] : gl::nq;
    const int v1 = j + 1 < gl::njoints ? gl::joint_v_index[j + 1] : gl::nv;
    if (q1 - gl::joint_q_index[j] != v1 - gl::joint_v_index[j]) p.q[q1 - 4] = 1.0;
  }
  integrate(p.q, Eigen::VectorXd::NullaryExpr(N, [&] { return 0.1 * u(rng); }));
  p.v = Eigen::VectorXd::NullaryExpr(N, [&] { return u(rng); });
  p.tau = Eigen::VectorXd::NullaryExpr(N, [&] { return 10.0 * u(rng); });
  Eigen::VectorXd phi(C);
  Eigen::MatrixXd J(C, N);
  for (int it = 0; it < 50; ++it) {
    gl::constraints(p.q.data(), phi.data());
    if (phi.cwiseAbs().maxCoeff() < 1e-13) break;
    gl::constraint_jacobian(p.q.data(), J.data());
    integrate(p.q, -J.completeOrthogonalDecomposition().solve(phi));
  }
  gl::constraints(p.q.data(), phi.data());
  p.phi_inf = phi.cwiseAbs().maxCoeff();
  if (!(p.phi_inf < 1e-12)) {
    std::fprintf(stderr, "loops_benchmark: Newton projection failed, |Phi| = %.3e\n", p.phi_inf);
    std::exit(1);
  }
  gl::constraint_jacobian(p.q.data(), J.data());
  for (int pass = 0; pass < 2; ++pass) p.v -= J.transpose() * (J * J.transpose()).ldlt().solve(J * p.v);
  p.phiq_v_inf = (J * p.v).cwiseAbs().maxCoeff();

  p.M.resize(N, N);
  p.Phiq.resize(C, N);
  p.h.resize(N);
  p.gamma.resize(C);
  gl::mass_matrix(p.q.data(), p.M.data());
  gl::bias_forces(p.q.data(), p.v.data(), p.h.data());
  gl::constraint_jacobian(p.q.data(), p.Phiq.data());
  gl::constraint_gamma(p.q.data(), p.v.data(), p.gamma.data());
  p.Q = p.tau - p.h;

  p.A = Eigen::MatrixXd::Zero(K, K);
  p.A.topLeftCorner(N, N) = p.M;
  p.A.topRightCorner(N, C) = p.Phiq.transpose();
  p.A.bottomLeftCorner(C, N) = p.Phiq;
  p.b.resize(K);
  p.b << p.Q, p.gamma;

  // Reference: LU in long double, refined twice with a __float128 residual.
  const MatrixXld A_ld = p.A.cast<long double>();
  Eigen::PartialPivLU<MatrixXld> lu(A_ld);
  p.x_ref = lu.solve(p.b.cast<long double>());
  for (int it = 0; it < 2; ++it) {
    const VectorXld dx = lu.solve(residual_q(p.A, p.b, p.x_ref));
    p.ref_update = static_cast<double>(dx.norm() / p.x_ref.norm());
    p.x_ref += dx;
  }
  p.A_fro = A_ld.norm();
  p.b_norm = p.b.cast<long double>().norm();
  const VectorXld f = p.Phiq.cast<long double>().transpose() * p.x_ref.tail(C);
  p.f_ref_norm = f.norm();
  p.f_ref = f.cast<double>();
  p.cond1 = 1.0 / Eigen::PartialPivLU<Eigen::MatrixXd>(p.A).rcond();
  return p;
}

Problem& problem() {
  static Problem p = make_problem();
  return p;
}

void add_accuracy(benchmark::State& state, const Eigen::VectorXd& qdd, const Eigen::VectorXd& lambda) {
  const Problem& p = problem();
  VectorXld x(K);
  x << qdd.cast<long double>(), lambda.cast<long double>();
  const VectorXld dq = x.head(N) - p.x_ref.head(N);
  const VectorXld df = p.Phiq.cast<long double>().transpose() * (x.tail(C) - p.x_ref.tail(C));
  const VectorXld r = residual_q(p.A, p.b, x);
  state.counters["err_qdd"] = static_cast<double>(dq.norm() / p.x_ref.head(N).norm());
  state.counters["err_f"] = static_cast<double>(df.norm() / p.f_ref_norm);
  state.counters["res17"] = static_cast<double>(r.norm() / (p.A_fro * x.norm() + p.b_norm));
}

// ---- operation counts of the --report files --------------------------------

struct Ops {
  long a = -1, m = -1, d = -1, sq = -1;
};

// The "Total" column of the A, M, D and SQ rows of a --report file.
Ops read_ops(const char* path) {
  Ops ops;
  std::ifstream in(path);
  if (!in) return ops;
  std::string line;
  int total_col = -1;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] != '|') continue;
    std::vector<std::string> cells;
    std::stringstream ss(line.substr(1));
    std::string cell;
    while (std::getline(ss, cell, '|')) {
      const auto b = cell.find_first_not_of(" *");
      const auto e = cell.find_last_not_of(" *");
      cells.push_back(b == std::string::npos ? "" : cell.substr(b, e - b + 1));
    }
    if (total_col < 0) {
      for (size_t i = 0; i < cells.size(); ++i)
        if (cells[i] == "Total") total_col = static_cast<int>(i);
      continue;
    }
    if (cells.empty() || total_col >= static_cast<int>(cells.size())) continue;
    const std::string& row = cells[0];
    long* slot = row == "A" ? &ops.a : row == "M" ? &ops.m : row == "D" ? &ops.d : row == "SQ" ? &ops.sq : nullptr;
    if (slot && *slot < 0) *slot = std::strtol(cells[total_col].c_str(), nullptr, 10);
  }
  return ops;
}

void add_ops(benchmark::State& state, const Ops& o) {
  state.counters["ops_A"] = static_cast<double>(o.a);
  state.counters["ops_M"] = static_cast<double>(o.m);
  state.counters["ops_D"] = static_cast<double>(o.d);
  state.counters["ops_SQ"] = static_cast<double>(o.sq);
}

std::string ops_string(const Ops& o) {
  return "A " + std::to_string(o.a) + ", M " + std::to_string(o.m) + ", D " + std::to_string(o.d) + ", SQ " +
         std::to_string(o.sq);
}

// ---- (a), (b): generated solve_augmented -----------------------------------

template <typename Fn>
void run_generated_solve(benchmark::State& state, Fn solve, const char* (*last_error)(), const char* ops_path) {
  Problem& p = problem();
  Eigen::VectorXd qdd(N), lambda(C);
  if (solve(p.M.data(), p.Q.data(), p.Phiq.data(), p.gamma.data(), qdd.data(), lambda.data()) != 0) {
    state.SkipWithError(last_error());
    return;
  }
  const double* M = p.M.data();
  const double* Q = p.Q.data();
  const double* Phiq = p.Phiq.data();
  const double* gamma = p.gamma.data();
  for (auto _ : state) {
    benchmark::DoNotOptimize(M);
    const int status = solve(M, Q, Phiq, gamma, qdd.data(), lambda.data());
    benchmark::DoNotOptimize(status);
    benchmark::ClobberMemory();
  }
  add_accuracy(state, qdd, lambda);
  add_ops(state, read_ops(ops_path));
}

void BM_gen_llt_solve_augmented(benchmark::State& state) {
  run_generated_solve(state, &gl::solve_augmented, &gl::last_error, JRGEN_LOOPS_OPS_LLT);
}
void BM_gen_ldlt_solve_augmented(benchmark::State& state) {
  run_generated_solve(state, &gd::solve_augmented, &gd::last_error, JRGEN_LOOPS_OPS_LDLT);
}

// ---- (c) Gauss: PartialPivLU of the augmented matrix ------------------------

template <typename Mat, typename Vec>
void run_gauss(benchmark::State& state) {
  Problem& p = problem();
  Mat A = p.A;  // built outside the timed loop
  Vec b = p.b, x(K);
  Eigen::PartialPivLU<Mat> lu(K);
  for (auto _ : state) {
    benchmark::DoNotOptimize(A.data());
    benchmark::DoNotOptimize(b.data());
    lu.compute(A);
    x.noalias() = lu.solve(b);
    benchmark::DoNotOptimize(x.data());
    benchmark::ClobberMemory();
  }
  add_accuracy(state, x.head(N), x.tail(C));
  // The paper's Table 1 (dgesv on 43 x 43).
  add_ops(state, Ops{27391, 27391, 946, 0});
  state.counters["cond1_A"] = p.cond1;
}

void BM_gauss_partial_lu(benchmark::State& state) {
  if (state.range(0) == 0)
    run_gauss<Eigen::MatrixXd, Eigen::VectorXd>(state);
  else
    run_gauss<Eigen::Matrix<double, K, K>, Eigen::Matrix<double, K, 1>>(state);
}

// ---- (d) Alg-D: Section 4.3 with dense matrices ------------------------------

template <bool Fixed>
struct AlgD {
  static constexpr int RN = Fixed ? N : Eigen::Dynamic;
  static constexpr int RC = Fixed ? C : Eigen::Dynamic;
  using MatNN = Eigen::Matrix<double, RN, RN>;
  using MatNC = Eigen::Matrix<double, RN, RC>;
  using MatCN = Eigen::Matrix<double, RC, RN>;
  using MatCC = Eigen::Matrix<double, RC, RC>;
  using VecN = Eigen::Matrix<double, RN, 1>;
  using VecC = Eigen::Matrix<double, RC, 1>;

  // Inputs.
  MatNN M;
  MatCN Phiq;
  VecN Q;
  VecC gamma;
  // Workspace and outputs.
  Eigen::LLT<MatNN> llt_M;
  Eigen::LLT<MatCC> llt_W;
  MatNC T;
  MatCC W;
  VecN zn, yn, qdd;
  VecC zm, lambda;

  explicit AlgD(const Problem& p)
      : M(p.M), Phiq(p.Phiq), Q(p.Q), gamma(p.gamma), llt_M(N), llt_W(C), T(N, C), W(C, C), zn(N), yn(N),
        qdd(N), zm(C), lambda(C) {}

  void step1() { llt_M.compute(M); }
  void step2() {
    zn = Q;
    llt_M.matrixL().solveInPlace(zn);
  }
  void step3_1() {
    T = Phiq.transpose();
    llt_M.matrixL().solveInPlace(T);
  }
  void step3_2() {
    zm.noalias() = T.transpose() * zn;
    zm -= gamma;
  }
  void step3_3() { W.noalias() = T.transpose() * T; }
  void step3_4() {
    llt_W.compute(W);
    lambda = zm;
    llt_W.solveInPlace(lambda);
  }
  void step3_5() { yn.noalias() = T * lambda; }
  void step4() {
    qdd = zn - yn;
    llt_M.matrixU().solveInPlace(qdd);
  }
  void solve() {
    step1();
    step2();
    step3_1();
    step3_2();
    step3_3();
    step3_4();
    step3_5();
    step4();
  }
  bool ok() const { return llt_M.info() == Eigen::Success && llt_W.info() == Eigen::Success; }
};

template <bool Fixed>
void run_alg_d(benchmark::State& state) {
  auto alg = std::make_unique<AlgD<Fixed>>(problem());
  for (auto _ : state) {
    benchmark::DoNotOptimize(alg->M.data());
    alg->solve();
    benchmark::DoNotOptimize(alg->qdd.data());
    benchmark::DoNotOptimize(alg->lambda.data());
    benchmark::ClobberMemory();
  }
  if (!alg->ok()) state.SkipWithError("Alg-D: Cholesky failed");
  add_accuracy(state, alg->qdd, alg->lambda);
  // The paper's Table 3.
  add_ops(state, Ops{15914, 16410, 989, 43});
}

void BM_alg_d(benchmark::State& state) {
  if (state.range(0) == 0)
    run_alg_d<false>(state);
  else
    run_alg_d<true>(state);
}

// One step of Alg-D (fixed-size), its inputs prepared by a full solve first.
void BM_alg_d_step(benchmark::State& state) {
  auto alg = std::make_unique<AlgD<true>>(problem());
  alg->solve();
  using Step = void (AlgD<true>::*)();
  static const Step steps[] = {&AlgD<true>::step1,   &AlgD<true>::step2,   &AlgD<true>::step3_1,
                               &AlgD<true>::step3_2, &AlgD<true>::step3_3, &AlgD<true>::step3_4,
                               &AlgD<true>::step3_5, &AlgD<true>::step4};
  static const char* const names[] = {"1", "2", "3.1", "3.2", "3.3", "3.4", "3.5", "4"};
  const Step step = steps[state.range(0)];
  for (auto _ : state) {
    benchmark::DoNotOptimize(alg.get());
    (alg.get()->*step)();
    benchmark::ClobberMemory();
  }
  state.SetLabel(std::string("step ") + names[state.range(0)]);
}

// ---- (e) generated forward_dynamics -----------------------------------------

template <typename Fn>
void run_forward_dynamics(benchmark::State& state, Fn fd, const char* (*last_error)()) {
  Problem& p = problem();
  Eigen::VectorXd qdd(N), lambda(C);
  if (fd(p.q.data(), p.v.data(), p.tau.data(), qdd.data(), lambda.data()) != 0) {
    state.SkipWithError(last_error());
    return;
  }
  const double* q = p.q.data();
  for (auto _ : state) {
    benchmark::DoNotOptimize(q);
    const int status = fd(q, p.v.data(), p.tau.data(), qdd.data(), lambda.data());
    benchmark::DoNotOptimize(status);
    benchmark::ClobberMemory();
  }
  add_accuracy(state, qdd, lambda);
}

void BM_gen_llt_forward_dynamics(benchmark::State& state) {
  run_forward_dynamics(state, &gl::forward_dynamics, &gl::last_error);
}
void BM_gen_ldlt_forward_dynamics(benchmark::State& state) {
  run_forward_dynamics(state, &gd::forward_dynamics, &gd::last_error);
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  const Problem& p = problem();
  char buf[256];
  benchmark::AddCustomContext("model", "hmmwv14 + hmmwv14.cuts.xml");
  std::snprintf(buf, sizeof buf, "nq %d, nv %d, nc %d, augmented %d x %d", gl::nq, N, C, K, K);
  benchmark::AddCustomContext("sizes", buf);
  std::snprintf(buf, sizeof buf, "|Phi|_inf %.2e, |Phiq v|_inf %.2e, cond1(A) %.2e, last refinement update %.1e",
                p.phi_inf, p.phiq_v_inf, p.cond1, p.ref_update);
  benchmark::AddCustomContext("state", buf);
  benchmark::AddCustomContext("ops_gen_llt", ops_string(read_ops(JRGEN_LOOPS_OPS_LLT)));
  benchmark::AddCustomContext("ops_gen_ldlt", ops_string(read_ops(JRGEN_LOOPS_OPS_LDLT)));
  benchmark::AddCustomContext("ops_gauss_paper_table1", ops_string(Ops{27391, 27391, 946, 0}));
  benchmark::AddCustomContext("ops_alg_d_paper_table3", ops_string(Ops{15914, 16410, 989, 43}));

  const auto us = benchmark::kMicrosecond;
  benchmark::RegisterBenchmark("gen_llt_solve_augmented", BM_gen_llt_solve_augmented)->Unit(us);
  benchmark::RegisterBenchmark("gen_ldlt_solve_augmented", BM_gen_ldlt_solve_augmented)->Unit(us);
  benchmark::RegisterBenchmark("gauss_partial_lu", BM_gauss_partial_lu)->ArgName("fixed")->Arg(0)->Arg(1)->Unit(us);
  benchmark::RegisterBenchmark("alg_d", BM_alg_d)->ArgName("fixed")->Arg(0)->Arg(1)->Unit(us);
  benchmark::RegisterBenchmark("alg_d_step", BM_alg_d_step)->DenseRange(0, 7)->Unit(us);
  benchmark::RegisterBenchmark("gen_llt_forward_dynamics", BM_gen_llt_forward_dynamics)->Unit(us);
  benchmark::RegisterBenchmark("gen_ldlt_forward_dynamics", BM_gen_ldlt_forward_dynamics)->Unit(us);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
