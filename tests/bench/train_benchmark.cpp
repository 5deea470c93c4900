// Vehicle trains (trains.cmake): the generated solver of a train of
// JRGEN_TRAIN_VEHICLES HMMWVs (27 coordinates and 16 cut rows each, 3 rows
// per hitch), at the zero configuration (assembled by construction), v = 0
// (so Phiq v = 0), tau seeded random:
//   train_forward_dynamics   kinematics, M, h, Phiq, gamma and Steps 1-4
//   train_solve_augmented    Steps 1-4 on given dense M, Q, Phiq, gamma (k <= 37)
// Counters: vehicles, nv, nc (time per coordinate: docs/trains.md).
#include <benchmark/benchmark.h>

#include <Eigen/Dense>
#include <cmath>
#include <vector>

#include "bench_fixture.hpp"
#include JRGEN_TRAIN_HEADER

namespace train = JRGEN_TRAIN_NS;

namespace {

constexpr int kVehicles = JRGEN_TRAIN_VEHICLES;

void train_forward_dynamics(benchmark::State& state) {
  const std::vector<double> q = jrgen::bench::zero_configuration(train::nq, train::njoints, train::joint_q_index),
                            v(train::nv, 0.0);
  std::vector<double> tau(train::nv), qdd(train::nv), lambda(train::nc);
  for (int i = 0; i < train::nv; ++i) tau[i] = std::sin(1.0 + i);
  for (auto _ : state) {
    const int status = train::forward_dynamics(q.data(), v.data(), tau.data(), qdd.data(), lambda.data());
    if (status != 0) state.SkipWithError(train::last_error());
    benchmark::DoNotOptimize(qdd.data());
  }
  state.counters["vehicles"] = kVehicles;
  state.counters["nv"] = train::nv;
  state.counters["nc"] = train::nc;
}
BENCHMARK(train_forward_dynamics)->Unit(benchmark::kMicrosecond);

void train_solve_augmented(benchmark::State& state) {
  if (kVehicles > 37) {
    state.SkipWithError("dense inputs too large (nv^2 doubles)");
    return;
  }
  const std::vector<double> q = jrgen::bench::zero_configuration(train::nq, train::njoints, train::joint_q_index),
                            v(train::nv, 0.0);
  std::vector<double> M(static_cast<std::size_t>(train::nv) * train::nv), h(train::nv), Q(train::nv);
  std::vector<double> Phiq(static_cast<std::size_t>(train::nc) * train::nv), gamma(train::nc);
  std::vector<double> qdd(train::nv), lambda(train::nc);
  train::mass_matrix(q.data(), M.data());
  train::bias_forces(q.data(), v.data(), h.data());
  for (int i = 0; i < train::nv; ++i) Q[i] = std::sin(1.0 + i) - h[i];
  train::constraint_jacobian(q.data(), Phiq.data());
  train::constraint_gamma(q.data(), v.data(), gamma.data());
  for (auto _ : state) {
    const int status = train::solve_augmented(M.data(), Q.data(), Phiq.data(), gamma.data(), qdd.data(), lambda.data());
    if (status != 0) state.SkipWithError(train::last_error());
    benchmark::DoNotOptimize(qdd.data());
  }
  state.counters["vehicles"] = kVehicles;
  state.counters["nv"] = train::nv;
  state.counters["nc"] = train::nc;
}
BENCHMARK(train_solve_augmented)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
