// The solver report, one model per process (docs/report.md).
//
// Problem (built once, before any timing): an assembled state of the model
// (q Newton-projected until |Phi(q)|_inf < 1e-12, v projected onto Phiq v = 0,
// tau random), and from the generated solver's own functions M, Q = tau - h,
// Phiq, gamma; the augmented matrix A = [M Phiq^T; Phiq 0] and b = [Q; gamma]
// of eq. (17).
//
// Methods (every one gets exactly these inputs; what a user does once --
// allocation, workspace queries, symbolic analysis -- is done outside the
// timed loop):
//   gauss        Eigen::PartialPivLU of A (the paper's dgesv): compute + solve
//   symmetric    LAPACKE_dsysv_work (Bunch-Kaufman L D L^T of A): copy of A
//                and b into the work arrays (dsysv overwrites them) + dsysv
//   sparse       UMFPACK on A in CSC: umfpack_di_symbolic once outside;
//                timed umfpack_di_numeric + umfpack_di_solve + free_numeric
//                (the role of the paper's Harwell MA28)
//   alg_d        Section 4.3 with dense Eigen matrices (Eigen::LLT of M and W)
//   alg_s        Section 4.3 interpreted from topology tables (alg_s.hpp)
//   gen_llt      the generated solve_augmented (--method llt)
//   gen_ldlt     the generated solve_augmented (--method ldlt)
//   mujoco       mj_factorM + mj_solveM on MuJoCo's own M (trees only)
//
// Full forward dynamics (issue 20), on the same q, v, tau:
//   fd/jrgen     the generated forward_dynamics (--method llt)
//   fd/mujoco    mj_forward (mujoco_model.hpp; trees only)
// each with its qdd error against the independent reference (fd_reference.hpp:
// the repository's world-frame M, h, Phiq, gamma, eq. (17) in long double),
// counter err_ref, and against jrgen's, err_jrgen.
//
// Accuracy (once per method, on its output): err_qdd = |qdd - qdd_ref| /
// |qdd_ref|, err_lambda likewise, err_f = |Phiq^T (lambda - lambda_ref)| /
// |Phiq^T lambda_ref| (lambda depends on how rows are scaled, Phiq^T lambda
// does not), and res17 = |b - A x| / (|A|_F |x| + |b|), the normwise backward
// error of eq. (17).  The reference x_ref solves A x = b by Eigen's
// PartialPivLU in long double (64-bit significand) with three steps of
// iterative refinement whose residual is computed in __float128.
#include "report_core.hpp"

#include <benchmark/benchmark.h>
#include <lapacke.h>
#include <suitesparse/umfpack.h>

#include <Eigen/Cholesky>
#include <Eigen/Dense>
#include <Eigen/LU>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "alg_s.hpp"
#include "analysis/constraints.hpp"
#include "analysis/runtime_model.hpp"
#include "fd_reference.hpp"
#include "mujoco_model.hpp"
#include "topology/topology.hpp"
#include "urdf/urdf_reader.hpp"

