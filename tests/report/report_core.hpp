// The solver report (docs/report.md): every method of eq. (17) on the same
// M, Q = tau - h, Phiq and gamma of one model, timed with Google Benchmark and
// checked against an extended-precision solve.  One program per model
// (report_main.cpp, compiled with the model's two generated solvers); this
// library does everything else.
#pragma once

namespace jrgen::report {

/// The generated API (docs/interface.md section 4) of one solver, as plain pointers.
struct GeneratedApi {
  int nq, nv, nc, njoints;
  int (*forward_dynamics)(const double* q, const double* v, const double* tau, double* qdd, double* lambda);
  int (*solve_augmented)(const double* M, const double* Q, const double* Phiq, const double* gamma,
                         double* qdd, double* lambda);
  void (*mass_matrix)(const double* q, double* M);
  void (*bias_forces)(const double* q, const double* v, double* h);
  void (*constraints)(const double* q, double* phi);
  void (*constraint_jacobian)(const double* q, double* Phiq);
  void (*constraint_gamma)(const double* q, const double* v, double* gamma);
  const char* (*last_error)();
  /// The opt-in JRGEN_EXPOSE_STEPS hook of the templates: gathers the inputs
  /// as solve_augmented does, then runs the steps up to `last` (0: gather
  /// only; 1: Step 1; 2: Step 2; 3..7: Steps 3.1..3.5; 8: Step 4).
  int (*solve_steps)(const double* M, const double* Q, const double* Phiq, const double* gamma, int last);
};

struct ModelInfo {
  const char* name;  ///< the model's name in tests/report/models.txt
  const char* urdf;  ///< its URDF file (read again for the topology tables and MuJoCo)
  const char* cuts;  ///< its --cuts file, or ""
};

/// Parses the report options (--quick, --check, --json FILE, --no-mujoco),
/// builds the problem, registers and runs the benchmarks, checks the errors.
/// Returns the process exit status: 0, or 1 when a check failed.
int run(int argc, char** argv, const ModelInfo& model, const GeneratedApi& llt, const GeneratedApi& ldlt);

}  // namespace jrgen::report
