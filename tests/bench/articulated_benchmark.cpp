// The runtime's articulated-body route (jrgen/articulated.hpp, issue 20 item
// 2) on serial revolute chains of 1000 and 10 000 joints, for the issue's
// goal: the 10 000-joint chain at most 15x the time of the 1000-joint one
// (O(n); the paper's route is O(n^3) on a chain).  Timed per size:
//   kinematics+articulated  jr::kinematics then jr::articulated_dynamics
//                           (what forward_dynamics of a tree would call);
//   articulated             jr::articulated_dynamics alone;
//   solve                   one jr::articulated_solve (M^-1 f, loops' columns);
//   papers_route/1000       for scale: kinematics, M (eq. 14, 18), h, the
//                           table-driven Steps 1, 2, 4 on the 1000-joint chain.
// Run with --benchmark_enable_random_interleaving=true and repetitions so
// that a drift of the machine's clock hits both sizes alike.  States: 16
// seeded random (q, v, tau) uniform in [-1, 1], cycled, as bench_scaling.
#include <benchmark/benchmark.h>

#include <jrgen/articulated.hpp>

#include <memory>
#include <random>
#include <string>
#include <vector>

#include "analysis/runtime_model.hpp"
#include "common/random_model.hpp"
#include "topology/topology.hpp"
#include "urdf/urdf_reader.hpp"

namespace {

struct Chain {
  jrgen::ir::Robot robot;
  jrgen::topology::Tree tree;
  std::unique_ptr<jrgen::analysis::RuntimeModel> rt;
  std::vector<jr::ArticulatedState> work;
  std::vector<std::vector<double>> q, v, tau;

  explicit Chain(int joints)
      : robot(jrgen::urdf::read_robot_string(jrgen::testing::chain_urdf(joints, 104), "chain.urdf")),
        tree(jrgen::topology::build_tree(robot)),
        rt(std::make_unique<jrgen::analysis::RuntimeModel>(tree, Eigen::Vector3d(0.0, 0.0, -9.81))),
        work(tree.bodies.size()) {
    std::mt19937_64 rng(20261204);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int k = 0; k < 16; ++k) {
      std::vector<double> qk(tree.nq), vk(tree.nv), tk(tree.nv);
      for (double& x : qk) x = u(rng);
      for (double& x : vk) x = u(rng);
      for (double& x : tk) x = u(rng);
      q.push_back(qk);
      v.push_back(vk);
      tau.push_back(tk);
    }
  }
};

// One chain per size for the whole process (building the 10 000-joint one
// reads a 10 000-joint URDF).
Chain& chain(int joints) {
  static std::unique_ptr<Chain> c1000, c10000;
  std::unique_ptr<Chain>& c = joints == 1000 ? c1000 : c10000;
  if (!c) c = std::make_unique<Chain>(joints);
  return *c;
}

void set_counters(benchmark::State& state, int nv) {
  state.counters["nv"] = nv;
  state.counters["time_per_dof"] = benchmark::Counter(static_cast<double>(state.iterations()) * nv,
                                                      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void kinematics_articulated(benchmark::State& state, int joints, bool with_kinematics) {
  Chain& c = chain(joints);
  const jr::Model& m = c.rt->model();
  std::vector<double> qdd(m.nv), pivots(m.nv);
  jr::kinematics(m, c.rt->workspace(), c.q[0].data());
  std::size_t k = 0;
  for (auto _ : state) {
    if (with_kinematics) jr::kinematics(m, c.rt->workspace(), c.q[k].data());
    const std::int32_t status = jr::articulated_dynamics<true, true>(m, c.rt->workspace(), c.work.data(),
                                                                     c.v[k].data(), c.tau[k].data(), qdd.data(),
                                                                     pivots.data());
    benchmark::DoNotOptimize(status);
    benchmark::DoNotOptimize(qdd.data());
    benchmark::ClobberMemory();
    if (status >= 0) state.SkipWithError("articulated_dynamics: pivot not positive");
    k = (k + 1) % c.q.size();
  }
  set_counters(state, m.nv);
}

void solve(benchmark::State& state, int joints) {
  Chain& c = chain(joints);
  const jr::Model& m = c.rt->model();
  std::vector<double> qdd(m.nv), pivots(m.nv), x(m.nv);
  jr::kinematics(m, c.rt->workspace(), c.q[0].data());
  if (jr::articulated_dynamics<true, true>(m, c.rt->workspace(), c.work.data(), c.v[0].data(), c.tau[0].data(),
                                           qdd.data(), pivots.data()) >= 0)
    state.SkipWithError("articulated_dynamics: pivot not positive");
  std::size_t k = 0;
  for (auto _ : state) {
    x = c.tau[k];
    jr::articulated_solve(m, c.rt->workspace(), c.work.data(), x.data());
    benchmark::DoNotOptimize(x.data());
    benchmark::ClobberMemory();
    k = (k + 1) % c.q.size();
  }
  set_counters(state, m.nv);
}

// The paper's route through the runtime (the table-driven Steps 1, 2, 4 of
// large generated solvers): O(n^2) entries of M, O(n^3) to factor a chain.
void papers_route(benchmark::State& state, int joints) {
  Chain& c = chain(joints);
  const jr::Model& m = c.rt->model();
  const std::int32_t nnz = m.M_col_start[m.nv];
  std::vector<double> L(nnz), Dinv(m.nv), z(m.nv);
  std::vector<std::int32_t> entry_row(nnz), row_start(m.nv + 1), row_entry(nnz - m.nv), row_col(nnz - m.nv);
  jr::fill_packed_rows(m, entry_row.data(), row_start.data(), row_entry.data(), row_col.data());
  const jr::PackedRows rows{entry_row.data(), row_start.data(), row_entry.data(), row_col.data()};
  std::size_t k = 0;
  for (auto _ : state) {
    jr::kinematics(m, c.rt->workspace(), c.q[k].data());
    jr::mass_matrix_packed(m, c.rt->workspace(), L.data());
    jr::bias_forces<true, true>(m, c.rt->workspace(), c.v[k].data(), z.data());
    for (std::int32_t j = 0; j < m.nv; ++j) z[j] = c.tau[k][m.dof_user[j]] - z[j];
    double pivot = 0.0;
    if (jr::factor_packed(m, L.data(), Dinv.data(), true, 0.0, &pivot) >= 0) state.SkipWithError("pivot");
    jr::forward_packed(m, rows, L.data(), Dinv.data(), true, z.data());
    jr::backward_packed(m, rows, L.data(), Dinv.data(), true, z.data());
    benchmark::DoNotOptimize(z.data());
    benchmark::ClobberMemory();
    k = (k + 1) % c.q.size();
  }
  set_counters(state, m.nv);
}

int register_all() {
  for (int joints : {1000, 10000}) {
    const std::string n = std::to_string(joints);
    benchmark::RegisterBenchmark(("kinematics+articulated/" + n).c_str(), kinematics_articulated, joints, true)
        ->UseRealTime();
    benchmark::RegisterBenchmark(("articulated/" + n).c_str(), kinematics_articulated, joints, false)
        ->UseRealTime();
    benchmark::RegisterBenchmark(("solve/" + n).c_str(), solve, joints)->UseRealTime();
  }
  benchmark::RegisterBenchmark("papers_route/1000", papers_route, 1000)->UseRealTime()->Unit(benchmark::kMillisecond);
  return 0;
}
const int kRegistered = register_all();

}  // namespace

BENCHMARK_MAIN();
