// jrgen::sim::run_batch (jrgen/batch.hpp): over 1, 2 and 4 threads, bitwise
// the same results as a plain serial loop of initial_state + run; a failing
// run is reported in its slot and the others go on.  Mechanism: the four-bar
// (models/fourbar.urdf, one loop: nq = nv = 3, nc = 2) of simulate_cli_test.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "fourbar_sim_dyn.hpp"
#include "jrgen/batch.hpp"

namespace sim = jrgen::sim;
namespace fb = fourbar_sim;

namespace {

double uniform(std::uint64_t& x) {  // splitmix64, in [-1, 1)
  std::uint64_t z = (x += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return 2.0 * static_cast<double>((z ^ (z >> 31)) >> 11) * 0x1.0p-53 - 1.0;
}

// 24 runs: random v0, t_end in [0.5, 1.5], the integrators in turn (each
// run's own Settings) and joint damping on every third run (its own forces),
// so that runs of different kinds follow each other on one thread.
std::vector<sim::RunSpec> make_runs() {
  const char* methods[] = {"auto", "radau5", "sdirk4", "dopri5"};
  std::vector<sim::RunSpec> runs(24);
  for (std::size_t i = 0; i < runs.size(); ++i) {
    std::uint64_t s = 1000 + i;
    sim::RunSpec& r = runs[i];
    r.q0.assign(fb::q_assembled, fb::q_assembled + fb::nq);
    for (int k = 0; k < fb::nv; ++k) r.v0.push_back(4.0 * uniform(s));
    r.t_end = 1.0 + 0.5 * uniform(s);
    sim::Settings set;
    set.method = methods[i % 4];
    set.rtol = set.atol = 1e-8;
    r.settings = set;
    if (i % 3 == 0)
      r.forces = [](double, const double*, const double* v, double* tau) {
        for (int k = 0; k < fb::nv; ++k) tau[k] = -0.5 * v[k];
      };
  }
  return runs;
}

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

// The reference: each run by hand (no run_one), last run first, so that the
// thread_local buffers carry other histories than in any batch order.
std::vector<sim::RunResult> serial_loop(const sim::Mechanism& mech, const std::vector<sim::RunSpec>& runs) {
  std::vector<sim::RunResult> out(runs.size());
  for (std::size_t i = runs.size(); i-- > 0;) {
    sim::Mechanism m = mech;
    if (runs[i].forces) m.set_forces(runs[i].forces);
    std::vector<double> y = m.initial_state(runs[i].q0.data(), runs[i].v0.data());
    out[i].stats = m.run(runs[i].t0, runs[i].t_end, y, *runs[i].settings);
    out[i].y = y;
    out[i].status = 0;
  }
  return out;
}

}  // namespace

TEST(Batch, ThreadsGiveTheSerialLoopsBits) {
  const sim::Mechanism mech(JRGEN_SIM_SYSTEM(fb));
  const std::vector<sim::RunSpec> runs = make_runs();
  const std::vector<sim::RunResult> ref = serial_loop(mech, runs);
  for (int threads : {1, 2, 4}) {
    const std::vector<sim::RunResult> res = sim::run_batch(mech, runs, sim::Settings{}, threads);
    ASSERT_EQ(res.size(), runs.size());
    for (std::size_t i = 0; i < runs.size(); ++i) {
      SCOPED_TRACE("threads " + std::to_string(threads) + ", run " + std::to_string(i));
      ASSERT_EQ(res[i].status, 0) << res[i].error;
      EXPECT_TRUE(same_bits(res[i].y, ref[i].y));
      EXPECT_EQ(res[i].t, runs[i].t_end);
      EXPECT_EQ(res[i].stats.steps, ref[i].stats.steps);
      EXPECT_EQ(res[i].stats.rejected, ref[i].stats.rejected);
      EXPECT_EQ(res[i].stats.f_calls, ref[i].stats.f_calls);
      EXPECT_LE(mech.phi_norm(res[i].y.data()), 1e-12);  // the projection's phi_tol
    }
  }
  // The runs are not all alike: damped and undamped end at different energies.
  EXPECT_FALSE(same_bits(ref[0].y, ref[1].y));
}

TEST(Batch, AFailingRunDoesNotStopTheOthers) {
  const sim::Mechanism mech(JRGEN_SIM_SYSTEM(fb));
  std::vector<sim::RunSpec> runs = make_runs();
  runs[5].v0[1] = std::numeric_limits<double>::quiet_NaN();  // the solver's status 3 at t = 0
  runs[9].q0.pop_back();                                      // a q0 of the wrong size
  runs[13].settings->method = "euler";                        // an unknown integrator
  const std::vector<sim::RunResult> res = sim::run_batch(mech, runs, sim::Settings{}, 2);
  for (std::size_t i = 0; i < runs.size(); ++i) {
    SCOPED_TRACE("run " + std::to_string(i));
    if (i == 5 || i == 9 || i == 13) {
      EXPECT_EQ(res[i].status, 1);
      EXPECT_TRUE(res[i].y.empty());
    } else {
      EXPECT_EQ(res[i].status, 0) << res[i].error;
      EXPECT_EQ(res[i].t, runs[i].t_end);
    }
  }
  EXPECT_NE(res[5].error.find("non-finite"), std::string::npos) << res[5].error;
  EXPECT_NE(res[9].error.find("q0 has 2 values, the mechanism 3"), std::string::npos) << res[9].error;
  EXPECT_NE(res[13].error.find("unknown integrator 'euler'"), std::string::npos) << res[13].error;
}

TEST(Batch, ParallelForVisitsEachIndexOnceAndRethrows) {
  std::vector<int> seen(1000, 0);
  sim::parallel_for(seen.size(), 4, [&](std::size_t i) { seen[i] += 1; });
  for (int s : seen) EXPECT_EQ(s, 1);
  EXPECT_THROW(sim::parallel_for(10, 2,
                                 [](std::size_t i) {
                                   if (i == 7) throw std::runtime_error("seven");
                                 }),
               std::runtime_error);
  sim::parallel_for(0, 4, [](std::size_t) { FAIL() << "called for n = 0"; });
}
