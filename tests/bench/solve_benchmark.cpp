// One benchmark program per model (tests/bench/CMakeLists.txt compiles this
// file once per generated solver, with JRGEN_BENCH_NS naming its namespace and
// JRGEN_BENCH_HEADER its header).  All methods run in the same process on the
// same data, set up once outside the timed loops (bench_fixture.hpp):
//
//   generated_solve_augmented  solve_augmented(M, Q, nullptr, nullptr, qdd, nullptr)
//   eigen_dense_llt            Eigen::LLT<MatrixXd>: compute(M) + solve(Q)
//   eigen_dense_partial_lu     Eigen::PartialPivLU<MatrixXd>: compute(M) + solve(Q)
//   eigen_sparse_llt           Eigen::SimplicialLLT (AMD ordering; pattern analysed
//                              once, outside the loop): factorize(M) + solve(Q)
//   generated_forward_dynamics forward_dynamics(q, v, tau, qdd, nullptr), full pipeline
//   serial_solve_augmented, serial_forward_dynamics
//                              with JRGEN_BENCH_SERIAL_NS: the same model generated
//                              with --threads 1 (the main solver is the parallel one)
//
// Each benchmark carries its accuracy as counters (computed once, before timing,
// on the same M and Q): err = ||qdd - qdd_ref|| / ||qdd_ref|| against an
// extended-precision reference, bwd = ||Q - M qdd|| / (||M||_F ||qdd|| + ||Q||)
// evaluated in long double, and the mutual differences d_gen, d_llt, d_lu.
//
// Environment: JRGEN_BENCH_DENSE_MAX_NV (default 4000): the dense Eigen
// factorizations (and the long-double dense reference) are skipped above this
// size; the reference then comes from iterative refinement (bench_fixture.hpp).
#include <benchmark/benchmark.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <Eigen/SparseCholesky>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "bench_fixture.hpp"
#include JRGEN_BENCH_HEADER
#ifdef JRGEN_BENCH_SERIAL_HEADER
#include JRGEN_BENCH_SERIAL_HEADER
#endif

namespace gen = JRGEN_BENCH_NS;

