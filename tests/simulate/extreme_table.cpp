// Prints the table of docs/simulation.md, "Extreme cases in time": every
// case of extreme_cases.hpp x {dopri5, radau5, sdirk4, auto} x tolerances,
// with the error against the exact solution or the reference run, energy
// (and invariant) drift, constraint drift, counters, CPU time, or the named
// failure.  Not a test (it takes about a minute):
//   cmake --build build --target simulate_extreme_table && build/tests/simulate_extreme_table
// Optional argument: a substring of the case names to run only those.
#include <cstdio>
#include <string>

#include "extreme_cases.hpp"

using namespace jrgen::extreme;

namespace {

const char* const kMethods[] = {"dopri5", "radau5", "sdirk4", "auto"};
const double kTols[] = {1e-4, 1e-7, 1e-10};

std::string fmt(double x) {
  if (std::isnan(x)) return "-";
  char b[32];
  std::snprintf(b, sizeof b, "%.1e", x);
  return b;
}

// The number of a failure message in the list below the table (1-based;
// a message already listed keeps its number).
size_t note(std::vector<std::string>& failures, const std::string& what) {
  for (size_t i = 0; i < failures.size(); ++i)
    if (failures[i] == what) return i + 1;
  failures.push_back(what);
  return failures.size();
}

// One cell of the compact table: error / energy drift / fd_calls / CPU ms, or the
// failure's status and time (the message is listed below the table).
std::string cell(const Result& r, std::vector<std::string>& failures) {
  std::string out;
  if (!r.ok) {
    out = "**failed** at t = " + fmt(r.t_fail) + " (" + std::to_string(note(failures, r.failure)) + ")";
  } else {
    char ms[32];
    std::snprintf(ms, sizeof ms, "%.3g", 1e3 * r.cpu_s);
    out = fmt(r.err) + " / " + fmt(r.e_drift) + " / " + std::to_string(r.st.f_calls) + " / " + ms;
    if (r.st.switches) out += " (sw)";
  }
  if (r.nonfinite) out += " NON-FINITE OUTPUT";
  return out;
}

void full_row(const Case& c, const char* method, double tol, const Result& r) {
  std::printf("| %s | %s | %.0e | %s | %s | %s | %s | %s | %ld (%ld) | %ld | %ld | %s | %s |\n", c.name.c_str(), method,
              tol, fmt(r.err).c_str(), fmt(r.e_drift).c_str(), fmt(r.inv_drift).c_str(), fmt(r.phi).c_str(),
              fmt(r.phiqv).c_str(), r.st.steps, r.st.rejected, r.st.f_calls, r.st.switches, fmt(r.cpu_s).c_str(),
              r.ok ? "" : r.failure.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  std::string only;
  bool full = false;
  for (int i = 1; i < argc; ++i) {
    if (std::string(argv[i]) == "--full") full = true;
    else only = argv[i];
  }
  const Case cases[] = {light_tip_1e6(), light_tip_1e9(), light_tip_1e12(), light_tip_1e15(), heavy_tip_1e6(),
                        heavy_tip_1e9(), spring_1e9(),
                        point_spring_1e9(), rope50(), rope50(M_PI / 2), parallelogram(false), parallelogram(true),
                        parallelogram(false, true), parallelogram(true, true),
                        near_toggle(), top(100), top(1000), top(10000)};
  if (full)
    std::printf("| case | integrator | tol | error | energy drift | L_z drift | max abs Phi | max abs Phiq v | steps "
                "(rejected) | fd_calls | switched | CPU s | failure |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  else
    std::printf("| case (reference) | tol | dopri5 | radau5 | sdirk4 | auto | max abs Phi, Phiq v |\n"
                "|---|---|---|---|---|---|---|\n");
  std::vector<std::string> failures;
  for (const Case& c : cases) {
    if (!only.empty() && c.name.find(only) == std::string::npos) continue;
    Vec ref;
    std::string what = "exact";
    try {
      ref = reference(c);
      if (!ref.empty()) what = "CVODE, reference/" + c.ref_file + ".tsv";
    } catch (const std::exception& e) {
      what = "no reference (" + std::to_string(note(failures, e.what())) + ")";
      ref.assign(c.sys.nq, 0.0);
    }
    for (double tol : kTols) {
      std::string line = "| " + c.name + " (" + what + ") | " + fmt(tol);
      double phi = 0.0, phiqv = 0.0;
      for (const char* method : kMethods) {
        const Result r = measure(c, method, tol, &ref);
        if (full) full_row(c, method, tol, r);
        line += " | " + cell(r, failures);
        phi = std::max(phi, r.phi);
        phiqv = std::max(phiqv, r.phiqv);
      }
      line += c.sys.nc == 0 ? " | (tree)" : " | " + fmt(phi) + ", " + fmt(phiqv);
      if (!full) std::printf("%s |\n", line.c_str());
      std::fflush(stdout);
    }
  }
  if (!full)
    for (size_t i = 0; i < failures.size(); ++i) std::printf("\n(%zu) `%s`\n", i + 1, failures[i].c_str());
}
