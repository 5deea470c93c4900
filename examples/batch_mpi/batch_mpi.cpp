// Many runs of the four-bar (models/fourbar.urdf) over MPI ranks and threads
// (docs/simulation.md, "Many runs: threads and MPI").
//
//   mpirun -np 2 jrgen_batch_mpi --runs 128 --threads 2 --output runs.csv
//   jrgen_batch_mpi --serial --runs 128 --output serial.csv    (1 rank, plain loop)
//
// Run i starts from the assembled configuration with a random velocity and
// ends at a random time, both drawn from splitmix64 streams seeded by
// (--seed, i) alone: the same on every rank, thread and machine.  Ranks take
// contiguous blocks of run indices (static block distribution, rank r:
// [r N / P, (r + 1) N / P)), run them with jrgen::sim::run_batch over
// --threads threads, format one CSV line per run (%.17g: doubles round-trip)
// and rank 0 gathers the lines in rank order, i.e. in run order.  The CSV is
// therefore byte for byte the same for any number of ranks and threads;
// tests/simulate/check_batch_mpi.cmake checks this.
//
// CSV: run,status,t,q0,...,v0,...,energy,phi_norm,phiqv_norm,steps,rejected,fd_calls,error
// (status 0: reached its t_end; 1: failed, error = the one-line message and
// the state fields empty; --nan-run K makes run K fail, the others go on).  Timing goes to stdout (rank 0), not to the CSV.
#include <mpi.h>

#include <cerrno>
#include <cmath>
#include <chrono>
#include <cinttypes>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "batch_fourbar.hpp"
#include <jrgen/batch.hpp>

namespace {

namespace sim = jrgen::sim;

struct Options {
  long runs = 128;
  int threads = 1;
  double t_end = 2.0;
  std::uint64_t seed = 1;
  double v_max = 5.0;
  bool serial = false;
  long nan_run = -1;  ///< --nan-run K: run K gets a NaN in v0 (a failing run, for the test)
  std::string output = "runs.csv";
  sim::Settings settings;
};

[[noreturn]] void usage(const char* msg) {
  std::fprintf(stderr,
               "jrgen_batch_mpi: error: %s\nusage: jrgen_batch_mpi [--runs N] [--threads T] [--t-end T] "
               "[--seed S] [--v-max V] [--integrator M] [--rtol R] [--atol A] [--serial] [--nan-run K] [--output FILE.csv]\n",
               msg);
  MPI_Abort(MPI_COMM_WORLD, 2);
  std::exit(2);
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--serial") {
      o.serial = true;
      continue;
    }
    if (i + 1 >= argc) usage(("option " + a + " needs a value").c_str());
    const char* v = argv[++i];
    if (a == "--runs") o.runs = std::atol(v);
    else if (a == "--threads") o.threads = std::atoi(v);
    else if (a == "--t-end") o.t_end = std::atof(v);
    else if (a == "--seed") o.seed = std::strtoull(v, nullptr, 10);
    else if (a == "--v-max") o.v_max = std::atof(v);
    else if (a == "--integrator") o.settings.method = v;
    else if (a == "--rtol") o.settings.rtol = std::atof(v);
    else if (a == "--atol") o.settings.atol = std::atof(v);
    else if (a == "--output") o.output = v;
    else if (a == "--nan-run") o.nan_run = std::atol(v);
    else usage(("unknown option " + a).c_str());
  }
  if (o.runs < 1 || o.threads < 1 || !(o.t_end > 0.0)) usage("--runs and --threads must be >= 1, --t-end > 0");
  return o;
}

