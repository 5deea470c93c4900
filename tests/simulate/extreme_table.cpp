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

std::string fmt(double x) {
  if (std::isnan(x)) return "-";
  char b[32];
  std::snprintf(b, sizeof b, "%.1e", x);
  return b;
}

void row(const Case& c, const char* method, double tol, const Vec& ref) {
  const Result r = measure(c, method, tol, ref.empty() ? nullptr : &ref);
  std::string tail;
  if (!r.ok) {
    std::string f = r.failure;
    if (f.size() > 160) f = f.substr(0, 157) + "...";
    tail = "failed: `" + f + "`";
  }
  if (r.nonfinite) tail += " NON-FINITE OUTPUT";
  std::printf("| %s | %s | %.0e | %s | %s | %s | %s | %s | %ld (%ld) | %ld | %ld | %s | %s |\n", c.name.c_str(), method,
              tol, fmt(r.err).c_str(), fmt(r.e_drift).c_str(), fmt(r.inv_drift).c_str(), fmt(r.phi).c_str(),
              fmt(r.phiqv).c_str(), r.st.steps, r.st.rejected, r.st.f_calls, r.st.switches, fmt(r.cpu_s).c_str(),
              tail.c_str());
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  const std::string only = argc > 1 ? argv[1] : "";
  const Case cases[] = {light_tip_1e6(), light_tip_1e9(), heavy_tip_1e6(), light_tip_1e15(), spring_1e9(),
                        point_spring_1e9(), rope50(), parallelogram(false), parallelogram(true), near_toggle(),
                        top(100), top(1000)};
  std::printf("| case | integrator | tol | error | energy drift | L_z drift | max abs Phi | max abs Phiq v | steps "
              "(rejected) | fd_calls | switched | CPU s | outcome |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Case& c : cases) {
    if (!only.empty() && c.name.find(only) == std::string::npos) continue;
    Vec ref;
    try {
      ref = reference(c);
    } catch (const jrgen::sim::Failure& f) {
      std::printf("| %s | reference %s | %.0e | | | | | | | | | | failed: `%s` |\n", c.name.c_str(),
                  c.ref_method.c_str(), c.ref_tol, f.what());
      continue;
    }
    for (const char* method : {"dopri5", "radau5", "sdirk4", "auto"})
      for (double tol : {1e-4, 1e-7, 1e-10}) row(c, method, tol, ref);
  }
}