namespace {

using jrgen::bench::Problem;
using jrgen::bench::relative_difference;

const jrgen::bench::SolverApi kApi = {gen::nq,          gen::nv,          &gen::forward_dynamics,
                                      &gen::solve_augmented, &gen::mass_matrix, &gen::bias_forces};

Problem& problem() {
  static Problem p = jrgen::bench::make_problem(kApi, JRGEN_BENCH_MODEL);
  return p;
}

void add_accuracy(benchmark::State& state, const Problem& p, const Eigen::VectorXd& x) {
  state.counters["nv"] = p.nv;
  state.counters["err"] = p.forward_error(x);
  state.counters["bwd"] = p.backward_error(x);
  if (p.have_gen) state.counters["d_gen"] = relative_difference(x, p.x_gen);
  if (p.have_dense) {
    state.counters["d_llt"] = relative_difference(x, p.x_llt);
    state.counters["d_lu"] = relative_difference(x, p.x_lu);
  }
}

using SolveFn = int (*)(const double*, const double*, const double*, const double*, double*, double*);
using DynamicsFn = int (*)(const double*, const double*, const double*, double*, double*);

void solve_augmented_loop(benchmark::State& state, SolveFn solve) {
  Problem& p = problem();
  Eigen::VectorXd x(p.nv);
  if (solve(p.M.data(), p.Q.data(), nullptr, nullptr, x.data(), nullptr) != 0) {
    state.SkipWithError(gen::last_error());
    return;
  }
  for (auto _ : state) {
    const int status = solve(p.M.data(), p.Q.data(), nullptr, nullptr, x.data(), nullptr);
    benchmark::DoNotOptimize(status);
    benchmark::DoNotOptimize(x.data());
    benchmark::ClobberMemory();
  }
  add_accuracy(state, p, x);
}

void BM_eigen_dense_llt(benchmark::State& state) {
  Problem& p = problem();
  Eigen::LLT<Eigen::MatrixXd> llt(p.nv);
  Eigen::VectorXd x(p.nv);
  for (auto _ : state) {
    llt.compute(p.M);
    x.noalias() = llt.solve(p.Q);
    benchmark::DoNotOptimize(x.data());
    benchmark::ClobberMemory();
  }
  if (llt.info() != Eigen::Success) state.SkipWithError("Eigen LLT failed");
  add_accuracy(state, p, x);
  state.counters["cond1"] = p.cond1_estimate;
}

void BM_eigen_dense_partial_lu(benchmark::State& state) {
  Problem& p = problem();
  Eigen::PartialPivLU<Eigen::MatrixXd> lu(p.nv);
  Eigen::VectorXd x(p.nv);
  for (auto _ : state) {
    lu.compute(p.M);
    x.noalias() = lu.solve(p.Q);
    benchmark::DoNotOptimize(x.data());
    benchmark::ClobberMemory();
  }
  add_accuracy(state, p, x);
}

void BM_eigen_sparse_llt(benchmark::State& state) {
  Problem& p = problem();
  Eigen::SimplicialLLT<Eigen::SparseMatrix<double>, Eigen::Lower> llt;
  llt.analyzePattern(p.M_sparse);  // symbolic analysis (AMD ordering) once, not timed
  Eigen::VectorXd x(p.nv);
  for (auto _ : state) {
    llt.factorize(p.M_sparse);
    x = llt.solve(p.Q);
    benchmark::DoNotOptimize(x.data());
    benchmark::ClobberMemory();
  }
  if (llt.info() != Eigen::Success) state.SkipWithError("Eigen SimplicialLLT failed");
  add_accuracy(state, p, x);
}

void BM_generated_solve_augmented(benchmark::State& state) { solve_augmented_loop(state, &gen::solve_augmented); }

void forward_dynamics_loop(benchmark::State& state, DynamicsFn fd) {
  Problem& p = problem();
  const int n = static_cast<int>(p.states.size());
  Eigen::VectorXd x(p.nv);
  int k = 0;
  for (auto _ : state) {
    const auto& s = p.states[k];
    const int status = fd(s.q.data(), s.v.data(), s.tau.data(), x.data(), nullptr);
    benchmark::DoNotOptimize(status);
    benchmark::DoNotOptimize(x.data());
    benchmark::ClobberMemory();
    k = k + 1 == n ? 0 : k + 1;
  }
  // Accuracy on state 0, the state M and Q were built from.
  const auto& s = p.states[0];
  if (fd(s.q.data(), s.v.data(), s.tau.data(), x.data(), nullptr) != 0) {
    state.SkipWithError(gen::last_error());
    return;
  }
  add_accuracy(state, p, x);
}

void BM_generated_forward_dynamics(benchmark::State& state) { forward_dynamics_loop(state, &gen::forward_dynamics); }

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  const Problem& p = problem();
  benchmark::AddCustomContext("model", JRGEN_BENCH_MODEL);
  benchmark::AddCustomContext("nv", std::to_string(p.nv));
  benchmark::AddCustomContext("nnz_lower_M", std::to_string(p.nnz_lower));
  benchmark::AddCustomContext("reference", p.reference_kind);
  const auto unit = p.nv >= 2000 ? benchmark::kMillisecond : benchmark::kMicrosecond;
  benchmark::RegisterBenchmark("generated_solve_augmented", BM_generated_solve_augmented)->Unit(unit)->UseRealTime();
  if (p.have_dense) {
    benchmark::RegisterBenchmark("eigen_dense_llt", BM_eigen_dense_llt)->Unit(unit)->UseRealTime();
    benchmark::RegisterBenchmark("eigen_dense_partial_lu", BM_eigen_dense_partial_lu)->Unit(unit)->UseRealTime();
  } else {
    std::fprintf(stderr, "nv = %d > JRGEN_BENCH_DENSE_MAX_NV = %d: dense LLT and LU skipped\n", p.nv,
                 p.dense_max_nv);
  }
  benchmark::RegisterBenchmark("eigen_sparse_llt", BM_eigen_sparse_llt)->Unit(unit)->UseRealTime();
  benchmark::RegisterBenchmark("generated_forward_dynamics", BM_generated_forward_dynamics)->Unit(unit)->UseRealTime();
#ifdef JRGEN_BENCH_SERIAL_NS
  // Parallel solvers: wall-clock time (real_time), not the calling thread's CPU time.
  benchmark::RegisterBenchmark("serial_solve_augmented", [](benchmark::State& s) {
    solve_augmented_loop(s, &JRGEN_BENCH_SERIAL_NS::solve_augmented);
  })->Unit(unit)->UseRealTime();
  benchmark::RegisterBenchmark("serial_forward_dynamics", [](benchmark::State& s) {
    forward_dynamics_loop(s, &JRGEN_BENCH_SERIAL_NS::forward_dynamics);
  })->Unit(unit)->UseRealTime();
#endif
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