namespace jrgen::report {

namespace {

using VectorXld = Eigen::Matrix<long double, Eigen::Dynamic, 1>;
using MatrixXld = Eigen::Matrix<long double, Eigen::Dynamic, Eigen::Dynamic>;
constexpr double kEps = std::numeric_limits<double>::epsilon();

// ---- extended-precision reference --------------------------------------------

// b - A x with every product and sum in __float128.
VectorXld residual_q(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, const VectorXld& x) {
  const int n = static_cast<int>(b.size());
  std::vector<__float128> r(b.data(), b.data() + n);
  for (int j = 0; j < n; ++j) {
    const __float128 xj = x[j];
    if (xj == 0) continue;
    for (int i = 0; i < n; ++i) r[i] -= static_cast<__float128>(A(i, j)) * xj;
  }
  VectorXld out(n);
  for (int i = 0; i < n; ++i) out[i] = static_cast<long double>(r[i]);
  return out;
}

struct Reference {
  VectorXld x;
  double last_update = 0;  ///< relative size of the last refinement correction
  long double A_fro = 0, b_norm = 0;
};

Reference reference_solve(const Eigen::MatrixXd& A, const Eigen::VectorXd& b) {
  Reference ref;
  const MatrixXld A_ld = A.cast<long double>();
  Eigen::PartialPivLU<MatrixXld> lu(A_ld);
  ref.x = lu.solve(b.cast<long double>());
  for (int it = 0; it < 3; ++it) {
    const VectorXld dx = lu.solve(residual_q(A, b, ref.x));
    ref.last_update = static_cast<double>(dx.norm() / ref.x.norm());
    ref.x += dx;
  }
  ref.A_fro = A_ld.norm();
  ref.b_norm = b.cast<long double>().norm();
  return ref;
}

double cond1(const Eigen::MatrixXd& A) {
  return A.size() == 0 ? 1.0 : 1.0 / Eigen::PartialPivLU<Eigen::MatrixXd>(A).rcond();
}

// ---- the problem -------------------------------------------------------------

struct Problem {
  int nq = 0, nv = 0, nc = 0, K = 0;
  Eigen::VectorXd q, v, tau;
  double phi_inf = 0, phiq_v_inf = 0;
  Eigen::MatrixXd M, Phiq;  // column-major, user order
  Eigen::VectorXd h, Q, gamma;
  Eigen::MatrixXd A;
  Eigen::VectorXd b;
  Reference ref;
  double cond_A = 0, cond_M = 0, cond_W = 1;
};

Problem make_problem(const GeneratedApi& g, const topology::Tree& tree, std::uint64_t seed) {
  Problem p;
  p.nq = g.nq, p.nv = g.nv, p.nc = g.nc, p.K = g.nv + g.nc;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  p.q = analysis::neutral_configuration(tree);
  // Closed loops: a small step from the (assembled) zero configuration, then
  // Newton in the velocity coordinates; trees: any configuration.
  const double step = p.nc > 0 ? 0.03 : 1.0;
  analysis::integrate(tree, p.q, Eigen::VectorXd::NullaryExpr(p.nv, [&] { return step * u(rng); }));
  p.v = Eigen::VectorXd::NullaryExpr(p.nv, [&] { return u(rng); });
  p.tau = Eigen::VectorXd::NullaryExpr(p.nv, [&] { return 10.0 * u(rng); });
  Eigen::MatrixXd J(p.nc, p.nv);
  if (p.nc > 0) {
    Eigen::VectorXd phi(p.nc);
    for (int it = 0; it < 60; ++it) {
      g.constraints(p.q.data(), phi.data());
      if (phi.cwiseAbs().maxCoeff() < 1e-13) break;
      g.constraint_jacobian(p.q.data(), J.data());
      analysis::integrate(tree, p.q, -J.completeOrthogonalDecomposition().solve(phi));
    }
    g.constraints(p.q.data(), phi.data());
    p.phi_inf = phi.cwiseAbs().maxCoeff();
    if (!(p.phi_inf < 1e-12)) {
      std::fprintf(stderr, "report: Newton projection failed, |Phi|_inf = %.3e\n", p.phi_inf);
      std::exit(1);
    }
    g.constraint_jacobian(p.q.data(), J.data());
    for (int pass = 0; pass < 2; ++pass) p.v -= J.transpose() * (J * J.transpose()).ldlt().solve(J * p.v);
    p.phiq_v_inf = (J * p.v).cwiseAbs().maxCoeff();
  }
  p.M.resize(p.nv, p.nv);
  p.Phiq.resize(p.nc, p.nv);
  p.h.resize(p.nv);
  p.gamma.resize(p.nc);
  g.mass_matrix(p.q.data(), p.M.data());
  g.bias_forces(p.q.data(), p.v.data(), p.h.data());
  if (p.nc > 0) {
    g.constraint_jacobian(p.q.data(), p.Phiq.data());
    g.constraint_gamma(p.q.data(), p.v.data(), p.gamma.data());
  }
  p.Q = p.tau - p.h;
  p.A = Eigen::MatrixXd::Zero(p.K, p.K);
  p.A.topLeftCorner(p.nv, p.nv) = p.M;
  p.A.topRightCorner(p.nv, p.nc) = p.Phiq.transpose();
  p.A.bottomLeftCorner(p.nc, p.nv) = p.Phiq;
  p.b.resize(p.K);
  p.b << p.Q, p.gamma;
  p.ref = reference_solve(p.A, p.b);
  p.cond_A = cond1(p.A);
  p.cond_M = cond1(p.M);
  if (p.nc > 0) {
    Eigen::LLT<Eigen::MatrixXd> llt(p.M);
    const Eigen::MatrixXd T = llt.matrixL().solve(p.Phiq.transpose());
    p.cond_W = cond1(T.transpose() * T);
  }
  return p;
}

// ---- the methods ---------------------------------------------------------------

struct Method {
  std::string name;
  std::function<int()> solve;  ///< the timed call
  /// After an untimed solve: copies the method's result into qdd, lambda.
  std::function<void(Eigen::VectorXd& qdd, Eigen::VectorXd& lambda)> result;
  // Accuracy, filled by measure() after one untimed solve.
  int status = 0;
  double err_qdd = 0, err_lambda = 0, err_f = 0, res17 = 0, bound = 0;
  bool pass = true;
};

struct Gauss {
  const Problem& p;
  Eigen::PartialPivLU<Eigen::MatrixXd> lu;
  Eigen::VectorXd x, qdd, lambda;
  explicit Gauss(const Problem& pr) : p(pr), lu(pr.K), x(pr.K) {}
  int solve() {
    lu.compute(p.A);
    x.noalias() = lu.solve(p.b);
    return 0;
  }
};

struct Symmetric {
  const Problem& p;
  Eigen::MatrixXd A;
  Eigen::VectorXd x;
  std::vector<lapack_int> ipiv;
  std::vector<double> work;
  explicit Symmetric(const Problem& pr) : p(pr), A(pr.A), x(pr.b), ipiv(pr.K) {
    double lwork = 0;
    LAPACKE_dsysv_work(LAPACK_COL_MAJOR, 'L', p.K, 1, A.data(), p.K, ipiv.data(), x.data(), p.K, &lwork, -1);
    work.resize(static_cast<std::size_t>(std::max(1.0, lwork)));
  }
  int solve() {
    A = p.A;  // dsysv overwrites A with its factor and b with x
    x = p.b;
    return LAPACKE_dsysv_work(LAPACK_COL_MAJOR, 'L', p.K, 1, A.data(), p.K, ipiv.data(), x.data(), p.K,
                              work.data(), static_cast<lapack_int>(work.size()));
  }
};

struct Sparse {
  const Problem& p;
  std::vector<int> Ap, Ai;
  std::vector<double> Ax;
  void* symbolic = nullptr;
  double control[UMFPACK_CONTROL], info[UMFPACK_INFO];
  Eigen::VectorXd x;
  explicit Sparse(const Problem& pr) : p(pr), x(pr.K) {
    // CSC of A; entries that are exactly zero (structurally or by accident)
    // are left out.
    Ap.push_back(0);
    for (int j = 0; j < p.K; ++j) {
      for (int i = 0; i < p.K; ++i)
        if (p.A(i, j) != 0.0) {
          Ai.push_back(i);
          Ax.push_back(p.A(i, j));
        }
      Ap.push_back(static_cast<int>(Ai.size()));
    }
    umfpack_di_defaults(control);
    umfpack_di_symbolic(p.K, p.K, Ap.data(), Ai.data(), Ax.data(), &symbolic, control, info);
  }
  ~Sparse() {
    if (symbolic) umfpack_di_free_symbolic(&symbolic);
  }
  Sparse(const Sparse&) = delete;
  Sparse& operator=(const Sparse&) = delete;
  int solve() {
    void* numeric = nullptr;
    int s = umfpack_di_numeric(Ap.data(), Ai.data(), Ax.data(), symbolic, &numeric, control, info);
    if (s == UMFPACK_OK)
      s = umfpack_di_solve(UMFPACK_A, Ap.data(), Ai.data(), Ax.data(), x.data(), p.b.data(), numeric, control, info);
    umfpack_di_free_numeric(&numeric);
    return s;
  }
};

// Alg-D: the steps of Section 4.3 on dense matrices (tests/bench/loops_benchmark.cpp
// has the fixed-size variant for the HMMWV).  Inputs copied into Eigen
// matrices once; no allocation in the loop.
struct AlgD {
  const Problem& p;
  Eigen::LLT<Eigen::MatrixXd> llt_M, llt_W;
  Eigen::MatrixXd T, W;
  Eigen::VectorXd zn, yn, qdd, zm, lambda;
  explicit AlgD(const Problem& pr)
      : p(pr), llt_M(pr.nv), llt_W(pr.nc), T(pr.nv, pr.nc), W(pr.nc, pr.nc), zn(pr.nv), yn(pr.nv), qdd(pr.nv),
        zm(pr.nc), lambda(pr.nc) {}
  void step1() { llt_M.compute(p.M); }  // M = L L^T
  void step2() {                         // z_n = L^-1 Q
    zn = p.Q;
    llt_M.matrixL().solveInPlace(zn);
  }
  void step3_1() {  // T = L^-1 Phiq^T
    T = p.Phiq.transpose();
    llt_M.matrixL().solveInPlace(T);
  }
  void step3_2() {  // z_m = T^T z_n - gamma
    zm.noalias() = T.transpose() * zn;
    zm -= p.gamma;
  }
  void step3_3() { W.noalias() = T.transpose() * T; }
  void step3_4() {  // W lambda = z_m
    llt_W.compute(W);
    lambda = zm;
    llt_W.solveInPlace(lambda);
  }
  void step3_5() {  // y_n = z_n - T lambda
    yn = zn;
    yn.noalias() -= T * lambda;
  }
  void step4() {  // L^T qdd = y_n
    qdd = p.nc > 0 ? yn : zn;
    llt_M.matrixU().solveInPlace(qdd);
  }
  int solve() {
    step1();
    step2();
    if (p.nc > 0) {
      step3_1();
      step3_2();
      step3_3();
      step3_4();
      step3_5();
    }
    step4();
    return llt_M.info() == Eigen::Success && (p.nc == 0 || llt_W.info() == Eigen::Success) ? 0 : 1;
  }
  void run_step(int k) {
    switch (k) {
      case 0: step1(); break;
      case 1: step2(); break;
      case 2: step3_1(); break;
      case 3: step3_2(); break;
      case 4: step3_3(); break;
      case 5: step3_4(); break;
      case 6: step3_5(); break;
      default: step4(); break;
    }
  }
};

struct Generated {
  const Problem& p;
  const GeneratedApi& g;
  Eigen::VectorXd qdd, lambda;
  Generated(const Problem& pr, const GeneratedApi& api) : p(pr), g(api), qdd(pr.nv), lambda(pr.nc) {}
  int solve() {
    return g.solve_augmented(p.M.data(), p.Q.data(), p.nc ? p.Phiq.data() : nullptr,
                             p.nc ? p.gamma.data() : nullptr, qdd.data(), p.nc ? lambda.data() : nullptr);
  }
};

const char* const kStepNames[8] = {"1", "2", "3.1", "3.2", "3.3", "3.4", "3.5", "4"};

// ---- accuracy ------------------------------------------------------------------

void measure(Method& m, const Problem& p) {
  m.status = m.solve();
  const int nv = p.nv, nc = p.nc;
  Eigen::VectorXd qdd(nv), lambda(nc);
  m.result(qdd, lambda);
  VectorXld x(p.K);
  x << qdd.cast<long double>(), lambda.cast<long double>();
  const VectorXld& xr = p.ref.x;
  m.err_qdd = static_cast<double>((x.head(nv) - xr.head(nv)).norm() / xr.head(nv).norm());
  if (nc > 0) {
    const MatrixXld PhiqT = p.Phiq.transpose().cast<long double>();
    const long double lr = xr.tail(nc).norm();
    const long double fr = (PhiqT * xr.tail(nc)).norm();
    m.err_lambda = lr > 0 ? static_cast<double>((x.tail(nc) - xr.tail(nc)).norm() / lr) : 0.0;
    m.err_f = fr > 0 ? static_cast<double>((PhiqT * (x.tail(nc) - xr.tail(nc))).norm() / fr) : 0.0;
  }
  const VectorXld r = residual_q(p.A, p.b, x);
  m.res17 = static_cast<double>(r.norm() / (p.ref.A_fro * x.norm() + p.ref.b_norm));
  // Tolerance: a backward-stable solve of A x = b has a relative forward
  // error <= c(K) eps cond(A); the range-space methods (Alg-D, Alg-S,
  // generated) solve with M and W = T^T T, whose error grows with
  // cond(M) cond(W).  c(K) = 10 K covers the usual n-dependence generously;
  // a wrong permutation, row order or sign gives an O(1) error and fails.
  const double kappa = std::max(p.cond_A, p.cond_M * p.cond_W);
  m.bound = 10.0 * p.K * kEps * kappa;
  m.pass = m.status == 0 && std::isfinite(m.err_qdd) && m.err_qdd <= m.bound;
}

void add_counters(benchmark::State& state, const Method& m, const Problem& p) {
  state.counters["nv"] = p.nv;
  state.counters["nc"] = p.nc;
  state.counters["err_qdd"] = m.err_qdd;
  state.counters["err_lambda"] = m.err_lambda;
  state.counters["err_f"] = m.err_f;
  state.counters["res17"] = m.res17;
  state.counters["bound"] = m.bound;
  state.counters["pass"] = m.pass ? 1 : 0;
}

template <typename Fn>
void timing_loop(benchmark::State& state, Fn&& fn) {
  for (auto _ : state) {
    const int s = fn();
    benchmark::DoNotOptimize(s);
    benchmark::ClobberMemory();
  }
}

// ---- full forward dynamics ---------------------------------------------------------

struct FdCase {
  std::string name;
  std::function<void()> run;  ///< the timed call
  double err_ref = 0, err_jrgen = 0;
  bool pass = true;
};

// fd/jrgen and (with a MuJoCo model) fd/mujoco, their errors measured once.
// The check catches a wrong mapping or formula (an O(1) error) in jrgen's
// call, not rounding: the accuracy tests bound that (tests/generated).
std::vector<FdCase> forward_dynamics_cases(const ir::Robot& robot, const Problem& p, const GeneratedApi& g,
                                           MujocoModel* mj) {
  const Eigen::VectorXd ref = reference_qdd(robot, p.q, p.v, p.tau, Eigen::Vector3d(0, 0, -9.81));
  auto qdd = std::make_shared<Eigen::VectorXd>(p.nv);
  auto lambda = std::make_shared<Eigen::VectorXd>(p.nc);
  std::vector<FdCase> out;
  FdCase jr{"fd/jrgen", [&g, &p, qdd, lambda] {
              if (g.forward_dynamics(p.q.data(), p.v.data(), p.tau.data(), qdd->data(),
                                     p.nc ? lambda->data() : nullptr))
                std::abort();
            }};
  jr.run();
  const Eigen::VectorXd qdd_jr = *qdd;
  jr.err_ref = relative_error(qdd_jr, ref);
  jr.pass = jr.err_ref < 1e-6;
  out.push_back(jr);
  if (mj && mj->ok()) {
    mj->set_state(p.q, p.v, p.tau);
    FdCase m{"fd/mujoco", [mj] { mj->forward(); }};
    m.run();
    m.err_ref = relative_error(mj->qdd(), ref);
    m.err_jrgen = relative_error(mj->qdd(), qdd_jr);
    out.push_back(m);
  }
  return out;
}

struct Options {
  bool quick = false, steps = false, mujoco = true;
  std::string json;
  std::vector<char*> passthrough;
};

}  // namespace

int run(int argc, char** argv, const ModelInfo& info, const GeneratedApi& llt, const GeneratedApi& ldlt) {
  Options opt;
  opt.passthrough.push_back(argv[0]);
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--quick") {
      opt.quick = true;
    } else if (a == "--steps") {
      opt.steps = true;
    } else if (a == "--no-mujoco") {
      opt.mujoco = false;
    } else if (a == "--json" && i + 1 < argc) {
      opt.json = argv[++i];
    } else {
      opt.passthrough.push_back(argv[i]);
    }
  }
  // Google Benchmark: the median of repeated runs, the repetitions of all
  // methods randomly interleaved, so that a change of the machine's speed
  // during the program (docs/benchmarks.md, runs 5 and 8) falls on every
  // method alike instead of on the ones that happened to run then.
  std::vector<std::string> gb_args = {opt.quick ? "--benchmark_min_time=0.01" : "--benchmark_min_time=0.1",
                                      opt.quick ? "--benchmark_repetitions=3" : "--benchmark_repetitions=7",
                                      "--benchmark_enable_random_interleaving=true",
                                      "--benchmark_report_aggregates_only=true"};
  if (!opt.json.empty()) {
    gb_args.push_back("--benchmark_out=" + opt.json);
    gb_args.push_back("--benchmark_out_format=json");
  }
  std::vector<char*> gb_argv = {opt.passthrough[0]};
  for (std::string& s : gb_args) gb_argv.push_back(s.data());
  for (std::size_t i = 1; i < opt.passthrough.size(); ++i) gb_argv.push_back(opt.passthrough[i]);
  int gb_argc = static_cast<int>(gb_argv.size());
  benchmark::Initialize(&gb_argc, gb_argv.data());
  if (benchmark::ReportUnrecognizedArguments(gb_argc, gb_argv.data())) return 2;

  // The topology, exactly as the generator builds it (kept rows included).
  ir::Robot robot = urdf::read_robot(info.urdf);
  if (info.cuts[0]) urdf::read_cuts(info.cuts, robot);
  topology::Tree tree = topology::build_tree(robot);
  if (!robot.cuts.empty()) analysis::analyze_constraints(robot, tree, false);
  if (tree.nv != llt.nv || tree.nc() != llt.nc) {
    std::fprintf(stderr, "report: %s: topology (nv %d, nc %d) does not match the generated solver (nv %d, nc %d)\n",
                 info.name, tree.nv, tree.nc(), llt.nv, llt.nc);
    return 1;
  }

  const Problem p = make_problem(llt, tree, 20240603);
  const int nv = p.nv, nc = p.nc;
  char buf[512];
  benchmark::AddCustomContext("model", info.name);
  benchmark::AddCustomContext("compile_flags", JRGEN_REPORT_COMPILE_FLAGS);
  std::snprintf(buf, sizeof buf, "%d %d %d %d", p.nq, nv, nc, p.K);
  benchmark::AddCustomContext("sizes_nq_nv_nc_K", buf);
  std::snprintf(buf, sizeof buf, "%.3e", p.cond_A);
  benchmark::AddCustomContext("cond1_A", buf);
  std::snprintf(buf, sizeof buf, "%.3e", p.cond_M);
  benchmark::AddCustomContext("cond1_M", buf);
  std::snprintf(buf, sizeof buf, "%.3e", p.cond_W);
  benchmark::AddCustomContext("cond1_W", buf);
  std::snprintf(buf, sizeof buf, "|Phi|_inf %.2e, |Phiq v|_inf %.2e, reference last update %.1e", p.phi_inf,
                p.phiq_v_inf, p.ref.last_update);
  benchmark::AddCustomContext("state", buf);

  // The methods, each owning its workspace.
  Gauss gauss(p);
  Symmetric sym(p);
  Sparse sparse(p);
  AlgD algd(p);
  AlgS algs(tree, p.M.data(), p.Q.data(), p.Phiq.data(), p.gamma.data());
  Generated gen_llt(p, llt), gen_ldlt(p, ldlt);

  // The results of the stacked-x methods split into (qdd, lambda).
  auto split = [nv, nc](const Eigen::VectorXd& x) {
    return [&x, nv, nc](Eigen::VectorXd& qdd, Eigen::VectorXd& lambda) {
      qdd = x.head(nv);
      lambda = x.tail(nc);
    };
  };
  auto both = [](const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
    return [&a, &b](Eigen::VectorXd& qdd, Eigen::VectorXd& lambda) {
      qdd = a;
      lambda = b;
    };
  };
  std::vector<Method> methods;
  methods.push_back({"gauss", [&] { return gauss.solve(); }, split(gauss.x)});
  methods.push_back({"symmetric", [&] { return sym.solve(); }, split(sym.x)});
  methods.push_back({"sparse", [&] { return sparse.solve(); }, split(sparse.x)});
  methods.push_back({"alg_d", [&] { return algd.solve(); }, both(algd.qdd, algd.lambda)});
  methods.push_back({"alg_s", [&] { return algs.solve(); },
                     [&](Eigen::VectorXd& qdd, Eigen::VectorXd& lambda) {
                       qdd = Eigen::Map<const Eigen::VectorXd>(algs.qdd().data(), nv);
                       lambda = Eigen::Map<const Eigen::VectorXd>(algs.lambda().data(), nc);
                     }});
  methods.push_back({"gen_llt", [&] { return gen_llt.solve(); }, both(gen_llt.qdd, gen_llt.lambda)});
  methods.push_back({"gen_ldlt", [&] { return gen_ldlt.solve(); }, both(gen_ldlt.qdd, gen_ldlt.lambda)});
  bool all_pass = true;
  for (Method& m : methods) {
    measure(m, p);
    std::fprintf(stderr, "%-12s %-10s status %d  err_qdd %.2e  err_lambda %.2e  res17 %.2e  bound %.2e  %s\n",
                 info.name, m.name.c_str(), m.status, m.err_qdd, m.err_lambda, m.res17, m.bound,
                 m.pass ? "ok" : "FAIL");
    all_pass = all_pass && m.pass;
  }

  // MuJoCo, trees only: its own M for the same configuration.
  std::unique_ptr<MujocoModel> mj;
  Eigen::MatrixXd M_mj;
  Eigen::VectorXd rhs_mj, x_mj;
  Method mj_method;
  std::string mj_status = "not run (closed loops)";
  if (nc == 0 && opt.mujoco) {
    const std::string mjcf = std::string(info.name) + ".mjcf.xml";
    mj = std::make_unique<MujocoModel>(tree, mjcf);
    if (!mj->ok()) {
      mj_status = "MuJoCo rejected the model: " + mj->error();
      for (char& c : mj_status)
        if (c == '\n') c = ' ';
    } else {
      mj->set_configuration(p.q);
      M_mj = mj->dense_mass_matrix();
      const Eigen::MatrixXd& P = mj->P();
      const double dM = (M_mj - P.transpose() * p.M * P).norm() / p.M.norm();
      // The check: MuJoCo's CRB and jrgen's must agree to rounding.
      const bool m_ok = dM <= 1e-12;
      std::snprintf(buf, sizeof buf, "|M_mj - P^T M P|_F / |M|_F = %.2e (%s)", dM, m_ok ? "ok" : "FAIL");
      mj_status = buf;
      all_pass = all_pass && m_ok;
      rhs_mj = P.transpose() * p.Q;
      x_mj.resize(mj->nv());
      // Accuracy against the extended-precision solve of MuJoCo's own system.
      static Problem pm;
      pm.nv = pm.K = mj->nv();
      pm.nc = 0;
      pm.M = M_mj;
      pm.A = M_mj;
      pm.b = rhs_mj;
      pm.ref = reference_solve(pm.A, pm.b);
      pm.cond_A = pm.cond_M = cond1(M_mj);
      mj_method.name = "mujoco";
      mj_method.solve = [&] {
        mj->factor_and_solve(rhs_mj.data(), x_mj.data());
        return 0;
      };
      mj_method.result = [&](Eigen::VectorXd& qdd, Eigen::VectorXd& lambda) {
        qdd = x_mj;
        lambda.resize(0);
      };
      measure(mj_method, pm);
      std::fprintf(stderr, "%-12s %-10s status %d  err_qdd %.2e  res %.2e  bound %.2e  %s;  %s\n", info.name,
                   "mujoco", mj_method.status, mj_method.err_qdd, mj_method.res17, mj_method.bound,
                   mj_method.pass ? "ok" : "FAIL", mj_status.c_str());
      all_pass = all_pass && mj_method.pass;
      methods.push_back(mj_method);
    }
  }
  benchmark::AddCustomContext("mujoco_check", mj_status);
  std::vector<FdCase> fd = forward_dynamics_cases(robot, p, llt, mj.get());
  for (const FdCase& c : fd) {
    std::fprintf(stderr, "%-12s %-10s err vs reference %.2e  vs jrgen %.2e%s\n", info.name, c.name.c_str(),
                 c.err_ref, c.err_jrgen, c.pass ? "" : "  FAIL");
    all_pass = all_pass && c.pass;
  }

  // Register the timings: every method of this model in this one process.
  const auto us = benchmark::kMicrosecond;
  for (const Method& m : methods) {
    const Method* mp = &m;
    const Problem* pp = m.name == "mujoco" ? nullptr : &p;
    benchmark::RegisterBenchmark(m.name.c_str(), [mp, pp, &p](benchmark::State& state) {
      timing_loop(state, mp->solve);
      add_counters(state, *mp, pp ? *pp : p);
    })->Unit(us);
  }
  for (const FdCase& c : fd) {
    const FdCase* cp = &c;
    benchmark::RegisterBenchmark(c.name.c_str(), [cp, &p](benchmark::State& state) {
      for (auto _ : state) {
        cp->run();
        benchmark::ClobberMemory();
      }
      state.counters["nv"] = p.nv;
      state.counters["nc"] = p.nc;
      state.counters["err_ref"] = cp->err_ref;
      state.counters["err_jrgen"] = cp->err_jrgen;
    })->Unit(us);
  }
  // Per-step timings (Table 5): Alg-D and Alg-S one step at a time on the
  // data of a full solve; the generated code by prefixes (steps 1..k after
  // the gather; the step times are differences of consecutive prefixes).
  if (opt.steps) {
    algd.solve();
    algs.solve();
    for (int k = 0; k < 8; ++k) {
      if (nc == 0 && k >= 2 && k <= 6) continue;
      benchmark::RegisterBenchmark((std::string("step/alg_d/") + kStepNames[k]).c_str(),
                                   [&algd, k](benchmark::State& state) {
                                     for (auto _ : state) {
                                       algd.run_step(k);
                                       benchmark::ClobberMemory();
                                     }
                                   })
          ->Unit(us);
      benchmark::RegisterBenchmark((std::string("step/alg_s/") + kStepNames[k]).c_str(),
                                   [&algs, k](benchmark::State& state) {
                                     for (auto _ : state) {
                                       algs.run_step(k);
                                       benchmark::ClobberMemory();
                                     }
                                   })
          ->Unit(us);
    }
    for (const GeneratedApi* g : {&llt, &ldlt}) {
      if (!g->solve_steps) continue;
      const std::string method = g == &llt ? "gen_llt" : "gen_ldlt";
      for (int last = 0; last <= 8; ++last) {
        if (nc == 0 && last >= 3 && last <= 7) continue;
        benchmark::RegisterBenchmark(("prefix/" + method + "/" + std::to_string(last)).c_str(),
                                     [g, &p, last](benchmark::State& state) {
                                       for (auto _ : state) {
                                         const int s = g->solve_steps(p.M.data(), p.Q.data(), p.Phiq.data(),
                                                                      p.gamma.data(), last);
                                         benchmark::DoNotOptimize(s);
                                         benchmark::ClobberMemory();
                                       }
                                     })
            ->Unit(us);
      }
    }
  }
  benchmark::AddCustomContext("checks", all_pass ? "pass" : "FAIL");
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  if (!all_pass) std::fprintf(stderr, "report: %s: a check FAILED (see above)\n", info.name);
  return all_pass ? 0 : 1;
}

}  // namespace jrgen::report
