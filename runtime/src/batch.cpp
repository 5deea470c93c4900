// Many runs over threads (jrgen/batch.hpp, docs/simulation.md).
#include "jrgen/batch.hpp"

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>

namespace jrgen::sim {

void parallel_for(std::size_t n, int threads, const std::function<void(std::size_t i)>& work) {
  std::size_t nt = threads > 0 ? static_cast<std::size_t>(threads) : std::thread::hardware_concurrency();
  nt = std::max<std::size_t>(1, std::min(nt, n));
  std::atomic<std::size_t> next{0};
  std::exception_ptr first_error;
  std::mutex error_mutex;
  auto worker = [&] {
    for (std::size_t i; (i = next.fetch_add(1)) < n;) {
      try {
        work(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!first_error) first_error = std::current_exception();
      }
    }
  };
  if (nt == 1) {  // the serial loop, on the calling thread
    worker();
  } else {
    std::vector<std::thread> pool;
    pool.reserve(nt - 1);
    for (std::size_t k = 1; k < nt; ++k) pool.emplace_back(worker);
    worker();
    for (std::thread& th : pool) th.join();
  }
  if (first_error) std::rethrow_exception(first_error);
}

namespace {

// q0 and v0 of a run, checked against the mechanism's sizes.
void check_sizes(const Mechanism& mech, const RunSpec& spec) {
  const System& s = mech.system();
  auto bad = [&spec](const char* what, std::size_t got, int want) {
    return Failure(spec.t0, std::string("run input: ") + what + " has " + std::to_string(got) + " values, the mechanism " +
                            std::to_string(want) + " (give all of them, or none for the default)");
  };
  if (!spec.q0.empty() && spec.q0.size() != static_cast<std::size_t>(s.nq)) throw bad("q0", spec.q0.size(), s.nq);
  if (!spec.v0.empty() && spec.v0.size() != static_cast<std::size_t>(s.nv)) throw bad("v0", spec.v0.size(), s.nv);
}

// Initial state and integration of one run; throws what they throw.
void integrate_run(const Mechanism& mech, const RunSpec& spec, const Settings& settings, const double* default_q0,
                   RunResult& out) {
  check_sizes(mech, spec);
  const System& s = mech.system();
  std::vector<double> zero_q(s.nq, 0.0);
  const double* q0 = !spec.q0.empty() ? spec.q0.data() : default_q0 ? default_q0 : zero_q.data();
  const double* v0 = spec.v0.empty() ? nullptr : spec.v0.data();
  std::vector<double> y = mech.initial_state(q0, v0, &out.assembled);
  out.stats = mech.run(spec.t0, spec.t_end, y, spec.settings ? *spec.settings : settings);
  out.t = out.stats.t;
  out.y = std::move(y);
}

}  // namespace

RunResult run_one(const Mechanism& mech, const RunSpec& spec, const Settings& settings, const double* default_q0) {
  RunResult out;
  try {
    if (spec.forces) {  // this run's forces: a copy of the mechanism (small: tables and pointers)
      Mechanism own = mech;
      own.set_forces(spec.forces);
      integrate_run(own, spec, settings, default_q0, out);
    } else {
      integrate_run(mech, spec, settings, default_q0, out);
    }
    out.status = 0;
  } catch (const Failure& f) {
    out = RunResult{1, f.what(), f.t, {}, {}, out.assembled};
  } catch (const std::exception& e) {
    out = RunResult{1, e.what(), spec.t0, {}, {}, out.assembled};
  } catch (...) {
    out = RunResult{1, "unknown exception", spec.t0, {}, {}, out.assembled};
  }
  return out;
}

std::vector<RunResult> run_batch(const Mechanism& mech, const std::vector<RunSpec>& runs, const Settings& settings,
                                 int threads, const double* default_q0) {
  std::vector<RunResult> results(runs.size());
  parallel_for(runs.size(), threads,
               [&](std::size_t i) { results[i] = run_one(mech, runs[i], settings, default_q0); });
  return results;
}

}  // namespace jrgen::sim
