// Many runs of one generated mechanism over threads (docs/simulation.md,
// "Many runs: threads and MPI"; issue 21 item 5).
//
//   jrgen::sim::Mechanism mech(JRGEN_SIM_SYSTEM(fourbar));
//   std::vector<jrgen::sim::RunSpec> runs(256);
//   for (auto& r : runs) { r.q0 = ...; r.v0 = ...; r.t_end = 2.0; }
//   jrgen::sim::Settings s;  s.rtol = 1e-8;
//   std::vector<jrgen::sim::RunResult> res = jrgen::sim::run_batch(mech, runs, s, 4);
//
// Each run is Mechanism::initial_state(q0, v0) followed by Mechanism::run()
// from t0 to t_end: deterministic, and it writes only its own result slot,
// so the results do not depend on the number of threads nor on which thread
// took which run (the generated solver's workspace and the integrator's
// buffers are thread_local and fully overwritten before use).  A run that
// fails (a Failure, or any other exception) is reported in its slot
// (status 1, error = the message) and the other runs go on.
//
// Ranks across machines: examples/batch_mpi/ splits the runs into blocks by
// run index and calls run_batch() on each rank's block.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "jrgen/simulate.hpp"

namespace jrgen::sim {

/// Joint forces tau(t, q, v) of one run (nv entries).
using Forces = std::function<void(double t, const double* q, const double* v, double* tau)>;

/// One run: initial state, interval and optional per-run parameters.
struct RunSpec {
  std::vector<double> q0;  ///< nq values (empty: the Mechanism's default q, see run_batch)
  std::vector<double> v0;  ///< nv values (empty: zero), projected onto Phiq v = 0
  double t0 = 0.0, t_end = 1.0;
  std::optional<Settings> settings;  ///< this run's integrator settings (default: run_batch's)
  Forces forces;                     ///< this run's joint forces (default: the Mechanism's)
};

/// The outcome of one run.
struct RunResult {
  int status = -1;           ///< 0: reached t_end; 1: failed (error set); -1: not run
  std::string error;         ///< one line (Failure::what()), empty on success
  double t = 0.0;            ///< time reached (failure: the time of the failure)
  std::vector<double> y;     ///< final state (q, v) (failure: empty)
  Stats stats;               ///< counters of Mechanism::run (failure: zero)
  bool assembled = false;    ///< q0 did not close the loops and was assembled
};

/// Calls work(i) for i = 0 .. n-1 over `threads` std::threads (0: the
/// hardware's concurrency, at least 1; never more than n), each index once;
/// threads take the next index from a shared counter.  work must write only
/// to its own index's data.  An exception escaping work(i) is rethrown after
/// all threads joined (run_batch never lets one escape).
void parallel_for(std::size_t n, int threads, const std::function<void(std::size_t i)>& work);

/// One run as run_batch does it (the serial reference).  `default_q0`: the
/// q of a RunSpec with an empty q0 (nullptr: zero, which is no unit
/// quaternion: pass the generated q_assembled for ball or floating joints).
RunResult run_one(const Mechanism& mech, const RunSpec& spec, const Settings& settings,
                  const double* default_q0 = nullptr);

/// All runs over `threads` threads; results in run order.  Input errors
/// (a q0 or v0 of the wrong size) are reported in the run's slot as well.
std::vector<RunResult> run_batch(const Mechanism& mech, const std::vector<RunSpec>& runs,
                                 const Settings& settings, int threads = 0,
                                 const double* default_q0 = nullptr);

}  // namespace jrgen::sim
