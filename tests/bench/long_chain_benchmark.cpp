// The generated forward_dynamics of serial chains of 1000 and 10 000 revolute
// joints (tests/CMakeLists.txt: gen_chain_1000, gen_chain_10000), as a user
// calls it: issue 20 item 3 asks the 10 000-joint chain to take at most 15x
// the time of the 1000-joint chain (O(n); the paper's route is O(n^3) on a
// chain).  Both run in one process, interleaved when run with
// --benchmark_enable_random_interleaving=true --benchmark_repetitions=N.
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "gen_chain_1000.hpp"
#include "gen_chain_10000.hpp"

namespace {

using Dynamics = int (*)(const double*, const double*, const double*, double*, double*);

void chain_forward_dynamics(benchmark::State& state, Dynamics forward_dynamics, int nq, int nv) {
  std::mt19937_64 rng(20261204);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  constexpr int kStates = 8;
  std::vector<std::vector<double>> q(kStates, std::vector<double>(nq)), v = q, tau = q;
  for (int k = 0; k < kStates; ++k)
    for (int i = 0; i < nv; ++i) {
      q[k][i] = u(rng);
      v[k][i] = u(rng);
      tau[k][i] = u(rng);
    }
  std::vector<double> qdd(nv);
  int k = 0, failures = 0;
  for (auto _ : state) {
    failures += forward_dynamics(q[k].data(), v[k].data(), tau[k].data(), qdd.data(), nullptr) != 0;
    benchmark::DoNotOptimize(qdd.data());
    k = (k + 1) % kStates;
  }
  if (failures) state.SkipWithError("forward_dynamics returned a non-zero status");
  state.counters["ns_per_dof"] = benchmark::Counter(static_cast<double>(nv) * state.iterations(),
                                                    benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

BENCHMARK_CAPTURE(chain_forward_dynamics, chain_1000, &gen_chain_1000::forward_dynamics, gen_chain_1000::nq,
                  gen_chain_1000::nv)
    ->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(chain_forward_dynamics, chain_10000, &gen_chain_10000::forward_dynamics, gen_chain_10000::nq,
                  gen_chain_10000::nv)
    ->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