// splitmix64 (Steele, Lea & Flood 2014): a well-defined stream per (seed, run).
std::uint64_t splitmix64(std::uint64_t& x) {
  std::uint64_t z = (x += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}
double uniform01(std::uint64_t& x) { return static_cast<double>(splitmix64(x) >> 11) * 0x1.0p-53; }

// Run i: random v0 in [-v_max, v_max]^nv and t_end in [t_end / 2, t_end].
sim::RunSpec make_run(const Options& o, long i) {
  std::uint64_t state = o.seed * 0x100000001b3ULL ^ static_cast<std::uint64_t>(i);
  splitmix64(state);
  sim::RunSpec r;
  r.q0.assign(batch_fourbar::q_assembled, batch_fourbar::q_assembled + batch_fourbar::nq);
  for (int k = 0; k < batch_fourbar::nv; ++k) r.v0.push_back(o.v_max * (2.0 * uniform01(state) - 1.0));
  r.t_end = o.t_end * (0.5 + 0.5 * uniform01(state));
  if (i == o.nan_run) r.v0[0] = std::nan("");
  return r;
}

void append_g(std::string& s, double x) {
  char buf[40];
  std::snprintf(buf, sizeof buf, ",%.17g", x);
  s += buf;
}

std::string csv_header() {
  std::string h = "run,status,t";
  for (int k = 0; k < batch_fourbar::nq; ++k) h += ",q" + std::to_string(k);
  for (int k = 0; k < batch_fourbar::nv; ++k) h += ",v" + std::to_string(k);
  return h + ",energy,phi_norm,phiqv_norm,steps,rejected,fd_calls,error\n";
}

// One CSV line; the error message quoted (it may hold commas), '"' doubled.
std::string csv_line(const sim::Mechanism& mech, long i, const sim::RunResult& r) {
  std::string s = std::to_string(i) + "," + std::to_string(r.status);
  append_g(s, r.t);
  const int n = mech.size();
  if (r.status == 0) {
    for (int k = 0; k < n; ++k) append_g(s, r.y[k]);
    append_g(s, mech.energy(r.y.data()));
    append_g(s, mech.phi_norm(r.y.data()));
    append_g(s, mech.phiqv_norm(r.y.data()));
  } else {
    s += std::string(static_cast<std::size_t>(n) + 3, ',');
  }
  s += "," + std::to_string(r.stats.steps) + "," + std::to_string(r.stats.rejected) + "," +
       std::to_string(r.stats.f_calls) + ",\"";
  for (char c : r.error) s += (c == '"') ? std::string("\"\"") : std::string(1, c);
  return s + "\"\n";
}

// Rank 0 receives every rank's text, in rank order.
std::string gather_text(const std::string& mine, int rank, int size) {
  const int len = static_cast<int>(mine.size());
  std::vector<int> lens(size), offs(size);
  MPI_Gather(&len, 1, MPI_INT, lens.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
  std::string all;
  if (rank == 0) {
    long total = 0;
    for (int r = 0; r < size; ++r) {
      offs[r] = static_cast<int>(total);
      total += lens[r];
    }
    all.resize(static_cast<std::size_t>(total));
  }
  MPI_Gatherv(mine.data(), len, MPI_CHAR, all.data(), lens.data(), offs.data(), MPI_CHAR, 0, MPI_COMM_WORLD);
  return all;
}

}  // namespace

int main(int argc, char** argv) {
  int provided = 0, rank = 0, size = 1;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);  // only this thread calls MPI
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  const Options o = parse(argc, argv);
  if (o.serial && size != 1) usage("--serial is the 1-rank reference: run it without mpirun or with -np 1");

  const sim::Mechanism mech(JRGEN_SIM_SYSTEM(batch_fourbar));
  // This rank's block of run indices.
  const long lo = o.runs * rank / size, hi = o.runs * (rank + 1) / size;
  std::vector<sim::RunSpec> runs;
  for (long i = lo; i < hi; ++i) runs.push_back(make_run(o, i));

  MPI_Barrier(MPI_COMM_WORLD);
  const auto t_start = std::chrono::steady_clock::now();
  std::vector<sim::RunResult> results;
  if (o.serial) {  // the reference: a plain loop, one run after the other
    for (const sim::RunSpec& r : runs) results.push_back(sim::run_one(mech, r, o.settings));
  } else {
    results = sim::run_batch(mech, runs, o.settings, o.threads);
  }
  std::string text;
  long failed = 0, fd_calls = 0;
  for (std::size_t k = 0; k < results.size(); ++k) {
    text += csv_line(mech, lo + static_cast<long>(k), results[k]);
    failed += results[k].status != 0;
    fd_calls += results[k].stats.f_calls;
  }
  const std::string all = gather_text(text, rank, size);
  long totals[2] = {failed, fd_calls}, sums[2] = {0, 0};
  MPI_Reduce(totals, sums, 2, MPI_LONG, MPI_SUM, 0, MPI_COMM_WORLD);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();

  int rc = 0;
  if (rank == 0) {
    std::FILE* f = std::fopen(o.output.c_str(), "wb");
    if (!f || std::fputs(csv_header().c_str(), f) < 0 || std::fwrite(all.data(), 1, all.size(), f) != all.size() ||
        std::fclose(f) != 0) {
      std::fprintf(stderr, "jrgen_batch_mpi: error: cannot write %s: %s\n", o.output.c_str(), std::strerror(errno));
      rc = 1;
    }
    std::printf("runs=%ld failed=%ld ranks=%d threads=%d fd_calls=%ld wall_s=%.3f output=%s\n", o.runs, sums[0],
                size, o.serial ? 1 : o.threads, sums[1], wall, o.output.c_str());
  }
  MPI_Finalize();
  return rc;
}
