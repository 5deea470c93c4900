// forward_dynamics against size, every model in one process (issue "First
// benchmark": time linear in DOF on bounded-depth trees, 10000 vs 1000 DOF at
// most 12x; issue 4: linear in DOF on bounded-depth trees and vehicle
// trains).  The solvers are the same generated libraries as the per-model
// programs (tests/bench/CMakeLists.txt, bench_scaling).  Run it with
// --benchmark_enable_random_interleaving=true and repetitions (as for
// docs/benchmarks.md, run 3): the sizes then run interleaved in random order,
// so a drift of the machine's clock hits every size alike and the ratios
// between sizes are meaningful even where the absolute times wander.
// Accuracy of the same solvers on the same kind of states: the err counters
// of bench_<model> (docs/benchmarks.md).
//
// Each benchmark cycles through 16 seeded random states (q, v, tau uniform in
// [-1, 1]; quaternions are normalized by the solver), as bench_<model> does;
// the vehicle trains (closed loops) take the assembled zero configuration at
// rest with random tau, as bench_train_<k> does.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <random>
#include <string>
#include <vector>

#include "bench_fixture.hpp"

#include "scaling_solvers.hpp"  // written by CMake: JRGEN_SCALING_SOLVERS(X)

namespace {

struct Solver {
  const char* name;
  int nq, nv, nc, njoints;
  const int* joint_q_index;
  int (*forward_dynamics)(const double*, const double*, const double*, double*, double*);
};

struct States {
  std::vector<std::vector<double>> q, v, tau;
};

States make_states(const Solver& s) {
  std::mt19937_64 rng(20261201);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  States st;
  for (int k = 0; k < 16; ++k) {
    std::vector<double> q(s.nq), v(s.nv), tau(s.nv);
    for (double& x : q) x = u(rng);
    for (double& x : v) x = u(rng);
    for (double& x : tau) x = u(rng);
    if (s.nc > 0) {
      // Closed loops (the trains): the assembled zero configuration, at
      // rest, as bench_train_<k>; a random q would not close the hitches.
      q = jrgen::bench::zero_configuration(s.nq, s.njoints, s.joint_q_index);
      std::fill(v.begin(), v.end(), 0.0);
    }
    st.q.push_back(std::move(q));
    st.v.push_back(std::move(v));
    st.tau.push_back(std::move(tau));
  }
  return st;
}

void forward_dynamics(benchmark::State& state, Solver s) {
  const States st = make_states(s);
  std::vector<double> qdd(s.nv), lambda(s.nc);
  std::size_t k = 0;
  for (auto _ : state) {
    const int status =
        s.forward_dynamics(st.q[k].data(), st.v[k].data(), st.tau[k].data(), qdd.data(), lambda.data());
    benchmark::DoNotOptimize(status);
    benchmark::DoNotOptimize(qdd.data());
    benchmark::ClobberMemory();
    if (status != 0) state.SkipWithError("forward_dynamics failed");
    k = (k + 1) % st.q.size();
  }
  state.counters["nv"] = s.nv;
  state.counters["time_per_dof"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * s.nv,
      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

#define JRGEN_SCALING_ENTRY(ns, label) \
  Solver{label, ns::nq, ns::nv, ns::nc, ns::njoints, ns::joint_q_index, &ns::forward_dynamics},
const Solver kSolvers[] = {JRGEN_SCALING_SOLVERS(JRGEN_SCALING_ENTRY)};

int register_all() {
  for (const Solver& s : kSolvers)
    benchmark::RegisterBenchmark((std::string("forward_dynamics/") + s.name).c_str(), forward_dynamics, s)
        ->UseRealTime();
  return 0;
}
const int kRegistered = register_all();

}  // namespace

BENCHMARK_MAIN();
